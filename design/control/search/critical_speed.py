"""Maximise the closed-loop critical speed subject to a robust margin.

``objective = "critical_speed"`` in :class:`bridgeflap.design.control.settings.DesignSettings`. The
critical speed is the lower of closed-loop flutter and divergence
(:func:`bridgeflap.design.control.review.checks.closed_loop_limits`).

Method (docs/methods.md#critical-speed-objective). An outer search over the design speed
``U_d``; the inner problem at ``U_d`` is the default design
(:func:`bridgeflap.design.control.search.driver.run_start`: phase 1, Ipopt, cutting planes, dense
checks) with the damping ratio ``zeta_min`` required on 0..``U_d`` (:func:`settings_at`: design
grid, dense check grid and robust speeds extended to ``U_d``). ``U_d`` is *feasible* when the inner
design verifies -- damping on the design model's dense grid to ``U_d``, true peak gain <=
``gain_limit``, stable to ``U_d`` on the verification model -- and its dense robust margin is >=
``margin_min``. The search starts at the card's ``speed_max_m_s``, steps by
``critical_speed_step_m_s`` (up, or down when the start is not feasible) until the feasibility
changes (the bracket), then bisects to ``critical_speed_tol_m_s``, each inner solve warm-started
from the design at the bracket's feasible end. Every feasible design's closed-loop limits are
computed (~5 s on 30 modes); the chosen design is the feasible one of highest closed-loop critical
speed (the objective; normally the one at the largest feasible ``U_d``, whose damping holds
furthest); the result is :func:`bridgeflap.design.control.search.driver.design`'s checks of it
(closed-loop limits, flap count, buffeting).

The inner objective stays the robust margin (not ``gamma_T <= 1/margin_min`` with the
regularisation as objective): both define the same feasible set of ``U_d`` (a design with
margin >= margin_min exists at ``U_d`` iff the largest margin there is >= margin_min), but
the max-margin solve always ends at a design, the dense margin is a continuous measure of
how far ``U_d`` is from the limit (recorded per inner solve: the margin-vs-design-speed
trade-off), and no Ipopt infeasibility detection (restoration phase, a useless iterate as the
next warm start) is needed; the NLP is unchanged.

Statuses (never ``converged`` unless every condition holds): ``converged`` (feasible and
not-feasible ends within the tolerance, the not-feasible end a completed inner design that
failed a check, the chosen design verified), ``not_bracketed`` (feasible up to the search
limit ``critical_speed_max_m_s``, or evaluations ran out while stepping up),
``not_converged`` (evaluations ran out before the tolerance, or the not-feasible end is a
solver failure, not a design shown to fail a check), ``infeasible`` (no tried speed feasible)
and ``failed`` (no inner solve produced a design).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from bridgeflap.design.control.settings import DesignSettings
from bridgeflap.model.errors import BridgeflapInputError

#: Outcomes of one inner design (:class:`Evaluation`).
FEASIBLE, NOT_FEASIBLE, FAILED = "feasible", "not_feasible", "failed"
#: Speeds closer than this [m/s] are the same (round-off of the bisection midpoints).
SPEED_EPS_M_S = 1e-9


@dataclass(frozen=True)
class Evaluation:
    """One inner design at design speed ``design_speed_m_s`` [m/s].

    ``outcome``: ``feasible``, ``not_feasible`` (a design came out and failed a check:
    ``reason``) or ``failed`` (no design: solver error); ``theta`` its coefficients (None
    when failed); ``warm_start_from_m_s`` the design speed of the warm start (None: the
    initial start); ``details``: JSON numbers of its checks (units in the keys);
    ``record``, ``settings``: the chosen
    :class:`bridgeflap.design.control.results.records.StartRecord` and the inner settings (not
    serialised).
    """

    design_speed_m_s: float
    outcome: str
    reason: str
    theta: tuple | None = None
    warm_start_from_m_s: float | None = None
    details: dict | None = None
    record: object = None
    settings: DesignSettings | None = None

    @property
    def feasible(self) -> bool:
        return self.outcome == FEASIBLE

    def to_dict(self) -> dict:
        """One entry of ``critical_speed.evaluations``."""
        return {"design_speed_m_s": self.design_speed_m_s, "outcome": self.outcome,
                "reason": self.reason,
                "theta": list(self.theta) if self.theta is not None else None,
                "warm_start_from_m_s": self.warm_start_from_m_s, **(self.details or {})}


@dataclass(frozen=True)
class SpeedSearch:
    """Outcome of :func:`search_design_speed`: ``status`` and ``reason`` (module docstring),
    the bracket's ends ``feasible`` / ``not_feasible`` (:class:`Evaluation` or None) and every
    evaluation in order."""

    status: str
    reason: str
    feasible: Evaluation | None
    not_feasible: Evaluation | None
    evaluations: tuple

    @property
    def bracket_width_m_s(self) -> float:
        if self.feasible is None or self.not_feasible is None:
            return float("nan")
        return abs(self.not_feasible.design_speed_m_s - self.feasible.design_speed_m_s)


def search_design_speed(evaluate, start_m_s: float, step_m_s: float, tol_m_s: float,
                        max_m_s: float, max_evaluations: int) -> SpeedSearch:
    """Largest feasible design speed by bracketing and bisection.

    ``evaluate(speed_m_s, warm)`` -> :class:`Evaluation`, ``warm`` the feasible evaluation
    to warm-start from (None: the initial start). From ``start_m_s`` step by ``step_m_s`` up
    (feasible start; at most to ``max_m_s``) or down (not feasible; while > 0) until the
    outcome changes, then bisect until the ends are within ``tol_m_s``; at most
    ``max_evaluations`` calls. A failed evaluation counts as not feasible for the search
    but cannot end it as ``converged``.
    """
    evals: list[Evaluation] = []

    def run(u, warm):
        e = evaluate(float(u), warm)
        evals.append(e)
        return e

    lo = hi = None
    e = run(start_m_s, None)
    if e.feasible:
        lo = e
        while hi is None and len(evals) < max_evaluations \
                and lo.design_speed_m_s < max_m_s - SPEED_EPS_M_S:
            e = run(min(lo.design_speed_m_s + step_m_s, max_m_s), lo)
            lo, hi = (e, hi) if e.feasible else (lo, e)
    else:
        hi = e
        while lo is None and len(evals) < max_evaluations \
                and hi.design_speed_m_s - step_m_s > SPEED_EPS_M_S:
            e = run(hi.design_speed_m_s - step_m_s, None)
            lo, hi = (e, hi) if e.feasible else (lo, e)
    while (lo is not None and hi is not None and len(evals) < max_evaluations
           and hi.design_speed_m_s - lo.design_speed_m_s > tol_m_s + SPEED_EPS_M_S):
        e = run(0.5 * (lo.design_speed_m_s + hi.design_speed_m_s), lo)
        lo, hi = (e, hi) if e.feasible else (lo, e)
    if lo is None:
        if all(x.outcome == FAILED for x in evals):
            return SpeedSearch("failed", "no inner solve produced a design", None, hi,
                               tuple(evals))
        return SpeedSearch("infeasible", f"no feasible design speed down to "
                           f"{evals[-1].design_speed_m_s:g} m/s", None, hi, tuple(evals))
    if hi is None:
        why = (f"feasible at the search limit {max_m_s:g} m/s" if lo.design_speed_m_s
               >= max_m_s - SPEED_EPS_M_S else f"{max_evaluations} evaluations used while "
               f"stepping up, feasible to {lo.design_speed_m_s:g} m/s")
        return SpeedSearch("not_bracketed", why, lo, None, tuple(evals))
    width = hi.design_speed_m_s - lo.design_speed_m_s
    if width > tol_m_s + SPEED_EPS_M_S:
        return SpeedSearch("not_converged", f"{max_evaluations} evaluations used, bracket "
                           f"{width:g} m/s > tolerance {tol_m_s:g} m/s", lo, hi, tuple(evals))
    if hi.outcome == FAILED:
        return SpeedSearch("not_converged", f"the bracket's upper end "
                           f"{hi.design_speed_m_s:g} m/s is a solver failure ({hi.reason}), "
                           "not a design shown to fail a check", lo, hi, tuple(evals))
    return SpeedSearch("converged", f"bracket {lo.design_speed_m_s:g}..{hi.design_speed_m_s:g} "
                       f"m/s within {tol_m_s:g} m/s; at {hi.design_speed_m_s:g} m/s: "
                       f"{hi.reason}", lo, hi, tuple(evals))


def _extend(speeds, speed: float, fallback_step: float) -> tuple:
    """``speeds`` [m/s] below ``speed``, then every finest spacing of ``speeds`` above their top
    up to ``speed``, and ``speed`` itself (empty stays empty)."""
    sp = sorted({float(u) for u in speeds})
    if not sp:
        return ()
    d = np.diff(sp)
    step = float(d.min()) if d.size else float(fallback_step)
    ext = [u for u in sp if u < speed - SPEED_EPS_M_S]
    u = sp[-1] + step
    while u < speed - SPEED_EPS_M_S:
        ext.append(u)
        u += step
    return tuple(sorted(set(ext) | {float(speed)}))


def search_limit_m_s(settings: DesignSettings) -> float:
    """Upper end of the search [m/s]: ``critical_speed_max_m_s``, 0 meaning twice the start
    (the range of the closed-loop limits,
    ``bridgeflap.design.control.review.checks.LIMIT_SPEED_FACTOR``)."""
    from bridgeflap.design.control.review.checks import LIMIT_SPEED_FACTOR

    return float(settings.critical_speed_max_m_s
                 or LIMIT_SPEED_FACTOR * settings.speed_max_m_s)


def settings_at(settings: DesignSettings, speed_m_s: float) -> DesignSettings:
    """The inner problem at design speed ``speed_m_s`` [m/s]: ``speed_max_m_s`` (so the design
    grid :meth:`~DesignSettings.design_speeds` and the dense check grid extend with it) and
    the robust speeds -- the epigraph's ``robust_design_speeds_m_s`` and the reported margin's
    ``robust_speeds_m_s`` -- cut at ``speed_m_s`` and extended to it at their finest spacing
    (the card's 85 m/s lists: 5 m/s above 80 m/s), ``speed_m_s`` included. The cutting planes'
    robust check speeds are their union
    (:meth:`bridgeflap.design.control.formulation.nlp.DesignProblem.robust_check_speeds`)."""
    u = float(speed_m_s)
    return replace(settings, speed_max_m_s=u, critical_speed_max_m_s=search_limit_m_s(settings),
                   robust_design_speeds_m_s=_extend(settings.robust_design_speeds_m_s, u,
                                                    settings.design_step_m_s),
                   robust_speeds_m_s=_extend(settings.robust_speeds_m_s, u,
                                             settings.design_step_m_s))


def _reason(rec, s: DesignSettings) -> str:
    """Why an inner design is not feasible (the first failed check)."""
    if rec is None or rec.failed:
        return rec.ipopt_status if rec is not None else "no design"
    if not rec.meets_damping:
        return (f"damping ratio below zeta_min {s.zeta_min:g} on 0..{s.speed_max_m_s:g} m/s "
                f"(max violation {rec.max_violation_1_s:.3g} 1/s, Ipopt {rec.ipopt_status})")
    if not rec.gain_ok:
        return f"peak gain {rec.max_gain:.4g} > gain_limit {s.gain_limit:g}"
    if not rec.verified:
        v = rec.verification
        return (f"unstable on the {v.modes}-mode verification model above "
                f"{v.stable_to_m_s:g} m/s" if v is not None else "not verified")
    return f"robust margin {rec.robust_margin:.4g} < margin_min {s.margin_min:g}"


def _limits(s: DesignSettings, rec, spec) -> dict:
    """Closed-loop critical speed [m/s] and mechanism of a start record's design on the
    verification model (:func:`bridgeflap.design.control.review.checks.closed_loop_limits`, ~5 s on
    30 modes)."""
    from bridgeflap.design.control.review.checks import closed_loop_limits
    from bridgeflap.model.aeroelastic.control import Compensator, Controller

    ctrl = Controller(Compensator(*(float(v) for v in rec.theta)),
                      tuple(float(x) for x in rec.flap_positions_m), s.flap_width_m,
                      s.leading_edge, s.trailing_edge, s.gain_limit,
                      flap_chord_m=s.flap_chord_m)
    try:
        lim = closed_loop_limits(s, ctrl, spec=spec)
    except Exception as exc:  # noqa: BLE001 - a report item, not the design
        return {"limits_status": f"failed: {exc}"}
    return {"critical_speed_m_s": lim.get("governing_speed_m_s"),
            "critical_mechanism": lim.get("governing_mechanism"),
            "flutter_speed_m_s": lim.get("flutter_speed_m_s"),
            "divergence_static_speed_m_s": lim.get("divergence_static_speed_m_s")}


def choose(search: SpeedSearch) -> Evaluation | None:
    """The feasible evaluation of highest closed-loop critical speed (the objective; ties
    and missing limits: the larger design speed), None when none is feasible."""
    feas = [e for e in search.evaluations if e.feasible]
    if not feas:
        return None

    def key(e):
        v = (e.details or {}).get("critical_speed_m_s")
        v = float(v) if v is not None else float("nan")
        return (v if np.isfinite(v) else -np.inf, e.design_speed_m_s)
    return max(feas, key=key)


def inner_design(settings: DesignSettings, speed_m_s: float, theta0, spec=None,
                 progress_bar=None, variants=(), warm_from=None) -> Evaluation:
    """The inner design at ``speed_m_s`` [m/s] from ``theta0`` (plus ``starts - 1`` screened
    Sobol starts, serially), its outcome and checks (:class:`Evaluation`)."""
    from bridgeflap.design.control.solve.start import run_start, screened_starts, select_start

    t0 = time.perf_counter()
    s = settings_at(settings, speed_m_s)
    starts = [np.asarray(theta0, float)]
    if s.starts > 1:
        starts += list(screened_starts(s, s.starts - 1, spec=spec))
    recs = [run_start(s, th, i, spec, progress_bar, variants) for i, th in enumerate(starts)]
    best, status = select_start(recs, s.gain_limit)
    ok = status == "converged" and best.robust_margin >= s.margin_min
    outcome = FEASIBLE if ok else (FAILED if best is None else NOT_FEASIBLE)
    details = {"time_s": time.perf_counter() - t0,
               "starts": [{"start": r.start, "status": r.ipopt_status} for r in recs]}
    if best is not None:
        v = best.verification
        details.update({
            "ipopt_status": best.ipopt_status, "iterations": best.iterations,
            "cut_rounds": best.cut_rounds, "verified": best.verified,
            "meets_damping": best.meets_damping, "max_violation_1_s": best.max_violation_1_s,
            "max_gain": best.max_gain, "robust_margin": best.robust_margin,
            "robust_speeds_m_s": list(s.robust_speeds_m_s),
            "verification_stable_to_m_s": v.stable_to_m_s if v is not None else None,
            "min_damping_ratio": (best.design_verification.min_damping_ratio
                                  if best.design_verification is not None else None)})
    if ok:      # the objective itself: closed-loop limits of the verified design
        details.update(_limits(s, best, spec))
    return Evaluation(design_speed_m_s=float(speed_m_s), outcome=outcome,
                      reason=("verified, margin >= margin_min" if ok else
                              _reason(best, s) if best is not None else
                              "; ".join(r.ipopt_status for r in recs)),
                      theta=None if best is None or best.failed else tuple(best.theta),
                      warm_start_from_m_s=warm_from, details=details, record=best, settings=s)


def critical_speed_design(settings: DesignSettings, progress=None, spec=None, warm_start=None,
                          progress_bar=None, *, design):
    """The critical-speed design (module docstring): search, then the chosen design's checks
    by ``design`` (:func:`bridgeflap.design.control.search.driver.design`, which calls this and
    passes itself: the search does not import the driver back; ``records``). Returns a
    :class:`bridgeflap.design.control.results.result.DesignResult` whose ``status`` is the search's
    (``controller`` only when ``converged``) and ``extras["critical_speed"]`` the search record."""
    from bridgeflap.design.control.formulation.problem_model import NOMINAL_START, warm_start_theta
    from bridgeflap.design.control.solve.scenarios import scenario_specs
    from bridgeflap.model.structure.loader import load_bridge

    t0 = time.perf_counter()
    log = progress or (lambda msg: None)
    theta_init = NOMINAL_START if warm_start is None else warm_start_theta(warm_start)
    base = load_bridge(settings.bridge if spec is None else spec)
    variants = scenario_specs(settings, base)
    u_max = search_limit_m_s(settings)

    def evaluate(u, warm):
        th = theta_init if warm is None or warm.theta is None else warm.theta
        try:
            e = inner_design(settings, u, th, spec, progress_bar, variants,
                             None if warm is None else warm.design_speed_m_s)
        except BridgeflapInputError:
            raise
        except Exception as exc:  # noqa: BLE001 - a failed inner solve is data (STYLE)
            e = Evaluation(u, FAILED, f"failed: {exc}",
                           warm_start_from_m_s=None if warm is None else warm.design_speed_m_s)
        d = e.details or {}
        crit = (f", closed-loop critical speed {d['critical_speed_m_s']:.2f} m/s "
                f"({d['critical_mechanism']})" if d.get("critical_speed_m_s") is not None
                else "")
        log(f"critical speed: design speed {u:g} m/s {e.outcome} ({e.reason}); margin "
            f"{d.get('robust_margin', float('nan')):.4g}, max gain "
            f"{d.get('max_gain', float('nan')):.4g}{crit}, {d.get('time_s', 0.0):.1f} s")
        return e

    srch = search_design_speed(evaluate, settings.speed_max_m_s,
                               settings.critical_speed_step_m_s,
                               settings.critical_speed_tol_m_s, u_max,
                               settings.critical_speed_evaluations)
    chosen = choose(srch)
    if chosen is None:      # for diagnosis: the first inner design that produced one
        chosen = next((e for e in srch.evaluations if e.record is not None),
                      srch.evaluations[0])
    s_ch = chosen.settings or settings_at(settings, chosen.design_speed_m_s)
    res = design(s_ch, progress=progress, bridge=spec, progress_bar=progress_bar,
                 records=[chosen.record] if chosen.record is not None else [])
    lim = res.extras.get("closed_loop_limits", {})
    status = srch.status if srch.status != "converged" or res.status == "converged" \
        else res.status
    # the margin constraint is checked over the whole speed range too (the
    # inner designs check it at the robust speeds only)
    grid = res.margin_grid()
    grid_ok = (bool(grid["margin"] >= settings.margin_min * (1.0 - settings.robust_cut_tol))
               if grid else None)
    reason = srch.reason
    if status == "converged" and grid_ok is False:
        status = "unverified"
        reason = (f"{reason}; robust margin {grid['margin']:.4g} at "
                  f"{grid['worst_speed_m_s']:.4g} m/s on the speed grid < margin_min "
                  f"{settings.margin_min:g}")
    hi = srch.not_feasible
    block = {
        "status": status, "reason": reason,
        "objective": "maximise the closed-loop critical speed (lower of flutter and "
                     "divergence) subject to robust margin >= margin_min: the largest design "
                     "speed whose max-margin design verifies with that margin",
        "margin_min": settings.margin_min,
        "start_speed_m_s": settings.speed_max_m_s,
        "step_m_s": settings.critical_speed_step_m_s,
        "tolerance_m_s": settings.critical_speed_tol_m_s,
        "search_max_m_s": u_max, "evaluations_max": settings.critical_speed_evaluations,
        "design_speed_m_s": chosen.design_speed_m_s if chosen.feasible else None,
        "largest_feasible_speed_m_s": (srch.feasible.design_speed_m_s if srch.feasible
                                       else None),
        "not_feasible_speed_m_s": hi.design_speed_m_s if hi is not None else None,
        "not_feasible_reason": hi.reason if hi is not None else None,
        "bracket_width_m_s": srch.bracket_width_m_s,
        "critical_speed_m_s": lim.get("governing_speed_m_s"),
        "critical_mechanism": lim.get("governing_mechanism"),
        "flutter_speed_m_s": lim.get("flutter_speed_m_s"),
        "flutter_frequency_hz": lim.get("flutter_frequency_hz"),
        "divergence_speed_m_s": lim.get("divergence_speed_m_s"),
        "divergence_static_speed_m_s": lim.get("divergence_static_speed_m_s"),
        "limits_modes": lim.get("modes"),
        "robust_margin": (grid["margin"] if grid else res.best.robust_margin
                          if res.best is not None else None),
        "robust_margin_at_robust_speeds": (res.best.robust_margin if res.best is not None
                                           else None),
        "margin_min_holds_on_speed_grid": grid_ok,
        "max_gain": res.best.max_gain if res.best is not None else None,
        "gain_limit": settings.gain_limit,
        "evaluations": [e.to_dict() for e in srch.evaluations],
        "inner_solves": len(srch.evaluations),
        "search_time_s": time.perf_counter() - t0,
    }
    log(f"critical speed: {status} ({reason}); design speed "
        f"{block['design_speed_m_s']} m/s, closed-loop critical speed "
        f"{block['critical_speed_m_s']} m/s ({block['critical_mechanism']})")
    extras = dict(res.extras)
    extras["critical_speed"] = block
    return replace(res, status=status,
                   controller=res.controller if status == "converged" else None,
                   wall_time_s=time.perf_counter() - t0, extras=extras)
