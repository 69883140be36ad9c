"""The usable speed of a flap controller: the highest mean wind speed up to which it does what
its linear design promises, with its real actuators, in the bridge's design turbulence.

The linear closed-loop critical speed assumes ideal actuators (any flap angle, any rate). A
controller is usable only up to the lowest of

(a) ``linear critical speed``: the linear closed loop's critical speed (flutter or
    divergence, the verification model of ``closed_loop_limits``);
(b) ``flap angle 3 sigma`` / ``flap rate 3 sigma``: the speed at which three times the
    spectral RMS flap angle (rate) of the linear closed loop, in the bridge's design
    turbulence (:func:`bridgeflap.model.aero.gust.gust_field`), reaches the actuator's angle
    (rate) limit: beyond it the flaps sit on their stops more than the 0.3 % of the time a
    Gaussian signal passes 3 sigma, and the linear RMS no longer describes the loop. The
    crossing is found by Brent's method on the spectral RMS to :data:`LINEAR_XTOL_M_S`;
(c) ``saturated loop``: the highest speed at which the closed loop with the angle and rate
    limits and the servo (:mod:`bridgeflap.model.response.actuator_sim`) stays bounded over
    the given Monte-Carlo records, by bisection to :data:`SATURATED_XTOL_M_S`. The bracket
    comes from the linear estimates: the lower end is (b)'s speed (the limits are rarely
    reached there; simulated to confirm), the upper end (a) (the loop is unstable there, no
    simulation needed), so a 22 m/s bracket takes ``1 + 6`` simulations. Every speed uses the
    same random phases (common random numbers), so that the bisection compares speeds, not
    draws; it assumes that a loop which holds at a speed holds below it.

:func:`usable_speed_verdict` is the one rule the acceptance applies: a controller whose usable
speed is not above the open-loop critical speed does not make the bridge safer in wind than no
controller at all.

:func:`response_by_speed` tabulates the right half of the paper's Fig. 5 as numbers: open- and
closed-loop RMS heave and twist and the 3 sigma flap angle and rate from 4 m/s to the closed-loop
critical speed, with the actuator limits beside them.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

__all__ = ["LIMITED_BY", "LINEAR_XTOL_M_S", "SATURATED_XTOL_M_S", "SIGMAS", "plot_response",
           "UsableSpeedResult", "flap_demand_loop", "linear_limit_speed", "response_by_speed",
           "saturated_holding_speed", "usable_speed", "usable_speed_verdict"]

#: names of the limits, in the order ties are named (``usable_speed_limited_by``)
LIMITED_BY = ("linear critical speed", "flap angle 3 sigma", "flap rate 3 sigma",
              "saturated loop")
#: peak factor of the flap demand: a Gaussian signal passes 3 sigma 0.27 % of the time
SIGMAS = 3.0
#: tolerance of the linear crossings [m/s]: Brent's xtol of 0.05 m/s keeps the bracket of the
#: reported crossing below 0.1 m/s, finer than any input of the model is known
LINEAR_XTOL_M_S = 0.1
#: tolerance of the saturated loop's holding speed [m/s]: each bisection step is one
#: Monte-Carlo simulation (7 s for 4 x 600 s records on 16 modes); 0.5 m/s is the grid step
#: of the project's stability sweeps
SATURATED_XTOL_M_S = 0.5
#: grid of the scan that brackets the linear crossings [m/s]; the RMS rises monotonically
#: towards the critical speed, where it is infinite (10 m/s: 9 spectral solutions to 87 m/s,
#: 0.4-1 s each on 16 modes, then ~7 of Brent's method per crossing)
SCAN_STEP_M_S = 10.0
#: first speed of the scan and of the response table [m/s] (the paper's Fig. 5 starts at 4 m/s)
FIRST_SPEED_M_S = 4.0


def usable_speed_verdict(usable_m_s, open_loop_m_s) -> tuple[str, str]:
    """``(status, reason)`` of the usable-speed check: ``above_open_loop`` when the usable
    speed is above the open-loop critical speed, ``not_above_open_loop`` when not,
    ``undetermined`` when either is unknown. The one place of the threshold."""
    u, o = _num(usable_m_s), _num(open_loop_m_s)
    if not (np.isfinite(u) and np.isfinite(o)):
        return "undetermined", "the usable or the open-loop critical speed is unknown"
    if u > o:
        return "above_open_loop", ""
    return "not_above_open_loop", (f"usable speed {u:.1f} m/s not above the open-loop "
                                   f"critical speed {o:.1f} m/s")


def _num(v) -> float:
    return float(v) if isinstance(v, int | float) and not isinstance(v, bool) else float("nan")


class _Demand:
    """Spectral RMS flap angle and rate [deg, deg/s] of the linear closed loop (largest over
    the flaps), cached per speed; infinite where the loop is unstable."""

    def __init__(self, loop, gust, bandwidth_rad_s):
        self.loop, self.gust, self.wa = loop, gust, float(bandwidth_rad_s)
        self.cache: dict = {}

    def __call__(self, U: float) -> tuple[float, float]:
        from bridgeflap.design.assessment.actuator_study import _linear_reference

        U = float(U)
        if U not in self.cache:
            A = self.loop.linear_matrix(U, self.wa)
            if np.max(np.linalg.eigvals(A).real) >= 0:
                self.cache[U] = (np.inf, np.inf)
            else:
                _, beta, rate, _ = _linear_reference(self.loop, A, U, self.gust, self.wa)
                self.cache[U] = (float(np.rad2deg(beta.max())), float(np.rad2deg(rate.max())))
        return self.cache[U]


def flap_demand_loop(spec, controller, n_modes: int):
    """The controller's :class:`~bridgeflap.model.response.actuator_sim.SaturatedLoop` on
    ``n_modes`` modes and the bridge's design turbulence."""
    from bridgeflap.model.aero.gust import gust_field
    from bridgeflap.model.aeroelastic.flaps import closed_loop_model
    from bridgeflap.model.response.actuator_sim import SaturatedLoop

    c = controller
    model = closed_loop_model(spec, c.flap_strip_positions_m, c.flap_width_m, int(n_modes),
                              c.chord_m, c.leading_edge, c.trailing_edge)
    return SaturatedLoop(model, c.compensator), gust_field(spec)


