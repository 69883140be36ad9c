"""Studies: definition files, the runner and its self-describing output folder.

A **study** is a TOML file (``runs/<name>/study.toml``; the built-in default is
``design/studies/humber.toml``, the paper's full reproduction) naming the bridge, the
analyses and their options::

    name = "humber"
    bridge = "humber"                       # built-in name or bridge .toml (relative to the file)
    analyses = ["modes", "frequency_ratio", "flutter", "erection", "buffeting", "sensitivity",
                "design"]
    [quick]                                  # applied by --quick (what CI runs)
    element_length_m = 47.0                  # coarser mesh
    [flutter]
    speeds = "0:100:0.5"
    modes = 16
    quick = { speeds = "0:100:1", modes = 10 }   # per-analysis quick overrides

:func:`run_study` writes everything into a temporary sibling folder of the target and moves it
into place only when complete (an earlier result folder is kept until then), so an interrupted
or failed run never leaves half-written results. Each analysis failure is recorded with its
status; bad input raises :class:`~bridgeflap.model.errors.BridgeflapInputError` before anything is
written: the whole configuration (every analysis's options, the bridge) is validated first, then the
output folder is checked (:func:`bridgeflap.design.io.outputs.check_replaceable`: a non-empty folder
that no bridgeflap run marked as its own is refused), then the run takes the folder's lock
(:func:`bridgeflap.design.io.outputs.claim_output`: a second concurrent run is refused; what a
crashed run left is recovered or cleaned) and only then creates anything. The replace itself is
crash-safe (:func:`bridgeflap.design.io.outputs.swap_into_place`).

Output folder::

    .bridgeflap-output  marker: this folder is a bridgeflap output
    (bridgeflap.design.io.outputs.OUTPUT_MARKER) config.json      resolved configuration (quick
    overrides applied) manifest.json    time, host, versions, git commit
    (bridgeflap.design.io.manifest.build_manifest) statuses.json    analysis -> status (and every
    solver status inside it) results/<analysis>.json, results/<analysis>.npz (arrays)
    figures/<analysis>.png
    report.md        comparison with the paper: Table 1, 65/74 m/s, Figs. 2-5
    report.html      the same, self-contained (figures inline)
    summary.json     the ``bridgeflap study --json`` payload

The analyses and their defaults are those of the registry
:data:`bridgeflap.design.studies.analyses.ANALYSES`; an option a study file does not give takes the
registry's default. DOE files:
:mod:`bridgeflap.design.studies.experiments`.
"""

from __future__ import annotations

import os
import shutil
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from types import MappingProxyType
from typing import Any

from bridgeflap.design.io.files import (
    atomic_write_json,
    atomic_write_text,
    output_folder,
    stdout_to_stderr,
)
from bridgeflap.design.io.options import (
    check_keys,
    plain_name,
    read_definition,
    resolve_bridge,
    table,
)
from bridgeflap.design.io.outputs import (
    check_replaceable,
    claim_output,
    swap_into_place,
    temporary_sibling,
    write_marker,
)
from bridgeflap.design.studies.analyses import ANALYSES, Outcome, RunContext
from bridgeflap.design.studies.report import PAPER, study_report, study_report_html
from bridgeflap.design.studies.study_files import write_outcome
from bridgeflap.model.arguments import (
    check_callable,
    check_mapping,
    check_path,
    check_text,
    checked,
    flag,
    instance_or_path,
    optional,
)
from bridgeflap.model.errors import BridgeflapError, BridgeflapInputError
from bridgeflap.model.results import ResultData
from bridgeflap.model.structure.bridge_arg import check_bridge_kind

__all__ = [
    "StudyConfig",
    "StudyResult",
    "default_study_path",
    "load_study",
    "run_study",
    "study_from_dict",
    "validate_study",
]

_TOP_KEYS = {"name", "bridge", "description", "analyses", "quick", *ANALYSES}
_QUICK_TOP = {"element_length_m"}


