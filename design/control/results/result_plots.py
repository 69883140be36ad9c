"""Plots of the design results that have no figure of their own in
:mod:`bridgeflap.design.control.results.figures` (the batch plot is
:mod:`bridgeflap.design.batch.plots`).

Each takes the result and an optional matplotlib axis (a new figure when None), draws, and
returns the axis; matplotlib is imported here only, and nothing calls ``plt.show()``
(STYLE.md: compute, then plot). Unstable or failed entries are left out or marked, never clipped.
"""

from __future__ import annotations

import numpy as np

from bridgeflap.model.axes import axes_or_new as _axes
from bridgeflap.model.axes import number_or_nan as _number

__all__ = ["erection_stages", "harm_ratios", "pair_failures"]


def harm_ratios(harm, ax=None):
    """Histogram of closed- over open-loop critical speed [-] of a
    :class:`bridgeflap.design.assessment.harm.HarmResult`'s variants, with the no-harm line at 1."""
    ax = _axes(ax)
    r = np.array([_number(x["closed_over_open"]) for x in harm.rows], float)
    ax.hist(r[np.isfinite(r)], bins=max(5, min(30, len(harm.rows) // 2)), color="C0")
    ax.axvline(1.0, color="C3", lw=1, label="closed loop = open loop")
    ax.set_xlabel("closed-loop / open-loop critical speed [-]")
    ax.set_ylabel("variants")
    ax.set_title(f"{harm.bridge}: do-no-harm over {len(harm.rows)} variants")
    ax.legend(fontsize=8)
    return ax


def pair_failures(res, ax=None):
    """Critical speed [m/s] with each flap pair of a
    :class:`bridgeflap.design.assessment.failsafe.FailSafeResult`
    failed, against the pair's position from mid-span [m]; intact and design speeds as lines."""
    ax = _axes(ax, (7.0, 4.0))
    x = np.array([r["position_m"] for r in res.rows], float)
    u = [_number(r["critical_speed_m_s"]) for r in res.rows]
    width = 0.6 * (np.ptp(x) / (x.size - 1) if x.size > 1 and np.ptp(x) > 0 else 10.0)
    ax.bar(x, u, width=width, color="C0", label="one pair failed")
    for v, name, c in ((res.intact["critical_speed_m_s"], "intact", "C2"),
                       (res.speed_max_m_s, "design speed", "C3")):
        if v is not None:
            ax.axhline(v, color=c, lw=1, label=name)
    ax.set_xlabel("failed pair position from mid-span [m]")
    ax.set_ylabel("critical wind speed [m/s]")
    ax.set_title(f"{res.bridge}: single-pair failures ({res.status})")
    ax.legend(fontsize=8)
    return ax


def erection_stages(res, ax=None):
    """Open- and closed-loop critical speeds [m/s] of a
    :class:`bridgeflap.design.assessment.erection_control.ErectionControlResult` against the erected
    fraction [%];
    the completed bridge is its own marker at 100 %."""
    ax = _axes(ax)
    stages = [r for r in res.rows if r.get("stage") != "completed bridge"]
    done = [r for r in res.rows if r.get("stage") == "completed bridge"]
    f = [100 * r["erected_fraction"] for r in stages]
    for loop, mark, c in (("open_loop", "s--", "C1"), ("closed_loop", "o-", "C0")):
        ax.plot(f, [_number(r[f"{loop}_critical_speed_m_s"]) for r in stages], mark, color=c,
                label=loop.replace("_", " "))
        if done:
            ax.plot([100], [_number(done[0][f"{loop}_critical_speed_m_s"])], "*", color=c,
                    ms=12, label=f"{loop.replace('_', ' ')}, completed bridge")
    ax.set_xlabel("main-span deck erected [%]")
    ax.set_ylabel("critical wind speed [m/s]")
    ax.set_title(f"{res.bridge}: erection with the controller ({res.status})")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return ax