def linear_limit_speed(demand, which: int, limit: float, u_max: float,
                       xtol: float = LINEAR_XTOL_M_S) -> float:
    """Lowest speed in ``(FIRST_SPEED_M_S, u_max)`` at which ``SIGMAS`` x the RMS
    ``demand(U)[which]`` (0: angle [deg], 1: rate [deg/s]) reaches ``limit``; NaN when it
    stays below up to ``u_max``. A scan every :data:`SCAN_STEP_M_S` brackets the first
    crossing, Brent's method refines it (the RMS is infinite at and beyond an unstable
    speed, so the function is capped to keep Brent's method finite)."""
    from scipy.optimize import brentq

    if not np.isfinite(u_max) or u_max <= FIRST_SPEED_M_S:
        return float("nan")

    def g(U):
        return min(SIGMAS * demand(U)[which], 1e6) - limit

    grid = list(np.arange(FIRST_SPEED_M_S, u_max, SCAN_STEP_M_S))
    # just below the critical speed (the RMS there is finite but may be huge)
    grid.append(u_max - 0.5 * xtol)
    a = grid[0]
    if g(a) >= 0:
        return float(a)
    for b in grid[1:]:
        if g(b) >= 0:
            return float(brentq(g, a, b, xtol=0.5 * xtol))
        a = b
    return float("nan")


