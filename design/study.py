"""Studies and designs of experiments: definition files, runners and self-describing output.

A **study** is a TOML file (``runs/<name>/study.toml``; the built-in default is
``design/studies/humber.toml``, the seed paper's full reproduction) naming the bridge, the
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
status; bad input raises :class:`~model.errors.BridgeflapInputError` before anything is written.

Output folder::

    config.json      resolved configuration (defaults, quick overrides applied)
    manifest.json    time, host, versions, git commit (design.manifest.build_manifest)
    statuses.json    analysis -> status (and every solver status inside it)
    results/<analysis>.json, results/<analysis>.npz (arrays)
    figures/<analysis>.png
    report.md        comparison with the paper: Table 1, 65/74 m/s, Figs. 2-5
    summary.json     the ``bridgeflap study --json`` payload

A **DOE** file (:func:`load_doe`, :func:`run_doe`) names the bridge, the analysis, the design
kind and the parameter ranges (dotted paths of :data:`model.spec.PARAMETER_PATHS`); it runs
through :func:`design.doe.run_batch` (per-case status, resumable).
"""

from __future__ import annotations

import contextlib
import functools
import os
import shutil
import sys
import time
import traceback
import uuid
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from design.io import atomic_savez, atomic_write_json, atomic_write_text, ensure_writable_dir
from model.errors import BridgeflapError, BridgeflapInputError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = [
    "ANALYSIS_KINDS",
    "DoeConfig",
    "DoeResult",
    "StudyConfig",
    "StudyResult",
    "default_study_path",
    "load_doe",
    "load_study",
    "run_doe",
    "run_study",
]

# analysis kind -> allowed option names (None: passed through to an analysis written elsewhere)
ANALYSIS_KINDS: dict[str, tuple | None] = {
    "modes": ("count",),
    "frequency_ratio": ("fractions",),
    "flutter": ("speeds", "modes", "rfa", "order"),
    "erection": ("fractions", "speeds", "modes"),
    "buffeting": None,
    "sensitivity": ("parameters", "speeds", "modes", "check"),
    "design": None,
}
PAPER = {"flutter_speed_m_s": 65.0, "divergence_speed_m_s": 74.0}
_TOP_KEYS = {"name", "bridge", "description", "analyses", "quick", *ANALYSIS_KINDS}
_QUICK_TOP = {"element_length_m"}


def default_study_path() -> Path:
    """The built-in default study (the seed paper's reproduction on the Humber case)."""
    return Path(str(resources.files("design.studies").joinpath("humber.toml")))


