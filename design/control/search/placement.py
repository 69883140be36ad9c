"""Flap placement: the fewest flap strips, and where, that meet a design target.

The question a bridge engineer asks of the flaps is not "which weights" but "how many flap
strips, and where, do I need so that the bridge with its real actuators holds a target speed?".
:func:`placement_search` answers it with K(s) re-optimised for every layout it tries.

The target
    A layout **meets the target** ``U_t`` [m/s] when the fixed-layout design on it
    (:func:`bridgeflap.design.control.solve.start.layout_record`: Ipopt with cutting planes,
    the card's scenario bridges held to do no harm, the verification model) is *verified*,
    and

    * its damping holds on the design model to ``speed_max_m_s >= U_t`` and the verification
      model is stable to it (the linear closed loop, ideal actuators);
    * its 3 sigma flap angle and rate in the bridge's design turbulence stay within the card's
      actuator limits at every actuator design speed, ``U_t`` among them (the design's own
      spectral integral, :func:`bridgeflap.design.control.solve.start.flap_demand_record`):
      so the *linear* usable speed
      (:mod:`bridgeflap.design.assessment.usable_speed`, cases (a) and (b)) is at least
      ``U_t``;
    * no harm on the scenario bridges (the design's ``variant_checks``);
    * **one strip failed is safe**: with any one flap pair stuck at 0 and the others driven by
      the same K(s), the linear closed loop stays stable on the design model's dense check
      grid up to the nominal bridge's open-loop critical speed (a failed strip leaves the
      bridge no worse than no controller: the package's do-no-harm rule).

    The default ``U_t`` is the open-loop divergence speed of the verification model raised by
    the scenarios' no-harm margin (:data:`TARGET_MARGIN`, 1 %): a controller that holds the
    deck past the speed at which it would diverge without flaps, with its real actuators.
    The saturated loop (case (c) of the usable speed) is not part of the search: it is the
    acceptance check of ``bridgeflap optimise`` on the chosen layout.

The method: greedy backward elimination over mirror groups
    The 25 candidate strips of the packaged card form 13 mirror groups (12 pairs ``+-x`` and
    the centre strip; :func:`bridgeflap.design.control.search.layout_search.layout_groups`).
    An exact search would try up to ``2**13 - 1 = 8191`` layouts at 25-60 s each. The search
    starts from every candidate (the most authority). If that layout does not meet the target,
    none is expected to and the search stops (status ``no_layout_meets_target``, the full
    layout's record as the best achievable). Otherwise each step re-optimises K(s) for every
    layout one group smaller than the current one (each from the current layout's K: a
    continuation in the layout), and keeps the one that meets the target with the fewest strips,
    then the largest robust margin, then the innermost group removed. It stops when no one-group
    removal meets the target: the next smaller count is shown failing in every way the step
    tried. This costs ``1 + n + (n - 1) + ...`` designs down to the chosen layout (about 50
    for 13 groups down to 9), independent and run in parallel worker processes.

    Why not the relaxed placement: a flap weight is a load factor, so ``(w, K) -> (c w, K/c)``
    leaves the loop unchanged and the relaxed optimum is flat in ``w``
    (docs/background/control.md); a sparsity penalty then trades against K's gain rather than
    against authority. The backward elimination decides on converged, verified designs only,
    each with its real actuator limits, and every layout tried is a row of the result.

    It is greedy: the chosen layout is the fewest strips on the elimination path, not proven
    the fewest over all 8191 subsets. Each step is exhaustive over its one-group removals.

The result (:class:`PlacementResult`) carries every layout tried, the elimination path, the
trade-off per strip count (strips -> critical speed, max gain, 3 sigma flap angle and rate at
the target, failed-strip stability) and a figure of it.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from bridgeflap.design.control.results.placement import (
    NAN,
    PlacementResult,
    PlacementRow,
    _f,
    _finite,
)

__all__ = ["TARGET_MARGIN", "PlacementResult", "PlacementRow", "evaluate_layout",
           "placement_search", "placement_settings", "default_target_m_s"]

#: The default target is the open-loop divergence speed times ``1 + TARGET_MARGIN``: the same 1 %
#: the scenario bridges are held above their own open-loop critical speed
#: (design.control.solve.scenarios.NO_HARM_SPEED_MARGIN), which covers the 0.70 % by which a
#: critical speed moves between the 16-mode design model and the 30-mode check.
TARGET_MARGIN = 0.01
#: An actuator design speed within this of the target [m/s] is the target (not a second one).
SPEED_TOL_M_S = 1e-6


def default_target_m_s(open_loop: dict) -> float:
    """The default target speed [m/s] from the open-loop limits of
    :func:`bridgeflap.design.control.review.checks.closed_loop_limits`: the open-loop divergence
    speed times ``1 + TARGET_MARGIN`` (the flutter speed when no divergence was found)."""
    div = open_loop.get("open_loop_divergence_speed_m_s")
    if not _finite(div):
        div = open_loop.get("open_loop_flutter_speed_m_s")
    if not _finite(div):
        from bridgeflap.model.errors import BridgeflapInputError

        raise BridgeflapInputError("target_m_s", "the open loop has no critical speed on the "
                                                 "check range: give the target speed")
    return float(div) * (1.0 + TARGET_MARGIN)


def placement_settings(settings, target_m_s: float):
    """The card's settings for a layout of the search: damping held to at least ``target_m_s``
    (``speed_max_m_s`` raised to it when below) and the actuator demand held at ``target_m_s``
    besides the card's actuator design speeds below it; the layout is set per row."""
    u = float(target_m_s)
    speeds = sorted({float(v) for v in settings.actuator_design_speeds_m_s
                     if v < u - SPEED_TOL_M_S} | {u})
    return replace(settings, speed_max_m_s=max(float(settings.speed_max_m_s), u),
                   actuator_design_speeds_m_s=tuple(speeds), optimise_placement=False,
                   layout_neighbours=False, layout_adopt=False, parallel=False)