def saturated_holding_speed(loop, gust, limits, u_lo: float, u_hi: float, *, records: int,
                            duration_s: float, seed: int = 0,
                            xtol: float = SATURATED_XTOL_M_S, progress=None) -> dict:
    """Highest speed at which the saturated loop holds (no record diverges), by bisection.

    ``u_lo``: the first guess of a holding speed (simulated; halved towards
    ``FIRST_SPEED_M_S`` while it does not hold); ``u_hi``: a speed at which it does not hold
    (the linear critical speed; not simulated). Returns ``holds_to_m_s`` (the highest speed
    simulated to hold), ``fails_from_m_s`` (the lowest that did not, or ``u_hi``), the
    simulations and their cost."""
    from bridgeflap.model.response.actuator_sim import simulate_records

    say = progress or (lambda _m: None)
    runs = []
    t0 = time.perf_counter()
    phases = np.random.SeedSequence(int(seed)).spawn(int(records))

    def holds(U):
        t = time.perf_counter()
        recs = simulate_records(loop, U, gust, limits, duration_s,
                                [np.random.default_rng(s) for s in phases])
        lost = None if recs is None else [r.diverged_at_s for r in recs
                                          if r.diverged_at_s is not None]
        ok = recs is not None and not lost
        runs.append({"speed_m_s": float(U), "holds": bool(ok),
                     "linear_loop_unstable": recs is None,
                     "diverged_records": None if recs is None else len(lost),
                     "diverged_after_s": float(min(lost)) if lost else None,
                     "elapsed_s": time.perf_counter() - t})
        say(f"usable speed: saturated loop at {U:.2f} m/s "
            f"{'holds' if ok else 'does not hold'} ({time.perf_counter() - t:.1f} s)")
        return ok

    hi = float(u_hi)
    lo = min(float(u_lo), hi - xtol) if np.isfinite(u_lo) else 0.5 * hi
    lo = max(lo, FIRST_SPEED_M_S)
    while not holds(lo):   # the guess does not hold: halve it (rare: a few more runs)
        hi = lo
        if lo <= FIRST_SPEED_M_S:
            lo = 0.0
            break
        lo = max(0.5 * lo, FIRST_SPEED_M_S)
    while hi - lo > xtol:
        mid = 0.5 * (lo + hi)
        if holds(mid):
            lo = mid
        else:
            hi = mid
    return {"holds_to_m_s": float(lo), "fails_from_m_s": float(hi),
            "tolerance_m_s": xtol, "simulations": runs,
            "simulated_record_s": float(records * duration_s * len(runs)),
            "elapsed_s": time.perf_counter() - t0}


@dataclass(frozen=True)
class UsableSpeedResult:
    """The usable-speed check: ``block`` (strict-JSON numbers, the acceptance block entry)
    and ``response`` (the paper's Fig. 5 right as rows, :func:`response_by_speed`)."""

    block: dict
    response: list = field(default_factory=list)

    def summary(self) -> dict:
        return dict(self.block)

    def to_dataframe(self):
        """The response rows (one per speed) as a table."""
        import pandas as pd

        return pd.DataFrame(self.response)