def default_study_path() -> Path:
    """The built-in default study (the paper's reproduction on the Humber case)."""
    return Path(str(resources.files("bridgeflap.design.studies").joinpath("humber.toml")))


@dataclass(frozen=True)
class StudyConfig:
    """A resolved study definition.

    Attributes
    ----------
    name : str
        Study name (default output ``runs/<name>/output``).
    bridge : str or BridgeSpec
        Built-in bridge name, absolute path of a bridge TOML or an in-memory spec.
    analyses : tuple of (str, dict)
        Analysis kind and its options, in run order (quick overrides already applied).
    quick : bool
        Whether the quick settings were applied.
    element_length_m : float or None
        Mesh override [m] (quick mode), ``None`` for the bridge file's mesh.
    """

    name: str
    bridge: Any
    analyses: tuple
    quick: bool = False
    element_length_m: float | None = None
    description: str = ""
    source: str = ""

    def as_dict(self) -> dict:
        """JSON-ready resolved configuration.

        Returns
        -------
        dict
            The name, the bridge's identity (name, file, hash), ``quick``, the mesh override
            ``element_length_m`` [m], the description, the source file and each analysis's
            options.
        """
        from bridgeflap.design.io.identity import bridge_identity

        return {"name": self.name, **bridge_identity(self.bridge), "quick": self.quick,
                "element_length_m": self.element_length_m, "description": self.description,
                "source": self.source,
                "analyses": {kind: dict(opts) for kind, opts in self.analyses}}

    def spec(self):
        """The bridge definition with the mesh override applied.

        Returns
        -------
        BridgeSpec
            The study's bridge, on elements of ``element_length_m`` [m] when the study sets it.

        Raises
        ------
        BridgeflapInputError
            The bridge cannot be loaded, or the element length is out of range.
        """
        from bridgeflap.model.structure.loader import load_bridge

        spec = load_bridge(self.bridge)
        if self.element_length_m is not None:
            spec = spec.replace(**{"mesh.element_length_m": self.element_length_m})
        return spec


@checked(path=optional(check_path), quick=flag, bridge=optional(check_bridge_kind))
def load_study(path: str | os.PathLike | None = None, quick: bool = False,
               bridge: Any = None) -> StudyConfig:
    """Read and validate a study TOML (the built-in default when ``path`` is ``None``);
    ``bridge`` (a name, a bridge TOML path or a
    :class:`~bridgeflap.model.structure.spec.BridgeSpec`) replaces the file's own ``bridge``.

    Parameters
    ----------
    path : str, path-like or None, default None
        A study TOML file (docs/reference/formats/study.md); ``None``: the built-in default
        study (the paper's reproduction on the Humber Bridge).
    quick : bool, default False
        Apply the study's quick settings.
    bridge : str, path-like or BridgeSpec, optional
        Replaces the file's ``bridge``.

    Returns
    -------
    StudyConfig
        The validated study, for :func:`run_study`.

    Raises
    ------
    BridgeflapInputError
        Missing file, malformed TOML, unknown analysis or option, bad bridge.
    """
    data, base, source = read_definition(default_study_path() if path is None else Path(path),
                                         "study")
    if bridge is not None:
        data = {**data, "bridge": bridge}
    return study_from_dict(data, base=base, quick=quick, source=source)


