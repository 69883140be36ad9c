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

__all__ = ["batch_cases"]


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