def evaluate_layout(settings, positions, theta0, target_m_s: float, open_loop_critical_m_s,
                    spec=None, variants=(), step: int = 0, groups=(), removed_group=None,
                    removed_radius_m: float = NAN) -> PlacementRow:
    """K(s) re-optimised on the layout ``positions`` [m] from ``theta0`` and judged against
    the target (module docstring). ``settings``: :func:`placement_settings` of the card.
    A failed solve is a row that does not meet the target (its status says why)."""
    from bridgeflap.design.control.formulation.problem_model import build_model
    from bridgeflap.design.control.solve.pair_failure import FailedPairProblem
    from bridgeflap.design.control.solve.start import layout_record
    from bridgeflap.model.structure.loader import load_bridge

    t0 = time.perf_counter()
    spec = load_bridge(settings.bridge if spec is None else spec)
    positions = tuple(sorted(float(x) for x in positions))
    rec = layout_record(settings, positions, theta0, step, spec, variants)
    why = []
    angle = rate = NAN
    demand_ok = False
    dem = rec.flap_demand
    if dem is not None:
        speeds = np.asarray(dem["speeds_m_s"], float)
        k = int(np.argmin(np.abs(speeds - target_m_s)))
        if abs(speeds[k] - target_m_s) < 1e-6:
            angle = float(dem["flap_angle_3sigma_deg"][k])
            rate = float(dem["flap_rate_3sigma_deg_s"][k])
        demand_ok = bool(dem["within_limits"])
        why += list(dem["exceeded"])
    elif rec.theta is not None:
        why.append("no actuator demand computed (the card sets no actuator design speed)")
    harm_ok = bool(rec.theta is not None
                   and all(v.get("meets_damping", False) for v in rec.variant_checks))
    fs_speed, fs_pos = NAN, NAN
    if rec.theta is None:
        why.append(f"no design: {rec.ipopt_status}")
    else:
        if not rec.meets_damping:
            why.append(f"damping zeta_min not met on the design model to "
                       f"{settings.speed_max_m_s:g} m/s (stable to {rec.stable_to_m_s:g} m/s)")
        if not rec.gain_ok:
            why.append(f"max gain {rec.max_gain:.3g} > {settings.gain_limit:g}")
        ver = rec.verification
        if ver is not None and not ver.stable_everywhere:
            why.append(f"{ver.modes}-mode check unstable from {ver.stable_to_m_s:g} m/s")
        if not harm_ok:
            why.append("harm on a scenario bridge (its damping below its own open-loop "
                       "critical speed)")
        if rec.verified and demand_ok:   # failed strips only for a layout that could be chosen
            model = build_model(settings, positions=positions, spec=spec)[1]
            worst = (math.inf, NAN)
            for f in range(model.n_flaps):
                v = FailedPairProblem(settings, model, f, spec=spec).verify(
                    np.asarray(rec.theta), refined=True)
                u = math.inf if v.stable_everywhere else float(v.stable_to_m_s)
                if u < worst[0]:
                    worst = (u, float(model.flaps.position_m[f]))
            fs_speed = float(settings.speed_max_m_s) if math.isinf(worst[0]) else worst[0]
            fs_pos = worst[1]
            if _finite(open_loop_critical_m_s) and fs_speed < open_loop_critical_m_s:
                why.append(f"one strip failed (at {fs_pos:g} m): stable only to "
                           f"{fs_speed:g} m/s, below the open loop's "
                           f"{open_loop_critical_m_s:.2f} m/s")
    meets = bool(rec.verified and demand_ok and harm_ok and not why)
    return PlacementRow(
        step=step, groups=tuple(int(g) for g in groups), removed_group=removed_group,
        removed_radius_m=float(removed_radius_m), flap_positions_m=positions,
        status=rec.ipopt_status, verified=bool(rec.verified), meets=meets, why_not=tuple(why),
        theta=None if rec.theta is None else tuple(float(v) for v in rec.theta),
        max_gain=float(rec.max_gain),
        robust_margin=float(rec.robust_margin) if rec.theta is not None else NAN,
        stable_to_m_s=float(rec.verification.stable_to_m_s) if rec.verification else NAN,
        flap_angle_3sigma_at_target_deg=angle, flap_rate_3sigma_at_target_deg_s=rate,
        demand_within_limits=demand_ok, no_harm_on_scenarios=harm_ok,
        failed_strip_stable_to_m_s=fs_speed, failed_strip_worst_position_m=fs_pos,
        iterations=int(rec.iterations), time_s=time.perf_counter() - t0)