@checked(data=check_mapping, base=optional(check_path), quick=flag, source=check_text)
def study_from_dict(data: Mapping, base: Path | None = None, quick: bool = False,
                    source: str = "<dict>") -> StudyConfig:
    """Build a :class:`StudyConfig` from parsed TOML (see the module docstring).

    Parameters
    ----------
    data : mapping
        The study file's tables (docs/reference/formats/study.md).
    base : pathlib.Path, optional
        Folder that relative paths in ``data`` are relative to.
    quick : bool, default False
        Apply the quick settings.
    source : str, default "<dict>"
        Where the data came from, for messages.

    Returns
    -------
    StudyConfig
        The validated study.

    Raises
    ------
    BridgeflapInputError
        Unknown analysis or option, bad bridge.
    """
    check_keys(data, _TOP_KEYS, "study", f"analyses: {', '.join(ANALYSES)}")
    base = Path.cwd() if base is None else base
    name = plain_name(data.get("name"))
    bridge = resolve_bridge(data.get("bridge", "humber"), base)
    kinds = data.get("analyses", list(ANALYSES))
    if not isinstance(kinds, list) or not kinds:
        raise BridgeflapInputError("analyses", "must be a non-empty list of analysis names")
    analyses = []
    for kind in kinds:
        if kind not in ANALYSES:
            raise BridgeflapInputError("analyses", f"unknown analysis {kind!r} (known: "
                                                   f"{', '.join(ANALYSES)})")
        if kind in (k for k, _ in analyses):
            raise BridgeflapInputError("analyses", f"{kind!r} listed twice")
        opts = table(data, kind)
        q = opts.pop("quick", {})
        if not isinstance(q, dict):
            raise BridgeflapInputError(f"{kind}.quick", "must be a table of options")
        ANALYSES[kind].resolve(q)  # names and values of the quick overrides, quick or not
        if quick:
            opts.update(q)
        ANALYSES[kind].resolve(opts)
        analyses.append((kind, opts))
    for kind in ANALYSES:
        if kind in data and kind not in kinds:
            raise BridgeflapInputError(kind, "options given for an analysis not in 'analyses'")
    qtop = data.get("quick", {})
    if not isinstance(qtop, dict) or set(qtop) - _QUICK_TOP:
        raise BridgeflapInputError("quick", f"must be a table with keys {sorted(_QUICK_TOP)}")
    length = None
    if quick and "element_length_m" in qtop:
        length = qtop["element_length_m"]
        if isinstance(length, bool) or not isinstance(length, int | float) or not length > 0:
            raise BridgeflapInputError("quick.element_length_m", "must be a positive number")
        length = float(length)
    description = data.get("description", "")
    return StudyConfig(name=name, bridge=bridge, analyses=tuple(analyses), quick=bool(quick),
                       element_length_m=length, description=str(description), source=source)




# ---------------------------------------------------------------------------- result


@dataclass(frozen=True)
class StudyResult(ResultData):
    """Outcome of :func:`run_study`.

    Attributes
    ----------
    config : StudyConfig
        The study that ran.
    out_dir : pathlib.Path
        The completed output folder.
    statuses : Mapping
        Analysis -> status (``"ok"``, ``"failed: ..."``, ...).
    results : Mapping
        Analysis -> JSON-ready summary.
    elapsed_s : float
        Wall time of the whole study [s].
    objects : Mapping
        Analysis -> its result object (not compared, not printed).
    """

    config: StudyConfig
    out_dir: Path
    statuses: Mapping
    results: Mapping
    elapsed_s: float
    objects: Mapping = field(default_factory=dict, compare=False, repr=False)

    @property
    def report(self) -> Path:
        """The ``report.md`` of the output folder."""
        return self.out_dir / "report.md"

    @property
    def status(self) -> str:
        """``"ok"`` when every analysis is ok (or converged), otherwise ``"partial"``."""
        good = ("ok", "converged")
        return "ok" if all(s in good for s in self.statuses.values()) else "partial"

    def summary(self) -> dict:
        """The ``bridgeflap study --json`` contract.

        Returns
        -------
        dict
            ``status``, ``study``, ``quick``, ``out_dir``, ``report``, ``elapsed_s`` [s], each
            analysis's status and, under ``results``, the flutter and divergence speeds [m/s]
            beside the paper's.
        """
        fl = self.results.get("flutter", {})
        return {"status": self.status, "study": self.config.name, "quick": self.config.quick,
                "out_dir": str(self.out_dir), "report": str(self.report),
                "elapsed_s": self.elapsed_s, "statuses": dict(self.statuses),
                "results": {"flutter_speed_m_s": fl.get("flutter_speed_m_s"),
                            "flutter_status": fl.get("flutter_status"),
                            "divergence_speed_m_s": fl.get("divergence_speed_m_s"),
                            "divergence_status": fl.get("divergence_status"),
                            "paper_flutter_speed_m_s": PAPER["flutter_speed_m_s"],
                            "paper_divergence_speed_m_s": PAPER["divergence_speed_m_s"]}}

    def _headline(self) -> dict:
        s = self.summary()
        return {"study": s["study"], "status": s["status"], "quick": s["quick"],
                **{k: v for k, v in s["results"].items() if not k.startswith("paper_")},
                "analyses": len(self.statuses), "elapsed_s": s["elapsed_s"],
                "out_dir": s["out_dir"]}

    def plot(self, axes=None):
        """The flutter root locus and damping/frequency plots (the paper's Fig. 3 left).

        Parameters
        ----------
        axes : sequence of three matplotlib.axes.Axes, optional
            Root-locus, V-g and V-f axes (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).

        Raises
        ------
        BridgeflapError
            The study ran no flutter analysis.
        """
        if self.objects.get("flutter") is None:
            raise BridgeflapError("the study has no flutter result to plot")
        return self.objects["flutter"].plot(axes)


