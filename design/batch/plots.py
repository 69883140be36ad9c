"""The plot of a batch: one numeric output per case, failed cases marked
(:meth:`bridgeflap.design.batch.runner.BatchResult.plot`).

Like every result plot it takes the result and an optional matplotlib axis (a new figure when
None), draws, and returns the axis; matplotlib is imported here only, and nothing calls
``plt.show()`` (STYLE.md: compute, then plot). Failed cases are marked, never clipped. Like the
runner, it knows no physics.
"""

from __future__ import annotations

import numpy as np

from bridgeflap.model.axes import axes_or_new as _axes
from bridgeflap.model.axes import number_or_nan as _number

__all__ = ["batch_cases", "cases_over_inputs"]


def batch_cases(batch, ax=None, output: str | None = None):
    """One numeric output of each case of a :class:`bridgeflap.design.batch.runner.BatchResult`
    (default: the first numeric entry of the first successful case), failed cases as red crosses at
    zero."""
    ax = _axes(ax)
    ok = [r.get("result") or {} for r in batch.rows if r["status"] == "ok"]
    if output is None:
        output = next((k for k, v in (ok[0] if ok else {}).items()
                       if not np.isnan(_number(v))), None)
    y = [_number((r.get("result") or {}).get(output)) if r["status"] == "ok" else np.nan
         for r in batch.rows]
    x = np.arange(len(batch.rows))
    ax.plot(x, y, "o", color="C0", label="ok")
    bad = [i for i, r in enumerate(batch.rows) if r["status"] != "ok"]
    ax.plot(bad, np.zeros(len(bad)), "x", color="C3", label="failed or timed out")
    ax.set_xticks(x, [r["case_id"] for r in batch.rows], rotation=90, fontsize=7)
    ax.set_ylabel(output or "(no numeric output)")
    ax.set_title(f"batch of {batch.cases} cases ({batch.failed} failed)")
    ax.legend(fontsize=8)
    return ax


def cases_over_inputs(rows, names, ax=None, output: str | None = None, title: str = ""):
    """One numeric output of each case over the cases' inputs (a DOE's plot).

    Parameters
    ----------
    rows : list of dict
        Case records (``case_id``, ``params``, ``status``, ``result``), as a DOE or batch
        writes them into ``cases/<case_id>.json``.
    names : sequence of str
        The inputs (keys of ``params``): the first is the x axis, the second (if any) the y
        axis; with one input the output is the y axis.
    ax : matplotlib.axes.Axes, optional
        Axis to draw on (default: a new figure).
    output : str, optional
        Result key to show (default: the first numeric entry of the first successful case).
    title : str, optional
        Axis title; default ``"<ok>/<cases> cases ok"``.

    Returns
    -------
    matplotlib.axes.Axes
        The axis drawn on. Failed cases, and cases without a number for ``output``, are red
        crosses at their inputs.
    """
    import matplotlib.pyplot as plt

    ax = _axes(ax)
    names = list(names)
    ok = [r.get("result") or {} for r in rows if r.get("status") == "ok"]
    if output is None:
        output = next((k for k, v in (ok[0] if ok else {}).items()
                       if not np.isnan(_number(v))), None)
    x = np.array([_number(r["params"].get(names[0])) for r in rows], dtype=float)
    val = np.array([_number((r.get("result") or {}).get(output)) if r.get("status") == "ok"
                    else np.nan for r in rows], dtype=float)
    good = np.isfinite(val)
    if len(names) > 1:
        y = np.array([_number(r["params"].get(names[1])) for r in rows], dtype=float)
        sc = ax.scatter(x[good], y[good], c=val[good], cmap="viridis", s=40)
        if good.any():
            plt.colorbar(sc, ax=ax, label=output)
        ax.plot(x[~good], y[~good], "rx", ms=9, label="failed / no crossing")
        ax.set_ylabel(names[1])
    else:
        ax.plot(x[good], val[good], "o", color="C0", label="ok")
        ax.plot(x[~good], np.zeros(int((~good).sum())), "rx", ms=9,
                label="failed / no crossing")
        ax.set_ylabel(output or "(no numeric output)")
    ax.set_xlabel(names[0])
    ax.set_title(title or f"{int(good.sum())}/{len(rows)} cases ok", fontsize=9)
    if (~good).any():
        ax.legend(fontsize=8)
    return ax