def _choose(rows):
    """The step's choice among rows that meet the target: fewest strips, then the largest robust
    margin, then the innermost group removed (deterministic); None when none meets it."""
    ok = [r for r in rows if r.meets]
    if not ok:
        return None
    return min(ok, key=lambda r: (r.strips, -r.robust_margin,
                                  -1 if r.removed_group is None else r.removed_group))


def placement_search(settings, *, target_m_s: float | None = None, bridge=None, log=None,
                     workers: int = 2, max_steps: int | None = None, theta0=None,
                     evaluate=None) -> PlacementResult:
    """The fewest flap strips, and where, that meet ``target_m_s`` (module docstring).

    Parameters
    ----------
    settings : DesignSettings
        The design card (its candidates: ``settings.positions(settings.flap_count)``, evenly
        spaced; its actuator limits, scenarios and gain limit).
    target_m_s : float, optional
        Target usable speed [m/s]; default :func:`default_target_m_s` of the bridge.
    bridge : BridgeSpec, name or bridge TOML path, optional
        The bridge (default ``settings.bridge``).
    log : callable, optional
        ``str -> None``, one line per layout with the time left at the rate so far.
    workers : int
        Worker processes for the layouts of a step (1: in this process).
    max_steps : int, optional
        At most this many removal steps (default: until a step finds no layout).
    theta0 : array_like, optional
        K(s) to start the full layout from (default the nominal start).
    evaluate : callable, optional
        Replaces :func:`evaluate_layout` (same arguments; tests).

    Returns
    -------
    PlacementResult

    Raises
    ------
    BridgeflapTypeError
        ``settings`` is not a DesignSettings, or a number is not a number.
    BridgeflapInputError
        ``target_m_s``, ``workers`` or ``max_steps`` out of range, or the card sets no
        actuator design speed; before any work.
    """
    from bridgeflap.design.control.formulation.problem_model import NOMINAL_START
    from bridgeflap.design.control.review.checks import closed_loop_limits
    from bridgeflap.design.control.search.layout_search import layout_groups
    from bridgeflap.design.control.solve.scenarios import scenario_specs
    from bridgeflap.design.io.api_args import check_settings
    from bridgeflap.model.aeroelastic.control import Compensator, Controller
    from bridgeflap.model.errors import BridgeflapInputError, BridgeflapTypeError
    from bridgeflap.model.structure.loader import load_bridge

    t0 = time.perf_counter()
    check_settings(settings)
    if target_m_s is not None:
        if isinstance(target_m_s, bool) or not isinstance(target_m_s, (int, float)):
            raise BridgeflapTypeError("target_m_s", f"must be a number [m/s], got "
                                                    f"{type(target_m_s).__name__}")
        if not (_finite(target_m_s) and target_m_s > 0):
            raise BridgeflapInputError("target_m_s", f"must be a speed > 0 m/s, got "
                                                     f"{target_m_s}")
    for name, v, low in (("workers", workers, 1), ("max_steps", max_steps, 0)):
        if v is None and name == "max_steps":
            continue
        if isinstance(v, bool) or not isinstance(v, int):
            raise BridgeflapTypeError(name, f"must be an integer, got {type(v).__name__}")
        if v < low:
            raise BridgeflapInputError(name, f"must be an integer >= {low}, got {v}")
    if log is not None and not callable(log):
        raise BridgeflapTypeError("log", "must be a callable str -> None")
    if not settings.actuator_design_speeds_m_s:
        raise BridgeflapInputError("settings", "the card sets no actuator_design_speeds_m_s: "
                                               "the placement judges layouts on their flap "
                                               "demand")
    log = log or (lambda msg: None)
    evaluate = evaluate or evaluate_layout
    spec = load_bridge(settings.bridge if bridge is None else bridge)
    cand = np.asarray(settings.positions(settings.flap_count), float)
    S = layout_groups(cand, settings.symmetric_layout)
    n_groups = S.shape[1]
    radius = [float(np.abs(cand[S[:, j] > 0.5]).min()) for j in range(n_groups)]
    # the open loop's limits on the verification model (the closed-loop sweep's open-loop
    # reference, which does not depend on the controller)
    zero = Controller(Compensator(*(float(v) for v in NOMINAL_START)),
                      tuple(float(x) for x in cand), settings.flap_width_m,
                      settings.leading_edge, settings.trailing_edge, settings.gain_limit,
                      flap_chord_m=settings.flap_chord_m)
    lim = closed_loop_limits(settings, zero, spec)
    open_loop = {k: lim.get(k) for k in ("open_loop_flutter_speed_m_s",
                                          "open_loop_divergence_speed_m_s")}
    ol_crit = min((v for v in open_loop.values() if _finite(v)), default=NAN)
    open_loop["open_loop_critical_speed_m_s"] = ol_crit
    if target_m_s is None:
        target_m_s = default_target_m_s(open_loop)
        basis = (f"open-loop divergence speed x (1 + {TARGET_MARGIN:g}) on the "
                 f"{settings.verification_modes}-mode model")
    else:
        basis = "given"
    target_m_s = float(target_m_s)
    s_t = placement_settings(settings, target_m_s)
    variants = scenario_specs(s_t, spec)
    log(f"placement: target {target_m_s:.2f} m/s ({basis}); {cand.size} candidate strips in "
        f"{n_groups} mirror groups; open-loop critical speed {ol_crit:.2f} m/s")

    def masks_positions(groups):
        z = np.zeros(n_groups)
        z[list(groups)] = 1.0
        return tuple(float(x) for x in cand[(S @ z) > 0.5])


    def run_step(step, jobs):
        """``jobs``: (groups, removed, theta0) per layout; rows in job order."""
        out = [None] * len(jobs)
        args = [(s_t, masks_positions(g), th, target_m_s, ol_crit, spec, variants, step,
                 tuple(sorted(g)), rm, radius[rm] if rm is not None else NAN)
                for g, rm, th in jobs]

        t_step = time.perf_counter()

        def note(k, r):
            # the time left at this step's rate so far (wall time: the workers run in parallel)
            left = (time.perf_counter() - t_step) / (k + 1) * (len(jobs) - k - 1)
            log(f"step {step}: layout {k + 1}/{len(jobs)} ({r.strips} strips"
                + (f", without +-{radius[r.removed_group]:g} m" if r.removed_group is not None
                   else "") + f"): {'meets the target' if r.meets else 'fails'} "
                f"({r.status}, max gain {r.max_gain:.3g}, angle 3s "
                f"{_f(r.flap_angle_3sigma_at_target_deg, '.1f')} deg) in {r.time_s:.0f} s; this "
                f"step ends in about {left:.0f} s")

        if pool[0] is not None and len(jobs) > 1:
            futs = [pool[0].submit(evaluate, *a) for a in args]
            for k, f in enumerate(futs):
                out[k] = f.result()
                note(k, out[k])
        else:
            for k, a in enumerate(args):
                out[k] = evaluate(*a)
                note(k, out[k])
        return out

    full = tuple(range(n_groups))
    first = np.asarray(NOMINAL_START if theta0 is None else theta0, float)
    pool = [None]
    if workers > 1:   # one pool for every step: its workers keep their scenario caches
        from bridgeflap.model.workers import process_pool

        pool[0] = process_pool(workers)
    try:
        rows, path, status = _search(run_step, full, first, max_steps, radius, log)
    finally:
        if pool[0] is not None:
            pool[0].shutdown(cancel_futures=True)
    chosen = path[-1] if rows[path[-1]].meets else None
    summary = {"card_bridge": str(settings.bridge), "n_modes": settings.n_modes,
               "verification_modes": settings.verification_modes,
               "speed_max_m_s": s_t.speed_max_m_s,
               "actuator_design_speeds_m_s": list(s_t.actuator_design_speeds_m_s),
               "flap_angle_limit_deg": settings.flap_angle_limit_deg,
               "flap_rate_limit_deg_s": settings.flap_rate_limit_deg_s,
               "gain_limit": settings.gain_limit, "scenario_bridges": len(variants)}
    return PlacementResult(status=status, target_m_s=target_m_s, target_basis=basis,
                           open_loop=open_loop, rows=tuple(rows), path=tuple(path),
                           chosen=chosen, candidates_m=tuple(float(x) for x in cand),
                           groups=n_groups, time_s=time.perf_counter() - t0,
                           settings_summary=summary)


def _search(run_step, full, first, max_steps, radius, log):
    """The elimination (module docstring): ``(rows, path, status)``."""
    rows = list(run_step(0, [(full, None, first)]))
    row = rows[0]
    path = [0]
    status = "found"
    if not row.meets:
        status = "no_layout_meets_target"
    else:
        step = 0
        current = full
        while True:
            if max_steps is not None and step >= max_steps:
                status = "stopped"
                break
            if len(current) <= 1:
                break
            step += 1
            parent = rows[path[-1]]
            jobs = [(tuple(g for g in current if g != rm), rm, parent.theta)
                    for rm in current]
            got = run_step(step, jobs)
            base = len(rows)
            rows.extend(got)
            best = _choose(got)
            if best is None:
                break
            path.append(base + next(i for i, r in enumerate(got) if r is best))
            current = best.groups
            log(f"step {step}: kept {best.strips} strips (without +-"
                f"{radius[best.removed_group]:g} m), robust margin {best.robust_margin:.3g}")
    return rows, path, status