# ---------------------------------------------------------------------------- runner


def _run_one(kind: str, spec, opts: Mapping, config: StudyConfig, say,
             workers: int = 1) -> Outcome:
    """Run one analysis; any exception becomes a ``failed: ...`` outcome, except an input error
    naming one of the study's own options of ``kind``: that is bad input that escaped the
    checks of :func:`validate_study`, and aborts the study (exit 2, the earlier output folder
    untouched) instead of replacing a good folder by a partial one. ``workers``: the
    study's, which an analysis with a parallel part of its own uses (the design's acceptance
    checks: its 1000 fresh variants)."""
    # the design's acceptance checks are the one long parallel part; the other analyses take
    # seconds, less than a nested pool's start-up
    context = RunContext(bridge=config.bridge, quick=config.quick, progress=say,
                         workers=workers if kind == "design" else 1)
    t0 = time.perf_counter()
    try:
        with stdout_to_stderr():
            outcome = ANALYSES[kind](spec, opts, context)
    except BridgeflapInputError as exc:
        name = str(exc.field).removeprefix(f"{kind}.").split(".", 1)[0]
        if name in opts:
            field = exc.field if str(exc.field).startswith(f"{kind}.") else f"{kind}.{exc.field}"
            raise BridgeflapInputError(field, exc.reason) from None
        outcome = Outcome(f"failed: {type(exc).__module__}.{type(exc).__name__}: "
                          f"{' '.join(str(exc).split())[:300]}")
    except Exception as exc:  # noqa: BLE001 - failure is data, never an aborted study
        tb = traceback.format_exception_only(type(exc), exc)[-1].strip()
        outcome = Outcome(f"failed: {' '.join(tb.split())[:300]}")
    inner = outcome.summary.get("status")
    summary = {**outcome.summary, "status": outcome.status,
               "elapsed_s": time.perf_counter() - t0}
    if inner is not None and inner != outcome.status:
        summary["solver_status"] = inner
    return Outcome(outcome.status, summary, outcome.arrays, outcome.figures, outcome.result)


@checked(config=optional(instance_or_path(StudyConfig, "bridgeflap.design.load_study")),
         out_dir=optional(check_path), quick=flag, progress=optional(check_callable))