def usable_speed(spec, controller, limits, *, linear_critical_m_s: float,
                 open_loop_critical_m_s: float, n_modes: int = 16, records: int = 4,
                 duration_s: float = 600.0, seed: int = 0, response: bool = True,
                 response_step_m_s: float = 4.0, progress=None) -> UsableSpeedResult:
    """The usable speed of ``controller`` on ``spec`` with actuator ``limits`` (module
    docstring), its binding limit and the verdict against ``open_loop_critical_m_s``.

    ``linear_critical_m_s`` and ``open_loop_critical_m_s``: the closed- and open-loop critical
    speeds of the verification model (``closed_loop_limits``). The flap demand and the
    simulations use ``n_modes`` modes, ``records`` records of ``duration_s`` each (the
    actuator check's sizes)."""
    t0 = time.perf_counter()
    say = progress or (lambda _m: None)
    loop, gust = flap_demand_loop(spec, controller, n_modes)
    demand = _Demand(loop, gust, limits.bandwidth_rad_s)
    crit = _num(linear_critical_m_s)
    u_top = crit if np.isfinite(crit) else 200.0  # the actuator study's search range
    u_angle = linear_limit_speed(demand, 0, limits.angle_deg, u_top)
    u_rate = linear_limit_speed(demand, 1, limits.rate_deg_s, u_top)
    n_spectral = len(demand.cache)
    t_lin = time.perf_counter() - t0
    say(f"usable speed: 3 sigma flap angle reaches {limits.angle_deg:g} deg at "
        f"{u_angle:.1f} m/s, rate {limits.rate_deg_s:g} deg/s at {u_rate:.1f} m/s "
        f"({n_spectral} spectral solutions, {t_lin:.1f} s)")
    guess = np.nanmin([u_angle, u_rate, u_top])
    sat = saturated_holding_speed(loop, gust, limits, guess, u_top, records=records,
                                  duration_s=duration_s, seed=seed, progress=say)
    sat_speed = sat["holds_to_m_s"] if sat["fails_from_m_s"] < u_top else u_top
    cands = [(v, name) for v, name in zip((crit, u_angle, u_rate, sat_speed), LIMITED_BY,
                                          strict=True) if np.isfinite(v)]
    value, by = min(cands, key=lambda c: c[0]) if cands else (float("nan"), None)
    status, reason = usable_speed_verdict(value, open_loop_critical_m_s)
    block = {
        "status": status, **({"reason": reason} if reason else {}),
        "usable_speed_m_s": value, "usable_speed_limited_by": by,
        "open_loop_critical_speed_m_s": _num(open_loop_critical_m_s),
        "linear_closed_loop_critical_speed_m_s": crit,
        "linear_closed_loop_critical_speed_note": "ideal actuators (any flap angle and rate)",
        "flap_angle_3sigma_speed_m_s": u_angle, "flap_rate_3sigma_speed_m_s": u_rate,
        "saturated_loop_holds_to_m_s": sat_speed,
        "saturated_loop_fails_from_m_s": sat["fails_from_m_s"],
        "flap_angle_limit_deg": limits.angle_deg, "flap_rate_limit_deg_s": limits.rate_deg_s,
        "actuator_bandwidth_rad_s": limits.bandwidth_rad_s, "sigmas": SIGMAS,
        "linear_tolerance_m_s": LINEAR_XTOL_M_S, "saturated_tolerance_m_s": SATURATED_XTOL_M_S,
        "modes_retained": int(n_modes), "records": int(records), "duration_s": float(duration_s),
        "seed": int(seed), "turbulence": gust.summary(),
        "saturated_loop_simulations": sat["simulations"],
        "cost": {"spectral_solutions": n_spectral, "spectral_s": t_lin,
                 "simulations": len(sat["simulations"]),
                 "simulated_record_s": sat["simulated_record_s"],
                 "simulation_s": sat["elapsed_s"]},
        "rule": "usable speed = min(linear closed-loop critical speed, 3 sigma flap angle and "
                "rate at their limits (spectral, design turbulence), saturated loop bounded "
                "in every record); it must be above the open-loop critical speed",
    }
    rows = []
    if response:
        rows = response_by_speed(spec, controller, demand, crit, limits, n_modes,
                                 step_m_s=response_step_m_s)
    block["elapsed_s"] = time.perf_counter() - t0
    say(f"usable speed {value:.1f} m/s ({by}): {status}")
    return UsableSpeedResult(block, rows)


def response_by_speed(spec, controller, demand, critical_m_s: float, limits, n_modes: int,
                      step_m_s: float = 4.0) -> list[dict]:
    """The paper's Fig. 5 (right) as rows: open- and closed-loop max RMS heave [m] and twist
    [rad] on
    the main span (:func:`bridgeflap.model.response.buffeting.buffeting`, spectral) and the 3
    sigma flap angle [deg] and rate [deg/s] of the closed loop (largest over the flaps), from
    4 m/s every ``step_m_s`` to just below ``critical_m_s``; the actuator limits in each row
    (``*_limit_*``) and whether the 3 sigma demand is within them."""
    from bridgeflap.model.response.buffeting import buffeting

    top = critical_m_s if np.isfinite(critical_m_s) else 85.0
    u = np.arange(FIRST_SPEED_M_S, top, step_m_s)
    if top - u[-1] > 0.5:      # the last row just below the critical speed
        u = np.append(u, np.floor(2.0 * top - 1e-9) / 2.0)
    ol = buffeting(spec, u, n_modes=n_modes, allow_unstable=True)
    cl = buffeting(spec, u, n_modes=n_modes, controller=controller, allow_unstable=True)
    rows = []
    for i, U in enumerate(u):
        a, r = demand(U)
        rows.append({"speed_m_s": float(U),
                     "open_loop_rms_heave_m": float(ol.rms_vertical[i]),
                     "closed_loop_rms_heave_m": float(cl.rms_vertical[i]),
                     "open_loop_rms_twist_rad": float(ol.rms_torsion[i]),
                     "closed_loop_rms_twist_rad": float(cl.rms_torsion[i]),
                     "flap_angle_3sigma_deg": SIGMAS * a, "flap_rate_3sigma_deg_s": SIGMAS * r,
                     "flap_angle_limit_deg": limits.angle_deg,
                     "flap_rate_limit_deg_s": limits.rate_deg_s,
                     "within_actuator_limits": bool(SIGMAS * a < limits.angle_deg
                                                    and SIGMAS * r < limits.rate_deg_s)})
    return rows


