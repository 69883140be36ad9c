"""Global screening of the flutter and divergence speeds (Morris, Sobol') over input ranges.

:func:`global_sensitivity` samples stated ranges of the *estimated* inputs
(docs/humber_data.md#estimated-inputs: NOT FOUND or ESTIMATE) with SALib (Morris elementary effects
or Sobol'/Saltelli), runs the flutter case of every sample through the fault-tolerant batch runner
(:func:`bridgeflap.design.batch.runner.run_batch`), and returns the indices and the 5/50/95 % band
of the flutter and divergence speeds. Local (implicit-function) derivatives are in
:mod:`bridgeflap.design.sensitivity.local`.

It is a study, not a derivative of the model: like a DOE
(:mod:`bridgeflap.design.studies.experiments`) it runs the registry's flutter case
(:func:`bridgeflap.design.studies.cases.flutter_case`, which takes its defaults from
:data:`bridgeflap.design.studies.analyses.ANALYSES`) over a sampling plan, so it sits beside the
registry, which itself runs the local sensitivities. The ranges are
:data:`bridgeflap.design.control.uncertainty.DEFAULT_UNCERTAIN_RANGES` (served from here too) and
the Morris plane is :func:`bridgeflap.design.sensitivity.figures.morris_mu_sigma`.

References
----------
Morris, M. D. (1991), Technometrics 33(2). Saltelli, A. (2002), Comput. Phys. Commun. 145.
Herman, J. & Usher, W. (2017), SALib, JOSS 2(9).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bridgeflap.design.control.uncertainty import DEFAULT_UNCERTAIN_RANGES  # also served from here
from bridgeflap.design.io.files import atomic_write_text
from bridgeflap.model.arguments import check_mapping, check_text, checked, count, flag, optional
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.results import ResultData
from bridgeflap.model.structure.bridge_arg import check_bridge_kind
from bridgeflap.model.structure.spec import PARAMETER_PATHS

__all__ = ["DEFAULT_UNCERTAIN_RANGES", "GlobalSensitivityResult", "global_sensitivity"]

@dataclass(frozen=True)
class GlobalSensitivityResult(ResultData):
    """Global sensitivity indices and uncertainty band of the flutter and divergence speeds.

    Attributes
    ----------
    method : str
        ``"morris"`` (``mu_star``, ``sigma`` [m/s]) or ``"sobol"`` (``S1``, ``ST`` [-]).
    ranges : dict
        Parameter -> (lower, upper) [SI].
    indices : dict
        Output -> parameter -> index dict; or ``{"status": ...}`` when not computable.
    band : dict
        Output -> ``{"p05", "p50", "p95", "min", "max"}`` [m/s] over the finite samples.
    cases, succeeded, failed : int
        Batch counts; ``out_dir`` the batch folder.
    """

    method: str
    ranges: dict
    indices: dict
    band: dict
    cases: int
    succeeded: int
    failed: int
    out_dir: str
    samples: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)), compare=False)
    outputs: dict = field(default_factory=dict, compare=False)

    def summary(self) -> dict:
        """JSON-ready summary.

        Returns
        -------
        dict
            ``method``, each parameter's range (SI), the ``indices`` per output, the 5-50-95 %
            ``band`` of each speed [m/s], the case counts and ``out_dir``.
        """
        return {"method": self.method, "ranges": {k: list(v) for k, v in self.ranges.items()},
                "indices": self.indices, "band": self.band, "cases": self.cases,
                "succeeded": self.succeeded, "failed": self.failed, "out_dir": self.out_dir}

    def _headline(self) -> dict:
        out = {"method": self.method, "parameters": len(self.ranges), "cases": self.cases,
               "succeeded": self.succeeded, "failed": self.failed}
        for q in ("flutter_speed_m_s", "divergence_speed_m_s"):
            b = self.band.get(q) or {}
            out[f"{q[:-10]}_p05_p95_m_s"] = (f"{b['p05']:.4g} .. {b['p95']:.4g}"
                                             if b.get("p05") is not None else None)
        out["status"] = "ok" if not self.failed else f"{self.failed} failed"
        return out

    def _rows(self) -> list[dict]:
        """One row per output x parameter: Morris ``mu_star_m_s``, ``mu_m_s``, ``sigma_m_s``,
        ``mu_star_conf_m_s``; Sobol' ``S1_index``, ``ST_index`` and their ``_conf`` [-]."""
        unit = "_m_s" if self.method == "morris" else "_index"
        rows = []
        for out, idx in self.indices.items():
            for name, vals in idx.items():
                if isinstance(vals, dict):
                    row = {"output": out, "parameter": name}
                    for k, v in vals.items():
                        stem, conf = (k[:-5], "_conf") if k.endswith("_conf") else (k, "")
                        row[f"{stem}{unit}{conf}"] = v
                    rows.append(row)
        return rows

    def write_indices(self, folder) -> Path | None:
        """Write the indices as ``indices.csv`` (:meth:`to_dataframe`) into ``folder``; None
        when none were computed.

        Parameters
        ----------
        folder : str or pathlib.Path
            An existing folder.

        Returns
        -------
        pathlib.Path or None
            The file written, or None when no index was computed.
        """
        rows = self._rows()
        if not rows:
            return None
        import pandas as pd

        path = Path(folder) / "indices.csv"
        atomic_write_text(path, pd.DataFrame(rows).to_csv(index=False))
        return path

    def plot(self, axes=None):
        """Index bars per output, the Morris ``sigma``-``mu*`` plane (Morris only) and the
        histograms of the two speeds, left to right.

        Parameters
        ----------
        axes : sequence of matplotlib.axes.Axes, optional
            Three axes for Morris, two for Sobol' (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        import matplotlib.pyplot as plt

        morris = self.method == "morris"
        if axes is None:
            _, axes = plt.subplots(1, 3 if morris else 2, figsize=(17 if morris else 12, 4.6),
                                   layout="constrained")
        ax0, ax1 = axes[0], axes[-1]
        names = list(self.ranges)
        y = np.arange(len(names))
        key = "mu_star" if morris else "ST"
        for j, (out, col) in enumerate((("flutter_speed_m_s", "C3"),
                                        ("divergence_speed_m_s", "C0"))):
            idx = self.indices.get(out, {})
            vals = [idx.get(n, {}).get(key, np.nan) if isinstance(idx.get(n), dict) else np.nan
                    for n in names]
            ax0.barh(y + (0.2 if j == 0 else -0.2), vals, height=0.4, color=col,
                     label=out.replace("_speed_m_s", ""))
            data = np.asarray(self.outputs.get(out, []), dtype=float)
            data = data[np.isfinite(data)]
            if data.size:
                ax1.hist(data, bins=20, alpha=0.6, color=col,
                         label=f"{out.replace('_speed_m_s', '')}: 5-95 % "
                               f"{self.band[out]['p05']:.1f}-{self.band[out]['p95']:.1f} m/s")
        if morris:
            from bridgeflap.design.sensitivity.figures import morris_mu_sigma

            morris_mu_sigma(axes[1], self.indices)
        ax0.set_yticks(y)
        ax0.set_yticklabels(names, fontsize=8)
        ax0.set_xlabel("Morris μ* [m/s]" if morris else "Sobol total index ST [-]")
        ax0.legend(fontsize=8)
        ax0.grid(alpha=0.3, axis="x")
        ax1.set_xlabel("critical wind speed [m/s]")
        ax1.set_ylabel("samples")
        ax1.legend(fontsize=8)
        ax1.set_title(f"{self.method}: {self.succeeded}/{self.cases} cases ok", fontsize=9)
        return axes


def _salib_problem(ranges: Mapping[str, tuple[float, float]]) -> dict:
    names = list(ranges)
    for n in names:
        if n not in PARAMETER_PATHS:
            raise BridgeflapInputError("ranges", f"unknown parameter {n!r}")
        lo, hi = (float(v) for v in ranges[n])
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise BridgeflapInputError(f"ranges.{n}", f"empty range ({lo}, {hi})")
    return {"num_vars": len(names), "names": names,
            "bounds": [[float(ranges[n][0]), float(ranges[n][1])] for n in names]}


def _band(y: np.ndarray) -> dict:
    y = y[np.isfinite(y)]
    if y.size == 0:
        return {"p05": np.nan, "p50": np.nan, "p95": np.nan, "min": np.nan, "max": np.nan,
                "finite": 0}
    p = np.percentile(y, [5, 50, 95])
    return {"p05": p[0], "p50": p[1], "p95": p[2], "min": y.min(), "max": y.max(),
            "finite": int(y.size)}


@checked(bridge=check_bridge_kind, ranges=optional(check_mapping), method=check_text,
         n=count(1, 100000), seed=count(0, 2**32 - 1), scheduler=optional(check_text),
         resume=flag, case_options=optional(check_mapping), progress=flag)
def global_sensitivity(bridge="humber",
                       ranges: Mapping[str, tuple[float, float]] | None = None,
                       method: str = "morris", n: int = 8, seed: int = 1,
                       out_dir: str | Path = "gsa", workers: int = 1,
                       scheduler: str | None = None, resume: bool = False,
                       case_options: Mapping | None = None,
                       progress: bool = True) -> GlobalSensitivityResult:
    """Morris or Sobol' indices of ``U_F`` and ``U_D`` through the DOE batch runner.

    Parameters
    ----------
    bridge : str or BridgeSpec
        Built-in name, bridge TOML path (loaded by each case) or an in-memory spec (sent to
        each case as it is, e.g. ``load_bridge("humber").replace(**{"deck.gj_nm2": ...})``);
        the batch fingerprint hashes the spec, so ``resume`` never mixes two specs.
    ranges : mapping
        Parameter path -> (lower, upper) [SI]; default :data:`DEFAULT_UNCERTAIN_RANGES`.
    method : {"morris", "sobol"}
        Morris: ``n`` trajectories, ``n (k + 1)`` cases, 4 levels. Sobol: Saltelli sample of base
        size ``n`` (a power of two), ``n (k + 2)`` cases, first and total indices.
    out_dir : path
        Batch folder (``cases/``, ``table.csv``, ``batch.json``; resumable).
    case_options : mapping
        Keyword options of :func:`bridgeflap.design.studies.cases.flutter_case` (``speeds``,
        ``modes``, ...).

    Returns
    -------
    GlobalSensitivityResult
        Per input and output (``U_F``, ``U_D``): Morris ``mu*`` and ``sigma`` or Sobol' first
        and total indices, each with its 5/50/95 % bootstrap band; ``table()``,
        ``to_dataframe()``, ``plot()``, and the batch folder.

    Raises
    ------
    BridgeflapInputError
        A bad bridge, range, method, ``n`` (Sobol': a power of two), folder or scheduler.

    Notes
    -----
    A case whose crossing is not found (status other than converged) gives NaN; the indices of
    that output are then not computed (SALib needs every sample) and its status says why. The
    band is over the finite samples; for Morris the sample is a set of one-at-a-time
    trajectories on a 4-level grid, uniform in each marginal, so the band is indicative; the
    Sobol' (Saltelli) sample is quasi-random uniform on the box.
    """
    from bridgeflap.design.batch.runner import run_batch
    from bridgeflap.design.studies.cases import check_applicable, flutter_case

    ranges = dict(DEFAULT_UNCERTAIN_RANGES if ranges is None else ranges)
    problem = _salib_problem(ranges)
    check_applicable(bridge, {k: v[0] for k, v in ranges.items()})
    if method not in ("morris", "sobol"):
        raise BridgeflapInputError("method", f"must be 'morris' or 'sobol', got {method!r}")
    if isinstance(n, bool) or not isinstance(n, int) or n < 2:
        raise BridgeflapInputError("n", f"must be an integer >= 2, got {n!r}")
    if method == "morris":
        from SALib.sample import morris as sampler

        X = sampler.sample(problem, n, num_levels=4, seed=seed)
    else:
        if n & (n - 1):
            raise BridgeflapInputError("n", f"Sobol base sample must be a power of two, got {n}")
        from SALib.sample import sobol as sampler

        X = sampler.sample(problem, n, calc_second_order=False, seed=seed)
    names = problem["names"]
    cases = [{"case_id": f"case-{i:04d}", **{k: float(v) for k, v in zip(names, row,
                                                                           strict=True)}}
             for i, row in enumerate(X)]
    from bridgeflap.model.structure.spec import BridgeSpec

    bridge = bridge if isinstance(bridge, BridgeSpec) else str(bridge)
    fn = functools.partial(flutter_case, bridge=bridge, **dict(case_options or {}))
    batch = run_batch(fn, cases, out_dir, workers=workers, scheduler=scheduler, resume=resume,
                      progress=progress)
    outputs, indices, band = {}, {}, {}
    for out in ("flutter_speed_m_s", "divergence_speed_m_s"):
        y = np.array([np.nan if (r["result"] is None or r["result"].get(out) is None)
                      else r["result"][out] for r in batch.rows], dtype=float)
        outputs[out] = y
        band[out] = _band(y)
        if not np.all(np.isfinite(y)):
            indices[out] = {"status": f"not computed: {int(np.sum(~np.isfinite(y)))} of "
                                      f"{y.size} cases without a converged {out}"}
            continue
        if np.ptp(y) == 0:
            indices[out] = {"status": "not computed: output constant over the sample"}
            continue
        if method == "morris":
            from SALib.analyze import morris as analyzer

            res = analyzer.analyze(problem, X, y, num_levels=4, seed=seed)
            indices[out] = {nm: {"mu_star": float(res["mu_star"][i]),
                                 "mu": float(res["mu"][i]), "sigma": float(res["sigma"][i]),
                                 "mu_star_conf": float(res["mu_star_conf"][i])}
                            for i, nm in enumerate(names)}
        else:
            from SALib.analyze import sobol as analyzer

            res = analyzer.analyze(problem, y, calc_second_order=False, seed=seed)
            indices[out] = {nm: {"S1": float(res["S1"][i]), "ST": float(res["ST"][i]),
                                 "S1_conf": float(res["S1_conf"][i]),
                                 "ST_conf": float(res["ST_conf"][i])}
                            for i, nm in enumerate(names)}
        indices[out]["status"] = "ok"
    res = GlobalSensitivityResult(method=method, ranges={k: tuple(v) for k, v in ranges.items()},
                                  indices=indices, band=band, cases=batch.cases,
                                  succeeded=batch.succeeded, failed=batch.failed,
                                  out_dir=str(batch.table_path.parent), samples=X,
                                  outputs=outputs)
    res.write_indices(batch.table_path.parent)  # mu*, sigma (or S1, ST) next to table.csv
    return res
