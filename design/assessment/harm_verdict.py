"""The do-no-harm verdict of one variant (:mod:`bridgeflap.design.assessment.harm`): the critical
speed of each loop read from its summary (resolved or not), the row that sets the closed loop
against the open loop, and whether a screened row lies near a decision. Shared by the reference
check (:mod:`bridgeflap.design.assessment.harm`) and the fast one
(:mod:`bridgeflap.design.assessment.harm_fast`); imports neither."""

from __future__ import annotations

import math

import numpy as np

#: closed-loop critical speed below ``(1 - HARM_TOL_REL)`` x the open-loop one is harm: the
#: crossings are refined to 1e-3 m/s (Brent), 1e-4 relative at 10 m/s and more
HARM_TOL_REL = 1e-4
#: a screened row within this relative distance of a decision (the design speed; the open-loop
#: speed: twice it) is recomputed on all modes. 16 modes against 30: the largest change of a
#: critical speed is 0.70 % over the 66 cases of model.analysis.DEFAULT_MODES (the open loop at
#: the 64 corners of the input ranges) and 0.095 % over 16 sampled variants of the default
#: design (closed loop: its static divergence, +0.08..0.095 %); 1.5 % is twice the first. The
#: margin is checked a posteriori on every recomputed row (SCREEN_CHECK_FRACTION)
SCREEN_MARGIN_REL = 0.015
#: statuses that are a result: a crossing found and verified, or none on the grid
_RESOLVED = ("converged", "no_crossing_in_range")


def _crit(summary: dict) -> tuple[float, str, bool]:
    """(critical speed [m/s] or inf beyond the grid, mechanism, resolved) of a summary.

    Resolved: every crossing is converged or absent, or the converged critical speed lies
    below the grid bracket of each crossing that is not (the lower crossing governs, whatever
    the unverified one above it is: the closed-loop divergence of the default design is
    ``unverified_crossing`` with a bracket above its flutter speed).
    """
    u = summary.get("critical_speed_m_s")
    u = math.inf if u is None or not np.isfinite(u) else float(u)
    lows = []
    for kind in ("flutter", "divergence"):
        if summary.get(f"{kind}_status") in _RESOLVED:
            continue
        bracket = summary.get(f"{kind}_bracket_m_s")
        lows.append(float(bracket[0]) if bracket else -math.inf)  # no bracket: unknown
    resolved = all(u <= lo for lo in lows) and not (lows and math.isinf(u))
    mech = "none" if math.isinf(u) else str(summary.get("critical_mechanism", ""))
    return u, mech, resolved


def _row(crits: dict, speed_max_m_s: float, modes: dict) -> dict:
    """The row of ``{"open_loop"|"closed_loop": (speed, mechanism, resolved)}`` (:func:`_crit`)
    and the mode count of each loop's numbers."""
    cl, cl_mech, cl_ok = crits["closed_loop"]
    ol, ol_mech, ol_ok = crits["open_loop"]
    resolved = cl_ok and ol_ok
    if math.isinf(ol) and math.isinf(cl):
        ratio = None  # both beyond the grid: nothing to compare
    elif math.isinf(cl):
        ratio = None  # closed loop beyond the grid: at least speeds[-1] / ol
    else:
        ratio = cl / ol if not math.isinf(ol) else 0.0  # open loop beyond the grid: harm
    harmed = resolved and cl < ol * (1.0 - HARM_TOL_REL)
    return {
        "open_loop_critical_speed_m_s": None if math.isinf(ol) else ol,
        "open_loop_beyond_grid": math.isinf(ol), "open_loop_mechanism": ol_mech,
        "closed_loop_critical_speed_m_s": None if math.isinf(cl) else cl,
        "closed_loop_beyond_grid": math.isinf(cl), "closed_loop_mechanism": cl_mech,
        "closed_over_open": ratio,
        "stable_to_design_speed": bool(resolved and cl > speed_max_m_s),
        "harmed": bool(harmed), "resolved": bool(resolved),
        "open_loop_modes": int(modes["open_loop"]), "closed_loop_modes": int(modes["closed_loop"]),
    }


def near_decision(row: dict, speed_max_m_s: float, margin: float | None = None) -> tuple:
    """The loops of a screened row whose numbers could change its verdict on more modes.

    Both loops when the row is not resolved, has a critical speed beyond the grid, or its
    closed/open ratio lies within ``2 margin`` of 1 (both speeds may move); the closed loop
    when its critical speed lies within ``margin`` (default :data:`SCREEN_MARGIN_REL`) of the
    design speed; else none.
    """
    m = SCREEN_MARGIN_REL if margin is None else float(margin)
    cl, ol = row["closed_loop_critical_speed_m_s"], row["open_loop_critical_speed_m_s"]
    if not row["resolved"] or cl is None or ol is None or abs(cl / ol - 1.0) <= 2 * m:
        return ("open_loop", "closed_loop")
    return ("closed_loop",) if abs(cl / speed_max_m_s - 1.0) <= m else ()