def run_study(config: StudyConfig | str | os.PathLike | None = None,
              out_dir: str | os.PathLike | None = None, quick: bool = False,
              progress: Callable[[str], None] | None = None, workers: int = 1) -> StudyResult:
    """Run every analysis of a study and write the self-describing output folder.

    Parameters
    ----------
    config : StudyConfig, path or None
        A loaded study, a study TOML path, or ``None`` for the built-in default.
    out_dir : path, optional
        Output folder (``bridgeflap study --out``; default ``runs/<name>/output`` relative to
        the current directory).
    quick : bool
        Apply the quick settings (only when ``config`` is a path or ``None``).
    progress : callable, optional
        Called with one-line progress messages (the CLI prints them on stderr).
    workers : int, optional
        Analyses run at once, each in its own worker process (:func:`_run_analyses`); 1 runs
        them one after another in this process. The numbers do not depend on it.

    Returns
    -------
    StudyResult
        Each analysis's result and status, the output folder; ``summary()`` (what
        ``bridgeflap study --json`` prints), ``table()``, ``plot()``.

    Raises
    ------
    BridgeflapInputError
        A bad study, folder (another kind of output, not writable) or ``workers``.
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise BridgeflapInputError("workers", f"must be an integer >= 1, got {workers!r}")
    if not isinstance(config, StudyConfig):
        config = load_study(config, quick=quick)
    say = progress or (lambda msg: None)
    validate_study(config)
    spec = config.spec()
    target = check_replaceable(output_folder(out_dir, config.name), "out", "study")  # typed folder
    with claim_output(target, "out", say=progress, kind="study"):  # notes: progress/stderr
        tmp = temporary_sibling(target)
        start = time.perf_counter()
        try:
            tmp.mkdir()
            write_marker(tmp, "study")
            (tmp / "results").mkdir()
            (tmp / "figures").mkdir()
            atomic_write_json(tmp / "config.json", config.as_dict())
            from bridgeflap.design.io.manifest import build_manifest

            atomic_write_json(tmp / "manifest.json", build_manifest(config.as_dict()))
            statuses, results, objects, figures = {}, {}, {}, {}
            done = _run_analyses(config, spec, tmp, say, progress, workers)
            for kind, _ in config.analyses:  # in the study's order, however they ran
                statuses[kind], results[kind], figures[kind], objects[kind] = done[kind]
            atomic_write_json(tmp / "statuses.json", statuses)
            elapsed = time.perf_counter() - start
            result = StudyResult(config, target, MappingProxyType(statuses),
                                 MappingProxyType(results), elapsed, MappingProxyType(objects))
            atomic_write_text(tmp / "report.md", study_report(result, figures))
            atomic_write_text(tmp / "report.html", study_report_html(result, figures, tmp))
            atomic_write_json(tmp / "summary.json", result.summary())
            swap_into_place(tmp, target)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
    say(f"study {config.name}: written {target} ({elapsed:.1f} s)")
    return result


#: the order in which a parallel study starts its analyses: longest first (Humber, 2 cores:
#: design ~60-200 s, sensitivity ~20 s, erection ~4 s, frequency ratio ~3 s, the rest ~1 s),
#: so that the short ones fill the other worker while the longest runs
_LONGEST_FIRST = ("design", "sensitivity", "erection", "frequency_ratio", "flutter",
                  "buffeting", "modes")


def _run_and_write(kind: str, spec, opts: Mapping, config: StudyConfig, folder: Path,
                   say, in_process: bool, workers: int = 1) -> tuple:
    """Run one analysis and write its files: ``(status, summary, figure names, result)``.

    What a study's worker process runs (:func:`_run_analyses`); the result object comes back
    only if it pickles (or ``in_process``), else ``None``.
    """
    say = say or (lambda msg: None)
    say(f"study {config.name}: {kind} ...")
    outcome = _run_one(kind, spec, opts, config, say, workers)
    summary, names = write_outcome(kind, outcome, folder)
    say(f"study {config.name}: {kind} {outcome.status} ({outcome.summary['elapsed_s']:.1f} s)")
    result = outcome.result
    if not in_process:
        import pickle

        try:
            pickle.dumps(result)
        except Exception:  # noqa: BLE001 - an unpicklable result stays in the worker
            result = None
    return outcome.status, summary, names, result


def _run_analyses(config: StudyConfig, spec, folder: Path, say, progress,
                  workers: int) -> dict:
    """Every analysis of ``config`` run and written: kind -> ``(status, summary, figures,
    result)``.

    ``workers == 1``: one after another in this process. Otherwise in a pool of that many
    worker processes (processes, not threads: the sweeps hold the GIL between LAPACK calls),
    longest first (:data:`_LONGEST_FIRST`); each analysis writes its own files, so the output
    is the serial one. The design analysis starts its own process pool for its parallel
    starts (pool workers are not daemonic, so they may). Progress lines of the workers reach
    ``progress`` when it can be pickled (the CLI's ``log``), else they are dropped.
    """
    jobs = list(config.analyses)
    if workers <= 1 or len(jobs) <= 1:
        return {kind: _run_and_write(kind, spec, opts, config, folder, say, True, workers)
                for kind, opts in jobs}
    import pickle

    from bridgeflap.model.workers import process_pool

    try:
        pickle.dumps(progress)
        remote_say = progress
    except Exception:  # noqa: BLE001 - e.g. a lambda: workers then report nothing
        remote_say = None
    rank = {k: i for i, k in enumerate(_LONGEST_FIRST)}
    jobs.sort(key=lambda job: rank.get(job[0], -1))  # unknown kinds first: no estimate
    with process_pool(min(workers, len(jobs))) as pool:  # the guard, before the line below
        say(f"study {config.name}: {len(jobs)} analyses on {min(workers, len(jobs))} worker "
            f"processes")
        # the study's worker count goes to each analysis too: the design's checks start
        # their own pool once the shorter analyses are done (pool workers are not daemonic)
        futures = {kind: pool.submit(_run_and_write, kind, spec, opts, config, folder,
                                     remote_say, False, workers) for kind, opts in jobs}
        try:
            return {kind: fut.result() for kind, fut in futures.items()}
        except KeyboardInterrupt:
            # Ctrl-C: the pool terminates its workers as the interrupt leaves it
            # (model.workers.process_pool), their analyses abandoned; the queued futures are
            # not cancelled as well (that races the pool's own clean-up: CPython 3.11 then
            # raises InvalidStateError in its manager thread, a traceback on stderr)
            raise
        except BaseException:
            for fut in futures.values():
                fut.cancel()
            raise


def validate_study(config: StudyConfig) -> None:
    """Check every analysis's options of ``config`` (names and values), before any write.

    :func:`load_study` already does this; a :class:`StudyConfig` built or changed by other
    code is checked again here, so that no folder is created for a run that would fail on its
    input.

    Raises
    ------
    BridgeflapInputError
        Unknown analysis, unknown option or bad option value (the field named).
    """
    for kind, opts in config.analyses:
        if kind not in ANALYSES:
            raise BridgeflapInputError("analyses", f"unknown analysis {kind!r} (known: "
                                                   f"{', '.join(ANALYSES)})")
        if not isinstance(opts, Mapping):
            raise BridgeflapInputError(kind, "must be a table of options")
        ANALYSES[kind].resolve(opts)
    fe_only = [k for k, _ in config.analyses if k in FE_ONLY_ANALYSES]
    if fe_only:
        from bridgeflap.model.structure.loader import load_bridge
        from bridgeflap.model.structure.modal_files import needs_fe

        spec = load_bridge(config.bridge)
        if getattr(spec, "structure", None) is not None:  # an imported modal model
            raise needs_fe(spec.name, f"the {fe_only[0]} analysis")


#: analyses that rebuild the structure (erection stages, per-stage modes): the cable/FE model
FE_ONLY_ANALYSES = ("erection", "frequency_ratio")

