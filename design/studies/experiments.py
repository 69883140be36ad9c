"""DOE definition files: configuration, run through the batch runner, result.

A **DOE** file (:func:`load_doe`, :func:`run_doe`) names the bridge, the analysis (one of the
registry :data:`bridgeflap.design.studies.analyses.ANALYSES` that has a case row: flutter, modes,
buffeting), its options, the design kind and the parameter ranges (dotted paths of
:data:`bridgeflap.model.structure.spec.PARAMETER_PATHS`); it runs through
:func:`bridgeflap.design.batch.runner.run_batch` (per-case status, resumable). An option the file
does not give takes the registry's default, the same as the command line's.

A design is refused before anything is allocated when it would have more than
:data:`MAX_DOE_CASES` cases (the product of the level counts of a full factorial, ``n`` of a
sampled design), naming the field. Each case's ``case_hash`` (the key of ``--resume``) covers
the bridge file's content, the analysis, its resolved options (defaults included) and the
bridgeflap version (:func:`doe_fingerprint`), so a folder holding another DOE's cases has them
recomputed, never reused.

The bridge may be an in-memory :class:`~bridgeflap.model.structure.spec.BridgeSpec` (``bridge=`` of
:func:`load_doe` and :func:`run_doe`, or the ``"bridge"`` of :func:`doe_from_dict`): the cases run
on it as it is, and the fingerprint hashes its canonical form
(:func:`bridgeflap.design.io.identity.bridge_identity`).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bridgeflap.design.io.files import output_folder
from bridgeflap.design.io.options import (
    MAX_DOE_CASES,
    check_int,
    check_keys,
    plain_name,
    read_definition,
    resolve_bridge,
    table,
)
from bridgeflap.design.studies.analyses import ANALYSES
from bridgeflap.design.studies.cases import ERECTED_FRACTION, analysis_case
from bridgeflap.model.arguments import (
    check_mapping,
    check_path,
    check_text,
    checked,
    flag,
    instance_or_path,
    optional,
)
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.results import ResultData
from bridgeflap.model.structure.bridge_arg import check_bridge_kind
from bridgeflap.model.structure.spec import PARAMETER_PATHS

__all__ = ["DOE_ANALYSES", "MAX_DOE_CASES", "DoeConfig", "DoeParameter", "DoeResult",
           "doe_fingerprint", "doe_from_dict", "load_doe", "run_doe"]

# MAX_DOE_CASES (design.io.options): at about a second per flutter case, 10^5 cases are already a
# day on one core; a larger study is better split into several DOE folders (and a 10^5-level
# factorial of two parameters, 10^10 cases, would not even fit in memory)

#: registered analyses with a DOE case row
DOE_ANALYSES = tuple(name for name, entry in ANALYSES.items() if entry.case is not None)

#: a DOE file's ``[design] kind``: the canonical names (those of :func:`design.make_design`)
#: and, read as them, the spellings of files written by earlier versions (a published format:
#: runs/doe_gj_sag/doe.toml and users' files; the fingerprint is of the canonical name)
_DESIGN_ALIASES = {"full_factorial": "full_factorial", "latin_hypercube": "latin_hypercube",
                   "sobol": "sobol", "full-factorial": "full_factorial",
                   "latin-hypercube": "latin_hypercube", "lhs": "latin_hypercube"}
_DOE_KEYS = {"name", "bridge", "analysis", "options", "design", "parameters", "quick",
             "description"}


@dataclass(frozen=True)
class DoeParameter:
    """One varied input: a range ``[low, high]`` in its SI unit, or explicit levels."""

    low: float | None = None
    high: float | None = None
    values: tuple[float, ...] | None = None

    def levels(self, count: int) -> list[float]:
        """The explicit levels, or ``count`` equally spaced points of the range."""
        if self.values is not None:
            return list(self.values)
        return np.linspace(self.low, self.high, count).tolist()

    def as_dict(self) -> dict:
        """``{"values": [...]}`` or ``{"range": (low, high)}`` (the file's spelling)."""
        if self.values is not None:
            return {"values": list(self.values)}
        return {"range": (self.low, self.high)}


@dataclass(frozen=True)
class DoeConfig:
    """A resolved DOE definition: bridge, analysis and its options, design and parameters."""

    name: str
    bridge: Any  # a built-in name, an absolute bridge TOML path or a BridgeSpec
    analysis: str
    options: dict
    kind: str
    parameters: dict  # dotted path -> DoeParameter
    levels: int = 3
    n: int = 16
    seed: int = 1
    quick: bool = False
    source: str = ""

    def as_dict(self) -> dict:
        """JSON-ready resolved configuration.

        Returns
        -------
        dict
            The name, the bridge's identity (name, file, hash), the analysis and its options,
            the sampler (``kind``, ``levels``, ``n``, ``seed``), each parameter's range and the
            source file.
        """
        from bridgeflap.design.io.identity import bridge_identity

        return {"name": self.name, **bridge_identity(self.bridge), "analysis": self.analysis,
                "options": dict(self.options), "kind": self.kind,
                "parameters": {k: v.as_dict() for k, v in self.parameters.items()},
                "levels": self.levels, "n": self.n, "seed": self.seed, "quick": self.quick,
                "source": self.source}

    def cases(self) -> list[dict]:
        """The design's cases (``case_id`` + parameter values).

        Returns
        -------
        list of dict
            One per case: ``case_id`` and each parameter path with its value (SI).
        """
        from bridgeflap.design.batch.designs import make_design

        if self.kind == "full_factorial":
            return make_design("full_factorial", levels={
                p: d.levels(self.levels) for p, d in self.parameters.items()})
        return make_design(self.kind, ranges={p: (d.low, d.high)
                                              for p, d in self.parameters.items()},
                           n=self.n, seed=self.seed)

    def case_function(self):
        """The picklable case function with its settings bound.

        Returns
        -------
        functools.partial
            ``analysis_case`` with the analysis, the bridge and the options bound: called with
            a case's parameters, it returns that case's result.
        """
        return functools.partial(analysis_case, analysis=self.analysis, bridge=self.bridge,
                                 **self.options)


@checked(path=check_path, quick=flag, bridge=optional(check_bridge_kind))
def load_doe(path: str | os.PathLike, quick: bool = False, bridge: Any = None) -> DoeConfig:
    """Read and validate a DOE TOML file; ``bridge`` (a name, a bridge TOML path or a
    :class:`~bridgeflap.model.structure.spec.BridgeSpec`) replaces the file's own ``bridge``.

    Format::

        name = "doe_gj_sag"
        bridge = "humber"
        analysis = "flutter"                  # flutter | modes | buffeting
        [options]                             # options of the case function
        speeds = "0:120:1"
        modes = 10                            # (default: the registry's, as `bridgeflap flutter`)
        [design]
        kind = "full_factorial"               # | "latin_hypercube" | "sobol"
        levels = 3                            # full factorial: points per range
        n = 16                                # latin hypercube / sobol: cases
        seed = 1
        [parameters]                          # dotted paths of
        bridgeflap.model.structure.spec.PARAMETER_PATHS "deck.gj_nm2" = [3.0e11, 4.5e11]      #
        range [lo, hi] "cable.main_sag_m" = { values = [110.0, 115.0, 120.0] }   # explicit levels
        [quick]                               # --quick overrides
        design = { levels = 2 }
        options = { speeds = "0:120:2" }

    Parameters
    ----------
    path : str or path-like
        The DOE TOML file.
    quick : bool, default False
        Apply the file's ``[quick]`` overrides.
    bridge : str, path-like or BridgeSpec, optional
        Replaces the file's ``bridge``.

    Returns
    -------
    DoeConfig
        The validated DOE, for :func:`run_doe`.

    Raises
    ------
    BridgeflapInputError
        Unknown key, analysis, design kind or parameter, empty range or level list.
    """
    data, base, source = read_definition(Path(path), "doe")
    if bridge is not None:
        data = {**data, "bridge": bridge}
    return doe_from_dict(data, base=base, quick=quick, source=source)


@checked(data=check_mapping, base=optional(check_path), quick=flag, source=check_text)
def doe_from_dict(data: Mapping, base: Path | None = None, quick: bool = False,
                  source: str = "<dict>") -> DoeConfig:
    """Build a :class:`DoeConfig` from parsed TOML (see :func:`load_doe`).

    Parameters
    ----------
    data : mapping
        The DOE file's tables (``name``, ``bridge``, ``analysis``, ``[options]``, ``[design]``,
        ``[parameters]``; docs/reference/formats/doe.md).
    base : pathlib.Path, optional
        Folder that relative paths in ``data`` are relative to (default: the current one).
    quick : bool, default False
        Apply the ``[quick]`` overrides.
    source : str, default "<dict>"
        Where the data came from, for messages.

    Returns
    -------
    DoeConfig
        The validated DOE: ``parameters``, ``cases()``, ``options``.

    Raises
    ------
    BridgeflapInputError
        Unknown key, analysis, design kind or parameter; empty range or level list.

    Examples
    --------
    >>> from bridgeflap import design
    >>> config = design.doe_from_dict({
    ...     "name": "gj", "bridge": "humber", "analysis": "flutter",
    ...     "design": {"kind": "full_factorial", "levels": 2},
    ...     "parameters": {"deck.gj_nm2": [4.7e11, 7.1e11]}})
    >>> list(config.parameters)
    ['deck.gj_nm2']
    """
    check_keys(data, _DOE_KEYS, "DOE")
    base = Path.cwd() if base is None else base
    name = plain_name(data.get("name"))
    bridge = resolve_bridge(data.get("bridge", "humber"), base)
    analysis = data.get("analysis", "flutter")
    if analysis not in DOE_ANALYSES:
        raise BridgeflapInputError("analysis", f"unknown analysis {analysis!r} (known: "
                                               f"{', '.join(DOE_ANALYSES)})")
    qk = data.get("quick", {})
    if not isinstance(qk, dict) or set(qk) - {"design", "options"}:
        raise BridgeflapInputError("quick", "must be a table with 'design' and/or 'options'")
    options = table(data, "options")
    design = table(data, "design")
    if quick:
        options.update(table(qk, "options"))
        design.update(table(qk, "design"))
    ANALYSES[analysis].resolve(options, what="options")
    if set(design) - {"kind", "levels", "n", "seed"}:
        bad = sorted(set(design) - {"kind", "levels", "n", "seed"})[0]
        raise BridgeflapInputError(f"design.{bad}", "unknown design option")
    kind = _DESIGN_ALIASES.get(design.get("kind", "full_factorial"))
    if kind is None:
        raise BridgeflapInputError("design.kind", f"unknown design {design.get('kind')!r} "
                                                  "(full_factorial, latin_hypercube, sobol)")
    levels = check_int(design.get("levels", 3), "design.levels", 1, MAX_DOE_CASES)
    n = check_int(design.get("n", 16), "design.n", 1, MAX_DOE_CASES)
    seed = check_int(design.get("seed", 1), "design.seed", 0)
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
                raise BridgeflapInputError(fld, f"explicit values need a full_factorial design, "
                                                f"not {kind}")
            params[path] = DoeParameter(values=tuple(float(v) for v in vals))
            continue
        if not (isinstance(spec, list) and len(spec) == 2 and all(
                isinstance(v, int | float) and not isinstance(v, bool) for v in spec)):
            raise BridgeflapInputError(fld, "expected a range [lo, hi] or {values = [...]}")
        lo, hi = float(spec[0]), float(spec[1])
        if not (np.isfinite(lo) and np.isfinite(hi)) or not lo < hi:
            raise BridgeflapInputError(fld, f"empty range [{lo}, {hi}] (need lo < hi)")
        params[path] = DoeParameter(low=lo, high=hi)
    _check_size(kind, params, levels, n)
    from bridgeflap.design.studies.cases import check_applicable

    check_applicable(bridge, {k: (v.values[0] if v.values else v.low)
                              for k, v in params.items()})
    return DoeConfig(name=name, bridge=bridge, analysis=analysis, options=options, kind=kind,
                     parameters=params, levels=levels, n=n, seed=seed, quick=bool(quick),
                     source=source)


def _check_size(kind: str, params: Mapping, levels: int, n: int) -> int:
    """The number of cases of the design; refuse more than :data:`MAX_DOE_CASES`."""
    if kind != "full_factorial":
        if n > MAX_DOE_CASES:
            raise BridgeflapInputError("design.n", f"{n} cases exceed the limit of "
                                                   f"{MAX_DOE_CASES}; split the study")
        return n
    counts = {p: (len(d.values) if d.values is not None else levels) for p, d in params.items()}
    total = math.prod(counts.values())  # Python integers: no overflow, nothing allocated
    if total > MAX_DOE_CASES:
        ranged = [p for p, d in params.items() if d.values is None]
        field = ("design.levels" if ranged and levels > 1
                 else f"parameters.{max(counts, key=counts.get)}")
        raise BridgeflapInputError(field, f"the full factorial has {total} cases (levels "
                                          f"{', '.join(str(c) for c in counts.values())}), "
                                          f"more than the limit of {MAX_DOE_CASES}; split the "
                                          "study")
    return total


@dataclass(frozen=True)
class DoeResult(ResultData):
    """Outcome of :func:`run_doe`: counts, the table and the case records."""

    config: DoeConfig
    out_dir: Path
    cases: int
    succeeded: int
    failed: int
    reused: int
    table_path: Path  # the table.csv (``table()`` is the table as text, ResultData)
    rows: tuple

    def summary(self) -> dict:
        """The ``bridgeflap doe --json`` contract.

        Returns
        -------
        dict
            ``name``, ``analysis``, the case counts (``cases``, ``succeeded``, ``failed``,
            ``reused``), the ``table`` path, ``out_dir`` and each case's status.
        """
        return {"name": self.config.name, "analysis": self.config.analysis,
                "cases": self.cases, "succeeded": self.succeeded, "failed": self.failed,
                "reused": self.reused, "table": str(self.table_path), "out_dir": str(self.out_dir),
                "statuses": {r["case_id"]: r["status"] for r in self.rows}}

    def _headline(self) -> dict:
        return {"name": self.config.name, "bridge": self.config.bridge,
                "analysis": self.config.analysis, "cases": self.cases,
                "succeeded": self.succeeded, "failed": self.failed, "reused": self.reused,
                "status": "ok" if not self.failed else f"{self.failed} failed",
                "table": str(self.table_path)}

    def _rows(self) -> list[dict]:
        """Parameters and results in one flat row per case
        (:func:`bridgeflap.design.batch.runner.flat_case_rows`)."""
        from bridgeflap.design.batch.runner import flat_case_rows

        return flat_case_rows(self.rows)

    def to_xarray(self):
        """The cases on the dimension ``case``: parameters as coordinates, each scalar result a
        variable (:func:`bridgeflap.design.batch.table.cases_dataset`); ``ds.set_index`` or
        ``ds.to_dataframe()`` for a grid.

        Returns
        -------
        xarray.Dataset
            The cases on the dimension ``case`` (NaN for a failed case).
        """
        from bridgeflap.design.batch.table import cases_dataset

        return cases_dataset(self.rows)

    def plot(self, ax=None, output: str | None = None):
        """Scatter of an output over the first two parameters (failed cases as crosses).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axis to draw on (default: a new figure).
        output : str, optional
            Result key to colour by, e.g. ``"flutter_speed_m_s"`` (default: the first numeric
            result of the first successful case).

        Returns
        -------
        matplotlib.figure.Figure
            The figure (:func:`bridgeflap.design.batch.plots.cases_over_inputs`).
        """
        from bridgeflap.design.batch.plots import cases_over_inputs

        return cases_over_inputs(
            self.rows, list(self.config.parameters), ax, output,
            title=f"{self.config.name}: {self.succeeded}/{self.cases} cases ok")


def doe_fingerprint(config: DoeConfig) -> str:
    """What, besides a case's parameters, determines its result: bridge file content (and the
    resolved bridge), analysis, resolved options, bridgeflap version (the ``case_hash`` key)."""
    from bridgeflap.design.batch.runner import _package_version
    from bridgeflap.design.io.identity import bridge_identity
    from bridgeflap.model.structure.loader import _read_source, _split_variant, load_bridge
    from bridgeflap.model.structure.spec import BridgeSpec

    if isinstance(config.bridge, BridgeSpec):  # in memory: the hash of its canonical form
        ident = bridge_identity(config.bridge)
    else:
        content = _read_source(_split_variant(config.bridge)[0])[0].encode("utf-8")
        ident = {"bridge": config.bridge, "bridge_sha256": hashlib.sha256(content).hexdigest()}
    payload = {**ident,
               # every resolved value (variants applied); no object addresses, which differ
               # from one process to the next
               "bridge_resolved": re.sub(r" at 0x[0-9a-fA-F]+", "",
                                         repr(load_bridge(config.bridge))),
               "analysis": config.analysis,
               "options": ANALYSES[config.analysis].resolve(config.options, what="options"),
               "version": _package_version()}
    return json.dumps(payload, sort_keys=True, default=repr)


@checked(config=instance_or_path(DoeConfig, "bridgeflap.design.load_doe"),
         out_dir=optional(check_path),
         scheduler=optional(check_text), resume=flag, quick=flag, progress=flag,
         bridge=optional(check_bridge_kind))
def run_doe(config: DoeConfig | str | os.PathLike,
            out_dir: str | os.PathLike | None = None,
            workers: int = 1, scheduler: str | None = None, resume: bool = False,
            quick: bool = False, progress: bool = True, bridge: Any = None) -> DoeResult:
    """Run a DOE through :func:`bridgeflap.design.batch.runner.run_batch` (per-case files;
    resumable).

    ``config``: a :class:`DoeConfig` or a DOE file path; ``out_dir``: the output folder
    (``bridgeflap doe --out``; default ``runs/<name>/output``); ``bridge`` (a name, a bridge TOML
    path or a :class:`~bridgeflap.model.structure.spec.BridgeSpec`) replaces the file's bridge (a
    path only; for a loaded config use ``load_doe(path, bridge=...)``).

    The resolved configuration is written as ``doe.json`` (and ``manifest.json``) next to the
    batch files, after the scheduler is reachable. ``resume`` reuses only cases whose
    ``case_hash`` (:func:`doe_fingerprint` and the parameters) matches; a folder holding
    another DOE has its cases recomputed (said on stderr). The folder rules (foreign folder
    refused, one run at a time) are those of :func:`bridgeflap.design.batch.runner.run_batch`.

    Parameters
    ----------
    config : DoeConfig, str or path-like
        A loaded DOE or the path of a DOE file.
    out_dir : str or path-like, optional
        The output folder (default ``runs/<name>/output``).
    workers : int, default 1
        Local worker processes (a local Dask cluster; in a script, under
        ``if __name__ == "__main__":``).
    scheduler : str, optional
        ``"serial"`` (in this process), ``"local"``, or a Dask scheduler address
        ``"tcp://host:8786"`` (reached within 5 s before anything is written).
    resume : bool, default False
        Reuse the finished cases of ``out_dir`` whose ``case_hash`` matches.
    quick : bool, default False
        Apply the file's ``[quick]`` overrides (a path only).
    progress : bool, default True
        A progress bar on stderr.
    bridge : str, path-like or BridgeSpec, optional
        Replaces the file's bridge (a path only).

    Returns
    -------
    DoeResult
        ``cases``, ``succeeded``, ``failed``, ``reused``; ``table()``, ``to_dataframe()`` (one
        flat row per case), ``to_xarray()``, ``plot(output=...)`` (an output over the first two
        inputs).

    Raises
    ------
    BridgeflapInputError
        A bad config, folder (another kind of output, not writable) or scheduler.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from bridgeflap import design
    >>> config = design.doe_from_dict({
    ...     "name": "gj", "bridge": "humber", "analysis": "flutter",
    ...     "options": {"speeds": "0:90:5", "modes": 4, "truncation_check": False},
    ...     "design": {"kind": "full_factorial", "levels": 2},
    ...     "parameters": {"deck.gj_nm2": [4.7e11, 7.1e11]}})
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "gj"
    >>> doe = design.run_doe(config, out_dir=out, scheduler="serial", progress=False)
    >>> doe.cases, doe.failed
    (2, 0)
    """
    from bridgeflap.design.batch.runner import run_batch
    from bridgeflap.design.io.manifest import build_manifest

    if not isinstance(config, DoeConfig):
        config = load_doe(config, quick=quick, bridge=bridge)
    elif bridge is not None:
        raise BridgeflapInputError("bridge", "given with a loaded DoeConfig: pass it to "
                                             "load_doe(path, bridge=...) instead")
    _check_size(config.kind, config.parameters, config.levels, config.n)
    ANALYSES[config.analysis].resolve(config.options, what="options")
    cases = config.cases()
    target = output_folder(out_dir, config.name)
    fingerprint = doe_fingerprint(config)
    files = {"doe.json": config.as_dict(), "manifest.json": build_manifest(config.as_dict())}
    batch = run_batch(config.case_function(), cases, target, workers=workers,
                      scheduler=scheduler, resume=resume, progress=progress,
                      fingerprint=fingerprint, files=files, kind="doe", definition="doe.json")
    return DoeResult(config=config, out_dir=target, cases=batch.cases,
                     succeeded=batch.succeeded, failed=batch.failed, reused=batch.reused,
                     table_path=batch.table_path, rows=batch.rows)