def _read_toml(path: Path, field_name: str) -> dict:
    if not path.is_file():
        raise BridgeflapInputError(field_name, f"file not found: {path}")
    try:
        return tomllib.loads(path.read_text("utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise BridgeflapInputError(field_name, f"cannot read {path}: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise BridgeflapInputError(field_name, f"malformed TOML in {path}: {exc}") from None


def _resolve_bridge(bridge: Any, base: Path, field_name: str = "bridge") -> str:
    from model.spec import BUILTIN_BRIDGES, load_bridge

    if not isinstance(bridge, str) or not bridge:
        raise BridgeflapInputError(field_name, "missing or not a string")
    if bridge not in BUILTIN_BRIDGES:
        p = Path(bridge)
        bridge = str(p if p.is_absolute() else (base / p).resolve())
    load_bridge(bridge)  # validate now: bad input exits before anything is written
    return bridge


def _name(value: Any, field_name: str = "name") -> str:
    if not isinstance(value, str) or not value or any(c in value for c in "/\\") \
            or value.startswith("."):
        raise BridgeflapInputError(field_name, f"must be a plain folder name, got {value!r}")
    return value


# ============================================================================ studies


@dataclass(frozen=True)
class StudyConfig:
    """A resolved study definition.

    Attributes
    ----------
    name : str
        Study name (default output ``runs/<name>/output``).
    bridge : str
        Built-in bridge name or absolute path of a bridge TOML.
    analyses : tuple of (str, dict)
        Analysis kind and its options, in run order (quick overrides already applied).
    quick : bool
        Whether the quick settings were applied.
    element_length_m : float or None
        Mesh override [m] (quick mode), ``None`` for the bridge file's mesh.
    """

    name: str
    bridge: str
    analyses: tuple
    quick: bool = False
    element_length_m: float | None = None
    description: str = ""
    source: str = ""

    def as_dict(self) -> dict:
        """JSON-ready resolved configuration."""
        return {"name": self.name, "bridge": self.bridge, "quick": self.quick,
                "element_length_m": self.element_length_m, "description": self.description,
                "source": self.source,
                "analyses": {kind: dict(opts) for kind, opts in self.analyses}}

    def spec(self):
        """The bridge definition with the mesh override applied."""
        from model.spec import load_bridge

        spec = load_bridge(self.bridge)
        if self.element_length_m is not None:
            spec = spec.replace(**{"mesh.element_length_m": self.element_length_m})
        return spec


def load_study(path: str | os.PathLike | None = None, quick: bool = False) -> StudyConfig:
    """Read and validate a study TOML (the built-in default when ``path`` is ``None``).

    Raises
    ------
    BridgeflapInputError
        Missing file, malformed TOML, unknown analysis or option, bad bridge.
    """
    p = default_study_path() if path is None else Path(path)
    data = _read_toml(p, "study")
    return study_from_dict(data, base=p.parent, quick=quick, source=str(p))


def study_from_dict(data: Mapping, base: Path | None = None, quick: bool = False,
                    source: str = "<dict>") -> StudyConfig:
    """Build a :class:`StudyConfig` from parsed TOML (see the module docstring)."""
    base = Path.cwd() if base is None else base
    unknown = set(data) - _TOP_KEYS
    if unknown:
        raise BridgeflapInputError(sorted(unknown)[0], "unknown key in the study file "
                                                      f"(analyses: {', '.join(ANALYSIS_KINDS)})")
    name = _name(data.get("name"))
    bridge = _resolve_bridge(data.get("bridge", "humber"), base)
    kinds = data.get("analyses", list(ANALYSIS_KINDS))
    if not isinstance(kinds, list) or not kinds:
        raise BridgeflapInputError("analyses", "must be a non-empty list of analysis names")
    analyses = []
    for kind in kinds:
        if kind not in ANALYSIS_KINDS:
            raise BridgeflapInputError("analyses", f"unknown analysis {kind!r} (known: "
                                                   f"{', '.join(ANALYSIS_KINDS)})")
        if kind in (k for k, _ in analyses):
            raise BridgeflapInputError("analyses", f"{kind!r} listed twice")
        table = data.get(kind, {})
        if not isinstance(table, dict):
            raise BridgeflapInputError(kind, "must be a table of options")
        opts = {k: v for k, v in table.items() if k != "quick"}
        q = table.get("quick", {})
        if not isinstance(q, dict):
            raise BridgeflapInputError(f"{kind}.quick", "must be a table of options")
        allowed = ANALYSIS_KINDS[kind]
        if allowed is not None:
            for key in (*opts, *q):
                if key not in allowed:
                    raise BridgeflapInputError(f"{kind}.{key}", f"unknown option (known: "
                                                                f"{', '.join(allowed)})")
        if quick:
            opts.update(q)
        _check_options(kind, opts)
        analyses.append((kind, opts))
    for kind in ANALYSIS_KINDS:
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


def _check_options(kind: str, opts: dict) -> None:
    """Validate the option values now, so that bad input exits before anything is written."""
    from model.analysis import parse_range

    for key in ("speeds", "fractions"):
        if isinstance(opts.get(key), str):
            parse_range(opts[key], f"{kind}.{key}", 0.0)
    for key in ("modes", "count"):
        if key in opts and (isinstance(opts[key], bool) or not isinstance(opts[key], int)
                            or opts[key] < 1):
            raise BridgeflapInputError(f"{kind}.{key}", "must be an integer >= 1")
    if kind == "sensitivity" and "parameters" in opts:
        from design.sensitivity import _check_parameters

        try:
            _check_parameters(opts["parameters"])
        except BridgeflapInputError as exc:
            raise BridgeflapInputError("sensitivity.parameters", exc.reason) from None


# ---------------------------------------------------------------------------- analyses


@dataclass
class _Outcome:
    status: str
    summary: dict = field(default_factory=dict)
    arrays: dict = field(default_factory=dict)
    figures: dict = field(default_factory=dict)
    obj: Any = None


def _figure_of(ax):
    if isinstance(ax, list | tuple | np.ndarray):
        return np.ravel(ax)[0].figure
    return ax.figure


def _run_modes(spec, opts) -> _Outcome:
    from model.analysis import modal_model
    from model.validation import compare_table1

    modal = modal_model(spec)
    rows = compare_table1(modal)
    s = {"cable_horizontal_tension_n": modal.structure.statics.horizontal_tension_n,
         "cable_main_sag_m": modal.structure.statics.main_sag_m,
         "modes": modal.table()[: int(opts.get("count", 30))], "table1": rows}
    freq = np.array([m["frequency_hz"] for m in s["modes"]])
    return _Outcome("ok", s, {"frequency_hz": freq}, {"modes": _figure_of(modal.plot())}, modal)


def _run_frequency_ratio(spec, opts) -> _Outcome:
    from model.analysis import frequency_ratio

    res = frequency_ratio(spec, opts.get("fractions", "0.1:1.0:0.05"))
    s = res.summary()
    bad = [st for st in res.stages if not np.isfinite(st["ratio_half_gj"])]
    status = "ok" if not bad else f"partial: {len(bad)} stages without a symmetric pair"
    arr = {k: np.array([st[k] for st in res.stages], dtype=float)
           for k in ("erected_fraction", "ratio_full_gj", "ratio_half_gj")}
    return _Outcome(status, s, arr, {"frequency_ratio": _figure_of(res.plot())}, res)


def _run_flutter(spec, opts) -> _Outcome:
    from model.analysis import DEFAULT_MODES, flutter

    res = flutter(spec, opts.get("speeds", "0:100:0.5"), n_modes=int(opts.get("modes",
                                                                              DEFAULT_MODES)),
                  order=opts.get("order", "modal"), rfa=opts.get("rfa", "rfa4"))
    s = res.summary()
    status = ("ok" if s["flutter_status"] == "converged" and s["divergence_status"] == "converged"
              else f"flutter {s['flutter_status']}, divergence {s['divergence_status']}")
    sw = res.sweep
    arr = {"speeds_m_s": sw.speeds, "eigenvalues": sw.eigenvalues, "branches": sw.branches,
           "branch_labels": np.array(sw.branch_labels)}
    return _Outcome(status, s, arr, {"flutter": _figure_of(res.plot())}, res)


def _run_erection(spec, opts, progress=None) -> _Outcome:
    from model.analysis import DEFAULT_MODES, erection

    res = erection(spec, opts.get("fractions", "0.1:1.0:0.1"), opts.get("speeds", "0:100:0.5"),
                   int(opts.get("modes", DEFAULT_MODES)), progress=progress)
    bad = [st for st in res.stages if st["flutter_status"] != "converged"]
    status = "ok" if not bad else (f"{len(bad)} of {len(res.stages)} stages: flutter "
                                   + ", ".join(sorted({st['flutter_status'] for st in bad})))
    arr = {k: np.array([np.nan if st.get(k) is None else st.get(k, np.nan)
                        for st in res.stages], dtype=float)
           for k in ("erected_fraction", "flutter_speed_m_s", "divergence_speed_m_s")}
    return _Outcome(status, res.summary(), arr, {"erection": _figure_of(res.plot())}, res)


def _run_sensitivity(spec, opts) -> _Outcome:
    from design.sensitivity import DEFAULT_PARAMETERS, local_sensitivity

    res = local_sensitivity(spec, opts.get("parameters", DEFAULT_PARAMETERS),
                            speeds=opts.get("speeds", "0:120:1"),
                            n_modes=int(opts.get("modes", 16)), check=bool(opts.get("check",
                                                                                    True)))
    bad = [r["parameter"] for r in res.rows
           if r["flutter_status"] != "ok" or r["divergence_status"] != "ok"]
    status = "ok" if not bad else f"IFT not available for {', '.join(bad)}"
    return _Outcome(status, res.summary(), {}, {"sensitivity": _figure_of(res.plot())}, res)


def _unavailable(module: str, exc: ImportError) -> _Outcome:
    return _Outcome(f"unavailable: {module} not importable ({exc})")


def _run_buffeting(spec, opts) -> _Outcome:
    try:
        from model.buffeting import buffeting
    except ImportError as exc:
        return _unavailable("model.buffeting", exc)
    from design.cases import accepted_kwargs
    from model.analysis import parse_range

    opts = dict(opts)
    if isinstance(opts.get("speeds"), str):
        opts["speeds"] = parse_range(opts["speeds"], "buffeting.speeds", 0.0)
    if "modes" in opts and "n_modes" not in opts:
        opts["n_modes"] = opts["modes"]
    res = buffeting(spec, **accepted_kwargs(buffeting, opts))
    s = res.summary()
    arr = {k: np.asarray(s[k], dtype=float) for k in ("speeds_m_s", "rms_vertical_m",
                                                      "rms_vertical_over_width") if k in s}
    figs = {"buffeting": _figure_of(res.plot())} if hasattr(res, "plot") else {}
    return _Outcome(_aggregate_status(s.get("status", "unknown")), s, arr, figs, res)


def _aggregate_status(status) -> str:
    """One status from a per-point list: ``ok`` or ``k of n points: <statuses>``."""
    if isinstance(status, list | tuple):
        bad = [str(x) for x in status if x not in ("ok", "converged")]
        return "ok" if not bad else f"{len(bad)} of {len(status)} points: " + ", ".join(
            sorted(set(bad)))
    return str(status)


def _run_design(spec, opts, quick: bool = False, bridge: str = "humber",
                progress=None) -> _Outcome:
    from design.driver import design
    from design.settings import load_settings, quick_settings

    settings = load_settings(**{"bridge": bridge, **opts})
    if quick:
        settings = quick_settings(settings)
    res = design(settings, progress=progress)
    s = res.summary() if hasattr(res, "summary") else dict(res)
    figs = {}
    if getattr(res, "controller", None) is not None:
        if progress:
            progress("closed-loop root locus and buffeting (Fig. 5)")
        figs["design"] = fig5(spec, res.controller, n_modes=getattr(settings, "n_modes", 16),
                              quick=quick)
    for method in ("plot_margins", "plot_bode"):
        if hasattr(res, method):
            figs[f"design_{method[5:]}"] = _figure_of(getattr(res, method)())
    return _Outcome(_aggregate_status(s.get("status", "unknown")), s, {}, figs, res)


def fig5(spec, controller, n_modes: int = 16, quick: bool = False):
    """Seed Fig. 5: closed-loop root locus 0-85 m/s (left) and buffeting with and without
    the flaps (right; the open loop is NaN beyond its flutter speed, never clipped)."""
    import matplotlib.pyplot as plt

    from model.buffeting import buffeting
    from model.flaps import closed_loop_flutter

    speeds = np.arange(0.0, 85.0 + 1e-9, 1.0 if quick else 0.5)
    cl = closed_loop_flutter(spec, controller, speeds, n_modes)
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 4.5), layout="constrained")
    sw = cl.base.sweep
    sw.plot_root_locus(ax0, title=f"closed loop, {controller.n_flaps} flap pairs: "
                       + (f"flutter {sw.flutter.speed:.1f} m/s"
                          if sw.flutter.status == "converged" else "stable 0-85 m/s"))
    bspeeds = np.arange(4.0, 84.0 + 1e-9, 8.0 if quick else 4.0)
    ol = buffeting(spec, bspeeds, n_modes=n_modes, allow_unstable=True)
    clb = buffeting(spec, bspeeds, n_modes=n_modes, controller=controller, allow_unstable=True)
    ax1.semilogy(ol.speeds, ol.rms_vertical_over_width, "k--o", ms=3, label="open loop")
    ax1.semilogy(clb.speeds, clb.rms_vertical_over_width, "b-o", ms=3, label="closed loop")
    uf = cl.open_loop.sweep.flutter
    if uf.status == "converged":
        ax1.axvline(uf.speed, color="r", ls=":", lw=1,
                    label=f"open-loop flutter {uf.speed:.1f} m/s")
    ax1.set_xlabel("mean wind speed U [m/s]")
    ax1.set_ylabel("max sigma_z / (2b) on the main span [-]")
    ax1.set_title("buffeting (NaN beyond open-loop flutter)")
    ax1.grid(alpha=0.3, which="both")
    ax1.legend(fontsize=8)
    return fig


def _dispatch(kind: str, spec, opts: dict, config: StudyConfig, say) -> _Outcome:
    runner = _RUNNERS[kind]
    if kind == "erection":
        return runner(spec, opts, progress=lambda f: say(f"  erection stage {f:.3f} done"))
    if kind == "design":
        return runner(spec, opts, quick=config.quick, bridge=config.bridge,
                      progress=lambda msg: say(f"  design: {msg}"))
    return runner(spec, opts)


_RUNNERS: dict[str, Callable] = {
    "modes": _run_modes, "frequency_ratio": _run_frequency_ratio, "flutter": _run_flutter,
    "erection": _run_erection, "sensitivity": _run_sensitivity, "buffeting": _run_buffeting,
    "design": _run_design,
}


# ---------------------------------------------------------------------------- result


@dataclass(frozen=True)
class StudyResult:
    """Outcome of :func:`run_study`.

    Attributes
    ----------
    out_dir : pathlib.Path
        The completed output folder.
    statuses : dict
        Analysis -> status (``"ok"``, ``"failed: ..."``, ``"unavailable: ..."``, ...).
    results : dict
        Analysis -> JSON-ready summary.
    """

    config: StudyConfig
    out_dir: Path
    statuses: dict
    results: dict
    elapsed_s: float
    objects: dict = field(default_factory=dict, compare=False, repr=False)

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
        """The ``bridgeflap study --json`` contract."""
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

    def plot(self, axes=None):
        """The flutter root locus and damping/frequency plots (seed Fig. 3 left)."""
        if "flutter" not in self.objects:
            raise BridgeflapError("the study has no flutter result to plot")
        return self.objects["flutter"].plot(axes)


# ---------------------------------------------------------------------------- runner


@contextlib.contextmanager
def _stdout_to_stderr():
    """Send file descriptor 1 to stderr meanwhile (solvers such as Ipopt print from C), so
    that ``--json`` keeps stdout to exactly one JSON object."""
    try:
        sys.stdout.flush()
        saved = os.dup(1)
    except (OSError, ValueError, AttributeError):
        yield
        return
    try:
        os.dup2(2, 1)
        yield
    finally:
        try:
            sys.stdout.flush()
        except (OSError, ValueError):
            pass
        os.dup2(saved, 1)
        os.close(saved)


def _new_sibling(target: Path, tag: str) -> Path:
    return target.parent / f".{target.name}.{tag}-{uuid.uuid4().hex[:10]}"


def _swap_into_place(tmp: Path, target: Path) -> None:
    """Replace ``target`` by the complete folder ``tmp``; the old folder is kept until then."""
    old = None
    if target.exists():
        old = _new_sibling(target, "old")
        os.rename(target, old)
    try:
        os.rename(tmp, target)
    except OSError:
        if old is not None:
            os.rename(old, target)
        raise
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def default_out_dir(name: str) -> Path:
    """``runs/<name>/output`` relative to the current directory."""
    return Path.cwd() / "runs" / name / "output"


def run_study(config: StudyConfig | str | os.PathLike | None = None,
              out: str | os.PathLike | None = None, quick: bool = False,
              progress: Callable[[str], None] | None = None) -> StudyResult:
    """Run every analysis of a study and write the self-describing output folder.

    Parameters
    ----------
    config : StudyConfig, path or None
        A loaded study, a study TOML path, or ``None`` for the built-in default.
    out : path, optional
        Output folder (default ``runs/<name>/output`` relative to the current directory).
    quick : bool
        Apply the quick settings (only when ``config`` is a path or ``None``).
    progress : callable, optional
        Called with one-line progress messages (the CLI prints them on stderr).
    """
    if not isinstance(config, StudyConfig):
        config = load_study(config, quick=quick)
    say = progress or (lambda msg: None)
    spec = config.spec()
    target = Path(out).expanduser().absolute() if out is not None else default_out_dir(
        config.name)
    if target.exists() and not target.is_dir():
        raise BridgeflapInputError("out", f"{target} exists and is not a folder")
    ensure_writable_dir(target.parent, "out")
    tmp = _new_sibling(target, "tmp")
    start = time.perf_counter()
    try:
        tmp.mkdir()
        (tmp / "results").mkdir()
        (tmp / "figures").mkdir()
        atomic_write_json(tmp / "config.json", config.as_dict())
        from design.manifest import build_manifest

        atomic_write_json(tmp / "manifest.json", build_manifest(config.as_dict()))
        statuses, results, objects, figures = {}, {}, {}, {}
        for kind, opts in config.analyses:
            say(f"study {config.name}: {kind} ...")
            t0 = time.perf_counter()
            try:
                with _stdout_to_stderr():
                    outcome = _dispatch(kind, spec, opts, config, say)
            except Exception as exc:  # noqa: BLE001 - failure is data, never an aborted study
                tb = traceback.format_exception_only(type(exc), exc)[-1].strip()
                outcome = _Outcome(f"failed: {' '.join(tb.split())[:300]}")
            inner = outcome.summary.get("status")
            outcome.summary = {**outcome.summary, "status": outcome.status,
                               "elapsed_s": time.perf_counter() - t0}
            if inner is not None and inner != outcome.status:
                outcome.summary["solver_status"] = inner
            statuses[kind] = outcome.status
            results[kind] = outcome.summary
            objects[kind] = outcome.obj
            atomic_write_json(tmp / "results" / f"{kind}.json", outcome.summary)
            if outcome.arrays:
                atomic_savez(tmp / "results" / f"{kind}.npz", **outcome.arrays)
            figures[kind] = _save_figures(outcome.figures, tmp / "figures")
            controller = getattr(outcome.obj, "controller", None) if kind == "design" else None
            if controller is not None:
                from model.control import save_controller

                save_controller(controller, tmp / "results" / "controller.toml")
                outcome.summary["controller_file"] = "results/controller.toml"
                atomic_write_json(tmp / "results" / f"{kind}.json", outcome.summary)
            say(f"study {config.name}: {kind} {outcome.status} "
                f"({time.perf_counter() - t0:.1f} s)")
        atomic_write_json(tmp / "statuses.json", statuses)
        elapsed = time.perf_counter() - start
        result = StudyResult(config, target, statuses, results, elapsed, objects)
        atomic_write_text(tmp / "report.md", _report(result, figures))
        atomic_write_json(tmp / "summary.json", result.summary())
        _swap_into_place(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    say(f"study {config.name}: written {target} ({elapsed:.1f} s)")
    return result


def _save_figures(figs: dict, folder: Path) -> list[str]:
    import matplotlib.pyplot as plt

    names = []
    for name, fig in figs.items():
        fig.savefig(folder / f"{name}.png", dpi=110, bbox_inches="tight")
        plt.close(fig)
        names.append(f"figures/{name}.png")
    return names


# ---------------------------------------------------------------------------- report


def _fmt(x, spec=".2f") -> str:
    if x is None or (isinstance(x, float) and not np.isfinite(x)):
        return "-"
    return format(x, spec)


def _report(res: StudyResult, figures: dict) -> str:
    cfg, r = res.config, res.results
    L = [f"# Study `{cfg.name}`: reproduction of Massaro, Limebeer et al. (flutter and buffeting "
         "of long-span suspension bridges)", "",
         f"Bridge: `{cfg.bridge}`; quick mode: {cfg.quick}"
         + (f" (mesh {cfg.element_length_m} m)" if cfg.element_length_m else "")
         + f"; run time {res.elapsed_s:.1f} s. Inputs marked NOT FOUND/ESTIMATE in "
           "HUMBER_DATA.md (sag, cable spacing, deck inertia, half-chord; EI/GJ updated to "
           "Table 1) "
           "are the built-in estimates; none was tuned to the paper's speeds.", "",
         "## Solver and analysis statuses", "", "| analysis | status |", "|---|---|"]
    for kind, st in res.statuses.items():
        L.append(f"| {kind} | {st} |")
    solver = []
    if "flutter" in r and "flutter_status" in r["flutter"]:
        solver.append(f"flutter sweep: flutter `{r['flutter']['flutter_status']}`, divergence "
                      f"`{r['flutter']['divergence_status']}`")
    if "erection" in r and "stages" in r["erection"]:
        for st in r["erection"]["stages"]:
            solver.append(f"erection {st['erected_fraction']:.2f}: flutter "
                          f"`{st.get('flutter_status')}`, divergence "
                          f"`{st.get('divergence_status')}`")
    if "sensitivity" in r and "derivatives" in r["sensitivity"]:
        solver.append(f"sensitivity nominal: flutter `{r['sensitivity']['flutter_status']}`, "
                      f"divergence `{r['sensitivity']['divergence_status']}`")
    for kind in ("buffeting", "design"):
        if kind in r:
            inner = r[kind].get("solver_status")
            solver.append(f"{kind}: `{r[kind]['status']}`"
                          + (f" (solver statuses: {', '.join(map(str, inner))})"
                             if isinstance(inner, list) else ""))
    if solver:
        L += ["", "Solver statuses inside the analyses:", ""] + [f"- {s}" for s in solver]

    if "modes" in r and "table1" in r["modes"]:
        L += ["", "## Table 1: natural frequencies", "",
              "Measured (Brownjohn et al. 1994) and the paper's model, against ours (paired in "
              "frequency order within each family, main-span modes; see model/validation.py).",
              "", "| family | Table 1 label | measured [Hz] | paper model [Hz] | ours [Hz] | "
              "our label | ours vs measured [%] |", "|---|---|---|---|---|---|---|"]
        for row in r["modes"]["table1"]:
            L.append(f"| {row['family']} | {row['table1_label']} | {row['measured_hz']:.3f} | "
                     f"{row['seed_model_hz']:.3f} | {_fmt(row['bridgeflap_hz'], '.3f')} | "
                     f"{row['bridgeflap_label']} | {_fmt(row['difference_percent'], '+.1f')} |")
        L += ["", "EI, GJ and lateral EI were fitted (least RMS log-misfit) to these measured "
              "frequencies (runs/model_updating), so the family-wide agreement is partly by "
              "construction; the individual mode pairings are the test. Table 1's labels "
              "are partly inconsistent (two VA rows, VS below VA)."]
    if "flutter" in r and "flutter_speed_m_s" in r["flutter"]:
        f = r["flutter"]
        uf, ud = f["flutter_speed_m_s"], f["divergence_speed_m_s"]
        L += ["", "## Flutter and torsional divergence (complete bridge)", "",
              "| quantity | paper | ours | difference | status |", "|---|---|---|---|---|",
              f"| flutter speed [m/s] | 65 | {_fmt(uf)} | {_pct(uf, 65.0)} | "
              f"{f['flutter_status']} |",
              f"| flutter frequency [Hz] | - | {_fmt(f['flutter_frequency_hz'], '.4f')} | - | "
              f"{f['flutter_status']} |",
              f"| torsional divergence [m/s] | 74 | {_fmt(ud)} | {_pct(ud, 74.0)} | "
              f"{f['divergence_status']} |", "",
              f"Critical branch {f['critical_branch']['label'] or '-'}; participation "
              + ", ".join(f"{k} {v:.2f}" for k, v in f["critical_participation"].items())
              + f"; {f['modes_retained']} modes, RFA {f['rfa']}, b = {f['half_chord_m']} m.", "",
              "The flutter speed is close to the paper's because flutter is governed by the "
              "TS1/VS1 frequencies, which are updated to the measured ones. Divergence depends "
              "only on GJ, the cable torsional stiffness 2H(b_c/2)^2 and the aerodynamic moment "
              "(rho U^2 b^2): with the estimated b = 11 m and cable spacing 22 m it comes out "
              "higher than 74 m/s; a wider aerodynamic chord lowers it as 1/b (see the "
              "sensitivity section)."]
    if "design" in r and isinstance(r["design"].get("coefficients"), dict):
        L += _design_section(r["design"])
    L += ["", "## Figures", ""]
    captions = {
        "frequency_ratio": ("Fig. 2", "f(TS1)/f(VS1) against deck completion with half and full "
                            "GJ. Same construction as the paper (EI = 0, GJ halved while "
                            "erecting); differences come from our estimated deck inertia and "
                            "the paper's unknown mode pairing at small fractions."),
        "flutter": ("Fig. 3 (left)", "Root locus 0-100 m/s and damping/frequency of the tracked "
                    "branches. As in the paper TS1 softens and couples with VS1/VS2; the real "
                    "divergence root appears later than the paper's 74 m/s (estimated b and "
                    "cable spacing)."),
        "erection": ("Fig. 3 (right)", "Flutter and divergence against deck completion. The "
                     "paper compares with Brancaleoni's findings, which we do not have as "
                     "numbers; the low speeds at small fractions follow from the low torsional "
                     "frequency of the half-GJ, EI = 0 partial deck."),
        "buffeting": ("Fig. 4", "Vertical RMS over 2b against wind speed (sigma_w/U = 0.07, "
                      "C_L' = 2.5). The measured curve of the paper's ref. [6] is not available "
                      "as numbers, so only our curve is shown."),
        "design": ("Fig. 5", "Closed loop with the optimised flap compensator: root locus "
                   "0-85 m/s and buffeting with and without flaps; followed by the margins "
                   "per speed with the flap layout, and the Bode plot of K(s) with the gain "
                   "limit."),
        "sensitivity": ("(extra)", "Tornado of relative derivatives (p/U) dU/dp by the "
                        "implicit-function theorem, checked by finite differences."),
        "modes": ("(extra)", "Mode shapes of the complete bridge."),
    }
    for kind in res.statuses:
        fig_no, text = captions.get(kind, ("", ""))
        names = figures.get(kind, [])
        L.append(f"### {fig_no}: {kind}")
        L.append("")
        if names:
            L += [f"![{kind}]({n})" for n in names]
            L += ["", text]
        else:
            L.append(f"No figure: {res.statuses[kind]}.")
        L.append("")
    if "sensitivity" in r and "derivatives" in r["sensitivity"]:
        L += ["## Sensitivities (implicit-function theorem)", "",
              "| parameter | value | dU_F/dp (IFT) | full FD | (p/U_F) dU_F/dp | "
              "(p/U_D) dU_D/dp | status |", "|---|---|---|---|---|---|---|"]
        for p, d in r["sensitivity"]["derivatives"].items():
            L.append(f"| {p} | {d['value']:.4g} | {_fmt(d['d_flutter_speed'], '.4g')} | "
                     f"{_fmt(d['d_flutter_speed_fd'], '.4g')} | "
                     f"{_fmt(d['relative_d_flutter_speed'], '+.3f')} | "
                     f"{_fmt(d['relative_d_divergence_speed'], '+.3f')} | "
                     f"{d['flutter_status']}/{d['divergence_status']} |")
    return "\n".join(L) + "\n"


def _design_section(d: dict) -> list[str]:
    """Report lines for the flap-compensator design (seed §6, Fig. 5)."""
    c = d["coefficients"]
    L = ["", "## Flap compensator (seed §6, Fig. 5)", "",
         f"Controller file: `{d.get('controller_file', '-')}` (use it with "
         "`bridgeflap flutter|buffeting|state-space --controller`).", "",
         f"K(s) = ({c['b2']:.4g} s^2 {c['b1']:+.4g} s {c['b0']:+.4g}) / "
         f"({c['a2']:.4g} s^2 {c['a1']:+.4g} s + 1), driving {d.get('flap_count')} LE+TE flap "
         "pairs from the local deck pitch (LE and TE antisymmetric).", "",
         "| quantity | value |", "|---|---|",
         f"| design status | {d.get('status')} |",
         f"| max gain, sup over w of abs K(jw) | {_fmt(d.get('max_gain'), '.3f')} (limit "
         f"{d.get('gain_limit')}) |",
         f"| closed loop stable to [m/s] (dense 16-mode check) | "
         f"{_fmt(d.get('closed_loop_stable_to_m_s'), '.2f')} |",
         f"| robust margin 1 / max norm(T, inf) | {_fmt(d.get('robust_margin'), '.3f')} |",
         f"| minimum flap count (same K) | {(d.get('minimum_flaps') or {}).get('minimum')} |",
         f"| wall time [s] | {_fmt(d.get('wall_time_s'), '.1f')} |"]
    starts = d.get("starts") or []
    if starts:
        L += ["", "Every Ipopt start:", "",
              "| start | Ipopt status | iterations | time [s] | max gain | margin | "
              "stable 0-85 m/s |", "|---|---|---|---|---|---|---|"]
        for st in starts:
            L.append(f"| {st.get('start')} | {st.get('status')} | {st.get('iterations')} | "
                     f"{_fmt(st.get('time_s'), '.1f')} | {_fmt(st.get('max_gain'), '.3f')} | "
                     f"{_fmt(st.get('robust_margin'), '.3f')} | "
                     f"{st.get('stable_everywhere')} |")
    buf = d.get("buffeting") or {}
    if buf.get("speeds_m_s"):
        L += ["", "Buffeting, open vs closed loop (max vertical RMS on the main span):", "",
              "| U [m/s] | open loop [m] | closed loop [m] | change |", "|---|---|---|---|"]
        for u, o, cl in zip(buf["speeds_m_s"], buf["open_loop_rms_vertical_m"],
                            buf["closed_loop_rms_vertical_m"], strict=False):
            L.append(f"| {u:g} | {_fmt(o, '.4f')} | {_fmt(cl, '.4f')} | {_pct(cl, o)} |")
    L += ["", "The paper hand-tunes one compensator and shows its root locus; here Ipopt "
          "maximises the robust margin subject to eigenvalue constraints at every design "
          "speed and the gain limit, and the result is verified on a 0.25 m/s grid."]
    return L


def _pct(x, ref) -> str:
    if x is None or not np.isfinite(x):
        return "-"
    return f"{100 * (x - ref) / ref:+.1f} %"


# ============================================================================ DOE

_DESIGN_ALIASES = {"full-factorial": "full_factorial", "full_factorial": "full_factorial",
                   "latin-hypercube": "latin_hypercube", "latin_hypercube": "latin_hypercube",
                   "lhs": "latin_hypercube", "sobol": "sobol"}
_DOE_KEYS = {"name", "bridge", "analysis", "options", "design", "parameters", "quick",
             "description"}


@dataclass(frozen=True)
class DoeConfig:
    """A resolved DOE definition: bridge, analysis and its options, design and parameters."""

    name: str
    bridge: str
    analysis: str
    options: dict
    kind: str
    parameters: dict  # path -> {"range": (lo, hi)} or {"values": [...]}
    levels: int = 3
    n: int = 16
    seed: int = 1
    quick: bool = False
    source: str = ""

    def as_dict(self) -> dict:
        """JSON-ready resolved configuration."""
        return {"name": self.name, "bridge": self.bridge, "analysis": self.analysis,
                "options": dict(self.options), "kind": self.kind,
                "parameters": {k: dict(v) for k, v in self.parameters.items()},
                "levels": self.levels, "n": self.n, "seed": self.seed, "quick": self.quick,
                "source": self.source}

    def cases(self) -> list[dict]:
        """The design's cases (``case_id`` + parameter values)."""
        from design.doe import make_design

        if self.kind == "full_factorial":
            levels = {}
            for p, d in self.parameters.items():
                levels[p] = (list(d["values"]) if "values" in d else
                             np.linspace(d["range"][0], d["range"][1], self.levels).tolist())
            return make_design("full_factorial", levels=levels)
        return make_design(self.kind, ranges={p: tuple(d["range"])
                                              for p, d in self.parameters.items()},
                           n=self.n, seed=self.seed)

    def case_function(self):
        """The picklable case function with its settings bound."""
        from design.cases import ANALYSES

        fn, _ = ANALYSES[self.analysis]
        return functools.partial(fn, bridge=self.bridge, **self.options)


def _int(value, field_name, minimum=1) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise BridgeflapInputError(field_name, f"must be an integer >= {minimum}, got {value!r}")
    return value


def load_doe(path: str | os.PathLike, quick: bool = False) -> DoeConfig:
    """Read and validate a DOE TOML file.

    Format::

        name = "doe_gj_sag"
        bridge = "humber"
        analysis = "flutter"                  # flutter | modes | buffeting
        [options]                             # options of the case function
        speeds = "0:120:1"
        modes = 10
        [design]
        kind = "full-factorial"               # | "latin-hypercube" | "sobol"
        levels = 3                            # full factorial: points per range
        n = 16                                # latin hypercube / sobol: cases
        seed = 1
        [parameters]                          # dotted paths of model.spec.PARAMETER_PATHS
        "deck.gj_nm2" = [3.0e11, 4.5e11]      # range [lo, hi]
        "cable.main_sag_m" = { values = [110.0, 115.0, 120.0] }   # explicit levels
        [quick]                               # --quick overrides
        design = { levels = 2 }
        options = { speeds = "0:120:2" }

    Raises
    ------
    BridgeflapInputError
        Unknown key, analysis, design kind or parameter, empty range or level list.
    """
    p = Path(path)
    data = _read_toml(p, "doe")
    return doe_from_dict(data, base=p.parent, quick=quick, source=str(p))


def doe_from_dict(data: Mapping, base: Path | None = None, quick: bool = False,
                  source: str = "<dict>") -> DoeConfig:
    """Build a :class:`DoeConfig` from parsed TOML (see :func:`load_doe`)."""
    from design.cases import ANALYSES, ERECTED_FRACTION
    from model.spec import PARAMETER_PATHS

    base = Path.cwd() if base is None else base
    unknown = set(data) - _DOE_KEYS
    if unknown:
        raise BridgeflapInputError(sorted(unknown)[0], "unknown key in the DOE file")
    name = _name(data.get("name"))
    bridge = _resolve_bridge(data.get("bridge", "humber"), base)
    analysis = data.get("analysis", "flutter")
    if analysis not in ANALYSES:
        raise BridgeflapInputError("analysis", f"unknown analysis {analysis!r} (known: "
                                               f"{', '.join(ANALYSES)})")
    qk = data.get("quick", {})
    if not isinstance(qk, dict) or set(qk) - {"design", "options"}:
        raise BridgeflapInputError("quick", "must be a table with 'design' and/or 'options'")
    options = dict(data.get("options", {}))
    design = dict(data.get("design", {}))
    if quick:
        options.update(qk.get("options", {}))
        design.update(qk.get("design", {}))
    allowed = ANALYSES[analysis][1]
    if allowed is not None:
        for key in options:
            if key not in allowed:
                raise BridgeflapInputError(f"options.{key}", f"not an option of {analysis} "
                                                             f"(known: {', '.join(allowed)})")
    _check_options(analysis, options)
    if set(design) - {"kind", "levels", "n", "seed"}:
        bad = sorted(set(design) - {"kind", "levels", "n", "seed"})[0]
        raise BridgeflapInputError(f"design.{bad}", "unknown design option")
    kind = _DESIGN_ALIASES.get(design.get("kind", "full-factorial"))
    if kind is None:
        raise BridgeflapInputError("design.kind", f"unknown design {design.get('kind')!r} "
                                                  "(full-factorial, latin-hypercube, sobol)")
    levels = _int(design.get("levels", 3), "design.levels")
    n = _int(design.get("n", 16), "design.n")
    seed = _int(design.get("seed", 1), "design.seed", 0)
    raw = data.get("parameters")
    if not isinstance(raw, dict) or not raw:
        raise BridgeflapInputError("parameters", "at least one parameter range is needed")
    params = {}
    for path, spec in raw.items():
        fld = f"parameters.{path}"
        if path not in PARAMETER_PATHS and path != ERECTED_FRACTION:
            raise BridgeflapInputError(fld, f"unknown parameter (known: "
                                            f"{', '.join(PARAMETER_PATHS)}, {ERECTED_FRACTION})")
        if isinstance(spec, dict) and set(spec) == {"values"}:
            vals = spec["values"]
            if not isinstance(vals, list) or not vals:
                raise BridgeflapInputError(fld, "empty list of values")
            if not all(isinstance(v, int | float) and not isinstance(v, bool)
                       and np.isfinite(v) for v in vals):
                raise BridgeflapInputError(fld, "values must be finite numbers")
            if kind != "full_factorial":
                raise BridgeflapInputError(fld, f"explicit values need a full-factorial design, "
                                                f"not {kind}")
            params[path] = {"values": [float(v) for v in vals]}
            continue
        if not (isinstance(spec, list) and len(spec) == 2 and all(
                isinstance(v, int | float) and not isinstance(v, bool) for v in spec)):
            raise BridgeflapInputError(fld, "expected a range [lo, hi] or {values = [...]}")
        lo, hi = float(spec[0]), float(spec[1])
        if not (np.isfinite(lo) and np.isfinite(hi)) or not lo < hi:
            raise BridgeflapInputError(fld, f"empty range [{lo}, {hi}] (need lo < hi)")
        params[path] = {"range": (lo, hi)}
    return DoeConfig(name=name, bridge=bridge, analysis=analysis, options=options, kind=kind,
                     parameters=params, levels=levels, n=n, seed=seed, quick=bool(quick),
                     source=source)


@dataclass(frozen=True)
class DoeResult:
    """Outcome of :func:`run_doe`: counts, the table and the case records."""

    config: DoeConfig
    out_dir: Path
    cases: int
    succeeded: int
    failed: int
    reused: int
    table: Path
    rows: tuple

    def summary(self) -> dict:
        """The ``bridgeflap doe --json`` contract."""
        return {"name": self.config.name, "analysis": self.config.analysis,
                "cases": self.cases, "succeeded": self.succeeded, "failed": self.failed,
                "reused": self.reused, "table": str(self.table), "out_dir": str(self.out_dir),
                "statuses": {r["case_id"]: r["status"] for r in self.rows}}

    def plot(self, ax=None, output: str | None = None):
        """Scatter of an output over the first two parameters (failed cases as crosses)."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 4.5))
        names = list(self.config.parameters)
        ok = [r for r in self.rows if r["status"] == "ok"]
        if output is None:
            keys = [k for k in (ok[0]["result"] if ok else {})
                    if isinstance(ok[0]["result"][k], int | float)]
            output = keys[0] if keys else None
        x = np.array([r["params"][names[0]] for r in self.rows], dtype=float)
        y = (np.array([r["params"][names[1]] for r in self.rows], dtype=float)
             if len(names) > 1 else np.zeros_like(x))
        val = np.array([np.nan if r["result"] is None or r["result"].get(output) is None
                        else r["result"][output] for r in self.rows], dtype=float)
        good = np.isfinite(val)
        sc = ax.scatter(x[good], y[good], c=val[good], cmap="viridis", s=40)
        if good.any():
            plt.colorbar(sc, ax=ax, label=output)
        ax.plot(x[~good], y[~good], "rx", ms=9, label="failed / no crossing")
        ax.set_xlabel(names[0])
        ax.set_ylabel(names[1] if len(names) > 1 else "-")
        ax.set_title(f"{self.config.name}: {self.succeeded}/{self.cases} cases ok", fontsize=9)
        if (~good).any():
            ax.legend(fontsize=8)
        return ax


def run_doe(config: DoeConfig | str | os.PathLike, out: str | os.PathLike | None = None,
            workers: int = 1, scheduler: str | None = None, resume: bool = False,
            quick: bool = False, progress: bool = True) -> DoeResult:
    """Run a DOE through :func:`design.doe.run_batch` (per-case files; resumable).

    The resolved configuration is written as ``doe.json`` next to the batch files; ``resume``
    refuses a folder whose ``doe.json`` has other settings (their stored cases would not
    belong to this DOE).
    """
    import json

    from design.doe import run_batch
    from design.manifest import build_manifest

    if not isinstance(config, DoeConfig):
        config = load_doe(config, quick=quick)
    cases = config.cases()
    target = Path(out).expanduser().absolute() if out is not None else default_out_dir(
        config.name)
    if target.exists() and not target.is_dir():
        raise BridgeflapInputError("out", f"{target} exists and is not a folder")
    stored_cfg = target / "doe.json"
    if resume and stored_cfg.is_file():
        try:
            stored = json.loads(stored_cfg.read_text("utf-8"))
        except (OSError, ValueError):
            stored = None
        keys = ("bridge", "analysis", "options")
        now = json.loads(json.dumps(config.as_dict()))
        if stored is None or any(stored.get(k) != now[k] for k in keys):
            raise BridgeflapInputError("resume", f"{target} holds a DOE with other settings; "
                                                 "use another --out")
    ensure_writable_dir(target, "out")
    atomic_write_json(stored_cfg, config.as_dict())
    atomic_write_json(target / "manifest.json", build_manifest(config.as_dict()))
    batch = run_batch(config.case_function(), cases, target, workers=workers,
                      scheduler=scheduler, resume=resume, progress=progress)
    reused = json.loads((target / "batch.json").read_text("utf-8")).get("reused", 0)
    return DoeResult(config=config, out_dir=target, cases=batch.cases,
                     succeeded=batch.succeeded, failed=batch.failed, reused=int(reused),
                     table=batch.table_path, rows=batch.rows)