def plot_response(rows, block=None, title: str = ""):
    """The paper's Fig. 5 (right) from :func:`response_by_speed` rows: open- vs closed-loop RMS
    heave
    and twist, and the 3 sigma flap angle and rate against their limits, with the open-loop
    critical, usable and linear closed-loop critical speeds marked (``block``: the usable-speed
    check's). Returns the Figure."""
    import matplotlib.pyplot as plt

    block = block or {}
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.8))
    u = np.array([r["speed_m_s"] for r in rows], float)

    def col(k, scale=1.0):
        return scale * np.array([np.nan if r[k] is None else r[k] for r in rows], float)

    for ax, key, scale, label in ((axes[0], "rms_heave_m", 1.0, "max RMS heave, main span [m]"),
                                  (axes[1], "rms_twist_rad", np.degrees(1.0),
                                   "max RMS twist, main span [deg]")):
        ax.semilogy(u, col("open_loop_" + key, scale), "k--o", ms=3, label="open loop")
        ax.semilogy(u, col("closed_loop_" + key, scale), "b-o", ms=3, label="closed loop")
        ax.set_ylabel(label)
    ax = axes[2]
    ax.semilogy(u, col("flap_angle_3sigma_deg"), "b-o", ms=3, label="3σ flap angle [deg]")
    ax.semilogy(u, col("flap_rate_3sigma_deg_s"), "g-s", ms=3, label="3σ flap rate [deg/s]")
    if rows:
        ax.axhline(rows[0]["flap_angle_limit_deg"], color="b", ls=":",
                   label=f"angle limit {rows[0]['flap_angle_limit_deg']:g} deg")
        ax.axhline(rows[0]["flap_rate_limit_deg_s"], color="g", ls=":",
                   label=f"rate limit {rows[0]['flap_rate_limit_deg_s']:g} deg/s")
    ax.set_ylabel("closed loop, linear (spectral)")
    marks = (("open_loop_critical_speed_m_s", "r", "open-loop critical"),
             ("usable_speed_m_s", "m", "usable"),
             ("saturated_loop_holds_to_m_s", "grey", "saturated loop holds to"),
             ("linear_closed_loop_critical_speed_m_s", "k", "linear closed-loop critical "
                                                             "(ideal actuators)"))
    for a in axes:
        for key, colour, name in marks:
            v = block.get(key)
            if isinstance(v, int | float) and np.isfinite(v):
                a.axvline(v, color=colour, ls="-." if key == "usable_speed_m_s" else ":",
                          lw=1.2, label=f"{name} {v:.1f} m/s")
        a.set_xlabel("mean wind speed U [m/s]")
        a.grid(alpha=0.3, which="both")
        a.legend(fontsize=7, loc="upper left")
    axes[0].set_title("heave (open loop NaN beyond its critical speed)", fontsize=9)
    axes[1].set_title("twist", fontsize=9)
    by = block.get("usable_speed_limited_by")
    axes[2].set_title("flap demand" + (f"; usable speed limited by {by}" if by else ""),
                      fontsize=9)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig
