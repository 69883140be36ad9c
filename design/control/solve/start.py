"""One start of the multistart design (:func:`bridgeflap.design.control.search.driver.design`): the
starting points (the nominal one and screened Sobol points), the solve with cutting planes, the
rounding of a relaxed flap layout by whole groups and the re-solve on it, the record of a solved
start (dense margin, verification-model check, design variants), and the choice among the starts.
Below the driver, so that the critical-speed search and the layout search run starts and layouts
without importing the driver back."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from bridgeflap.design.control.formulation.loop_algebra import (
    compensator_damped,
    compensator_damping_ratio,
)
from bridgeflap.design.control.formulation.nlp import EIG_SCALE, DesignProblem
from bridgeflap.design.control.formulation.nlp_tolerances import SPEED_GUARD_REL
from bridgeflap.design.control.formulation.problem_model import build_model, verify_layout
from bridgeflap.design.control.results.records import RobustMargin, StartRecord
from bridgeflap.design.control.review.checks import nlp_active_speeds
from bridgeflap.design.control.settings import DesignSettings
from bridgeflap.model.aeroelastic.control import Compensator
from bridgeflap.model.progress import Eta

NAN = float("nan")


def round_layout(S, z, budget=0) -> np.ndarray:
    """0/1 flap weights from relaxed placement variables ``z`` (``w = S z``).

    The groups (mirror pairs with ``symmetric_layout``) are taken largest ``z`` first: with a
    ``budget`` > 0 while the flap count stays within it, otherwise every group with
    ``z > 0.5``; at least the largest group is kept (of groups within 1e-6 of the largest, the
    first), so a layout never loses every flap.
    The rounded layout stays symmetric because whole groups are kept.
    """
    S = np.asarray(S, float)
    z = np.asarray(z, float)
    sizes = S.sum(axis=0)
    keep = np.zeros(z.size, bool)
    count = 0.0
    for j in np.argsort(-z, kind="stable"):
        if budget > 0:
            if count + sizes[j] > budget:
                continue
        elif z[j] <= 0.5:
            break
        keep[j] = True
        count += sizes[j]
    if not keep.any():      # the largest group; near-equal ones (1e-6) by the lower index
        keep[int(np.flatnonzero(z >= z.max() - 1e-6)[0])] = True
    return (S @ keep.astype(float) > 0.5).astype(float)


#: Layouts whose scores (:func:`choose_layout`) lie within this relative distance of the best
#: count as equal, and the rule decides among them (fewer flaps, then the positions in
#: lexicographic order). Converged solves on other BLAS kernels agree to ~1e-4 relative (the
#: default card, OpenBLAS SkylakeX/Haswell/Sandybridge/Nehalem): 1 % is 100 times that.
LAYOUT_TIE_REL = 0.01
#: At most this many groups inside the dead band are decided by evaluating both roundings
#: (2^3 = 8 layouts); any further ones (the farthest from 0.5) are rounded at 0.5.
DEAD_BAND_GROUPS = 3


def layout_candidates(S, z, dead_band, budget=0) -> list[np.ndarray]:
    """The 0/1 flap weights a relaxed solution ``z`` may round to: :func:`round_layout`, and
    with no ``budget`` every choice of the groups within ``dead_band`` of 0.5 (at most
    :data:`DEAD_BAND_GROUPS` of them, the closest to 0.5), each such group in or out."""
    z = np.asarray(z, float)
    base = round_layout(S, z, budget)
    if budget > 0 or dead_band <= 0:
        return [base]
    near = np.flatnonzero(np.abs(z - 0.5) < dead_band)
    near = near[np.argsort(np.abs(z[near] - 0.5), kind="stable")][:DEAD_BAND_GROUPS]
    if not near.size:
        return [base]
    S = np.asarray(S, float)
    keep0 = (z > 0.5).astype(float)
    out = []
    for bits in range(2 ** near.size):
        keep = keep0.copy()
        keep[near] = [(bits >> i) & 1 for i in range(near.size)]
        if keep.any():
            out.append((S @ keep > 0.5).astype(float))
    return out


def choose_layout(settings, prob, res, w_cont) -> tuple[np.ndarray, dict]:
    """The rounded layout of a relaxed placement solve and how it was chosen.

    A layout is chosen only from a converged relaxed solution (Ipopt converged, the chosen
    round meets the damping and is not the phase-1 point); otherwise every candidate pair is
    kept (a fixed rule, not the unconverged weights). Groups within ``layout_dead_band`` of the
    0.5 threshold are decided by evaluating both roundings (:func:`layout_candidates`) at the
    relaxed K on the candidates' model: meeting the damping on the check grid first, then the
    larger dense robust margin at ``robust_speeds_m_s``; scores within
    :data:`LAYOUT_TIE_REL` tie and the rule decides (fewer flaps, then lexicographic positions).
    """
    S = prob.symmetry
    z = prob.z_of(w_cont)
    chosen_round = res.rounds[res.chosen_round] if res.rounds else None
    converged = bool(res.solve.success and res.verification.meets_damping
                     and not (chosen_round is not None and chosen_round.placement
                              and chosen_round.placement.startswith("phase 1")))
    info = {"relaxed_converged": converged, "weights_near_threshold": [
        float(v) for v in z if abs(v - 0.5) < settings.layout_dead_band]}
    if not converged:
        return np.ones(S.shape[0]), {**info, "rule": "relaxed solve not converged: every "
                                                     "candidate pair kept"}
    cands = layout_candidates(S, z, settings.layout_dead_band, settings.flap_budget)
    if len(cands) == 1:
        return cands[0], {**info, "rule": "rounded at 0.5 (no weight in the dead band)"}
    pos = settings.positions()
    rows = []
    for w in cands:
        ver = prob.verify(res.theta, w, refined=True)
        margin = (prob.robust_margin(res.theta, weights=w).margin
                  if settings.weight_robust > 0 and settings.robust_speeds_m_s else 0.0)
        rows.append({"flap_positions_m": [float(x) for x in pos[w > 0.5]],
                     "meets_damping": bool(ver.meets_damping), "robust_margin": float(margin)})
    best = max((r["robust_margin"] for r in rows if r["meets_damping"]), default=None)

    def rank(i):
        r = rows[i]
        top = (best is not None and r["meets_damping"]
               and r["robust_margin"] >= best * (1.0 - LAYOUT_TIE_REL))
        return (not top, not r["meets_damping"], len(r["flap_positions_m"]),
                tuple(r["flap_positions_m"]))

    i = min(range(len(rows)), key=rank)
    return cands[i], {**info, "rule": f"dead band: {len(cands)} roundings evaluated at the "
                                      f"relaxed K (damping, then margin within "
                                      f"{LAYOUT_TIE_REL:g}, then fewer flaps)",
                      "candidates": rows, "chosen_candidate": int(i)}


#: Candidates screened per Sobol start (:func:`screened_starts`).
SCREEN_FACTOR = 8


def sobol_starts(settings: DesignSettings, count: int) -> np.ndarray:
    """Sobol points in the compensator box (b's in [-5, 5], a2, a1 log-uniform) (count, 5)."""
    from scipy.stats import qmc

    m = max(1, int(np.ceil(np.log2(max(count, 1)))))
    pts = qmc.Sobol(5, scramble=True, seed=settings.seed).random_base2(m)[:count]
    lo_a2, hi_a2 = np.log10(0.01), np.log10(1.0)
    lo_a1, hi_a1 = np.log10(0.05), np.log10(3.0)
    th = np.empty((count, 5))
    th[:, :3] = -5.0 + 10.0 * pts[:, :3]
    th[:, 3] = 10 ** (lo_a2 + (hi_a2 - lo_a2) * pts[:, 3])
    th[:, 4] = 10 ** (lo_a1 + (hi_a1 - lo_a1) * pts[:, 4])
    th[:, 0] = np.clip(th[:, 0], -0.5 * settings.gain_limit * th[:, 3],
                       0.5 * settings.gain_limit * th[:, 3])
    # the compensator's poles damped as the NLP asks (a1 >= 2 zeta_c sqrt(a2)), 10 % over
    th[:, 4] = np.maximum(th[:, 4], 2.2 * settings.compensator_damping_min * np.sqrt(th[:, 3]))
    return th


def screened_starts(settings: DesignSettings, count: int, model=None,
                    spec=None) -> np.ndarray:
    """``count`` Sobol starts, the best of ``SCREEN_FACTOR * count`` Sobol candidates.

    Raw Sobol points in the compensator box are mostly far from feasible (positive static
    gain, fast lead) and a start from there can use the whole Ipopt budget (80 iterations,
    ~80 s on 16 modes) to reach a poor local solution. Each candidate is scored by the NLP's
    own merit at the start point: ``weight_robust * gamma_T0 + EIG_SCALE * max(0, max
    violation of the damping constraints)`` (objective plus an exact l-inf penalty on the
    scaled eigenvalue constraints, unit weight) on a 10 m/s speed grid and the robust sample
    points; candidates with ``sup|K| > gain_limit`` are rejected first. Cost: one eig per
    speed and one epigraph evaluation per candidate (~0.2 s on 16 modes).
    """
    if count <= 0:
        return np.empty((0, 5))
    cand = sobol_starts(settings, SCREEN_FACTOR * count)
    if model is None:
        _, model = build_model(settings, spec=spec)
    prob = DesignProblem(replace(settings, optimise_placement=False), model)
    speeds = np.unique(np.append(np.arange(0.0, settings.speed_max_m_s, 10.0),
                                 settings.speed_max_m_s))
    use_rob = settings.weight_robust > 0 and bool(settings.robust_design_speeds_m_s)
    rob = prob.robust_function(analytic=True)[0] if use_rob else None
    w = np.ones(model.n_flaps)
    scores = []
    for th in cand:
        if Compensator(*(float(v) for v in th)).max_gain() > settings.gain_limit:
            scores.append(np.inf)
            continue
        viol = float(np.max(prob.constraint_values(th, speeds)))
        gam = float(np.sqrt(np.max(np.asarray(rob(th, w).full())))) if rob else 0.0
        sc = settings.weight_robust * gam + EIG_SCALE * max(0.0, viol)
        scores.append(sc if np.isfinite(sc) else np.inf)
    order = np.argsort(np.asarray(scores), kind="stable")
    return cand[order[:count]]


def _progress_bar(index: int, show, total: int):
    """tqdm bar on stderr of one start's Ipopt iterations out of ``total``, their cap (None
    when not shown: ``show`` None means "stderr is a terminal")."""
    import sys

    if not (sys.stderr.isatty() if show is None else show):
        return None
    from tqdm import tqdm

    return tqdm(desc=f"start {index} Ipopt", unit="it", file=sys.stderr, leave=False,
                position=index, total=total)


def run_start(settings: DesignSettings, theta0, index: int, spec=None,
              progress_bar=None, variants=(), say=None) -> StartRecord:
    """One start: solve with cuts (placement: round the weights, re-solve), then the dense
    robust margin and the check on the verification model. A failure is a record (STYLE).
    ``spec``: the bridge (default ``settings.bridge``); ``progress_bar``: a tqdm bar of the
    Ipopt iterations on stderr (None: when stderr is a terminal); ``variants``: bridge
    variants (BridgeSpec) of a multi-model design -- every damping constraint and check on
    every variant as well; ``say``: a progress function (None: silent), told at every tenth of
    the iteration cap how many Ipopt iterations ran, with the elapsed time and the time left at
    the rate so far (an upper bound: the cap is rarely reached)."""
    from bridgeflap.design.control.solve.pair_failure import extra_models

    t0 = time.perf_counter()
    spec, model = build_model(settings, spec=spec)
    relaxed = settings
    if settings.optimise_placement and settings.placement_cut_rounds >= 0:
        # the relaxed rounds only choose the layout: their own cut budget
        relaxed = replace(settings, cutting_plane_rounds=settings.placement_cut_rounds)
    prob = DesignProblem(relaxed, model, spec=spec)
    prob.speed_guard_rel = SPEED_GUARD_REL
    # multi-model with placement: the relaxed solve chooses the layout on the nominal bridge,
    # the variants join the rounded layout's K (fixed layout: 5 parameters per variant block,
    # not 5 + the flap weights; measured: variants in the relaxed solve too took the default
    # card to 3.4 min, round 0 capped infeasible, against ~1 min)
    if not settings.optimise_placement:
        prob.variants = extra_models(settings, model, spec, variants)
    cap = settings.iteration_cap()
    bar = _progress_bar(index, progress_bar, cap)
    if bar is not None or say is not None:
        eta, every, count = Eta(cap), max(1, cap // 10), [0]

        def tick(i, f, x):
            count[0] += 1  # over every Ipopt solve of the start (i restarts with each)
            if bar is not None:
                bar.update(1)
                bar.set_postfix_str(f"objective {f:.4g}", refresh=False)
            if say is not None and count[0] == 1:
                # at once: a solve may converge before a tenth of its cap
                say(f"start {index}: Ipopt running (at most {cap} iterations)")
            if say is not None and count[0] % every == 0:
                say(f"start {index}: {count[0]} Ipopt iterations of at most {cap}, "
                    f"objective {f:.4g} {eta.text(count[0])}")
        prob.on_iteration = tick
    theta0 = tuple(float(v) for v in theta0)
    w_cont = layout_choice = None
    try:
        res = prob.solve_with_cuts(np.asarray(theta0))
        rounds = list(res.rounds)
        positions = settings.positions()
        if settings.optimise_placement:
            w_cont = tuple(float(v) for v in res.solve.weights)
            rounded, layout_choice = choose_layout(settings, prob, res, w_cont)
            positions = positions[rounded > 0.5]
            prob, res = solve_fixed_layout(settings, positions, res.theta, spec, variants,
                                           prob.on_iteration)
            rounds += [replace(r, placement="rounded") for r in res.rounds]
    except Exception as exc:  # noqa: BLE001 - solver failure is data (STYLE)
        if bar is not None:
            bar.close()
        return StartRecord(start=index, theta0=theta0, ipopt_status=f"failed: {exc}",
                           success=False, time_s=time.perf_counter() - t0,
                           weights_continuous=w_cont)
    if bar is not None:
        bar.close()
    rec = _start_record(settings, prob, res, rounds, positions, theta0, index, t0, w_cont, spec)
    return replace(rec, layout_choice=layout_choice) if settings.optimise_placement else rec


def solve_fixed_layout(settings: DesignSettings, positions, theta0, spec=None, variants=(),
                       on_iteration=None):
    """K(s) re-optimised with cutting planes on the flaps at ``positions`` [m] only, from
    ``theta0`` (the rounded layout's step of :func:`run_start`; also
    :mod:`bridgeflap.design.control.search.layout_search`). The candidates left out are not built,
    so the flap loop (and its robust margin) has no channel for them. ``variants``: multi-model
    bridges. Returns ``(problem, CutsOutcome)``; raises what the solve raises."""
    from bridgeflap.design.control.solve.pair_failure import extra_models
    from bridgeflap.model.structure.loader import load_bridge

    spec = load_bridge(settings.bridge if spec is None else spec)
    fixed_s = replace(settings, optimise_placement=False)
    fixed = DesignProblem(fixed_s, build_model(settings, positions=positions, spec=spec)[1],
                          spec=spec)
    fixed.on_iteration = on_iteration
    fixed.speed_guard_rel = SPEED_GUARD_REL
    fixed.variants = extra_models(fixed_s, fixed.model, spec, variants, positions)
    return fixed, fixed.solve_with_cuts(np.asarray(theta0, float))


def layout_record(settings: DesignSettings, positions, theta0, index: int = 0, spec=None,
                  variants=()) -> StartRecord:
    """K(s) re-optimised and checked on the fixed layout ``positions`` [m] from ``theta0``,
    exactly as :func:`run_start` treats a rounded layout (:func:`solve_fixed_layout`, then
    the same dense margin and verification); a failed solve is a record (STYLE)."""
    t0 = time.perf_counter()
    theta0 = tuple(float(v) for v in theta0)
    positions = np.asarray(positions, float)
    try:
        prob, res = solve_fixed_layout(settings, positions, theta0, spec, variants)
    except Exception as exc:  # noqa: BLE001 - solver failure is data (STYLE)
        return StartRecord(start=index, theta0=theta0, ipopt_status=f"failed: {exc}",
                           success=False, time_s=time.perf_counter() - t0,
                           flap_positions_m=tuple(float(x) for x in positions))
    return _start_record(settings, prob, res, list(res.rounds), positions, theta0, index, t0,
                         None, prob.spec)


def _start_record(settings, prob, res, rounds, positions, theta0, index, t0, w_cont,
                  spec) -> StartRecord:
    """The record of a solved start: dense margin, verification-model check, variants."""
    from bridgeflap.design.control.solve.pair_failure import pair_label

    theta = res.theta
    ver = res.verification
    rob = _margin_at(res.robust, settings.robust_speeds_m_s)
    if rob is None:
        rob = prob.robust_margin(theta)
    ver16 = (verify_layout(settings, theta, positions, spec=spec)
             if settings.verification_modes != settings.n_modes else ver)
    gain_ok = bool(ver.max_gain <= settings.gain_limit)
    comp_ok = compensator_damped(theta, settings.compensator_damping_min)
    # the design variants on the refined check grid (the dense check's decisions: damping
    # met, first unstable speed; the smallest damping ratio over the speeds checked)
    vchecks = [q.verify(theta, refined=True) for q in prob.variants]
    variants_ok = all(v.meets_damping for v in vchecks)
    demand = flap_demand_record(settings, prob, theta)
    return StartRecord(
        start=index, theta0=theta0, theta=tuple(float(v) for v in theta),
        ipopt_status=res.solve.ipopt_status, success=res.solve.success,
        iterations=sum(r.iterations for r in rounds), time_s=time.perf_counter() - t0,
        rounds=tuple(rounds), max_violation_1_s=ver.max_violation_1_s,
        stable_to_m_s=ver.stable_to_m_s, stable_everywhere=ver.stable_everywhere,
        max_gain=ver.max_gain, meets_damping=ver.meets_damping, gain_ok=gain_ok,
        # verified: every a posteriori check holds, whatever Ipopt's exit status
        verified=bool(ver.meets_damping and gain_ok and comp_ok and ver16.stable_everywhere
                      and variants_ok),
        compensator_damping_ratio=compensator_damping_ratio(theta),
        gamma_T_frobenius=res.solve.gamma_T, phase_1_point=_phase_1(res),
        objective=NAN if _phase_1(res) else float(res.solve.objective),
        dense_t_peak_check_speeds=res.robust.peak if res.robust is not None else float("nan"),
        robust_bound_holds=res.robust_bound_holds, robust=rob, verification=ver16,
        robust_cuts=res.robust_cuts, gain_cuts=res.gain_cuts,
        flap_positions_m=tuple(float(x) for x in positions),
        design_speeds_m_s=res.design_speeds_m_s, weights_continuous=w_cont,
        nlp_active_speeds_m_s=nlp_active_speeds(res.solve, res.design_speeds_m_s,
                                                settings.n_eig),
        variant_checks=tuple({**pair_label(q), "speed_limit_m_s": q.settings.speed_max_m_s,
                              "meets_damping": v.meets_damping,
                              "min_damping_ratio": v.min_damping_ratio,
                              "stable_to_m_s": v.stable_to_m_s}
                             for q, v in zip(prob.variants, vchecks, strict=True)),
        design_verification=ver, nlp_objective=float(res.solve.objective),
        flap_demand=demand, actuator_ok=bool(demand is None or demand["within_limits"]))


def flap_demand_record(settings: DesignSettings, prob, theta) -> dict | None:
    """The a posteriori check of the actuator-demand constraints at the solution ``theta``:
    the 3 sigma flap angle [deg] and rate [deg/s] per ``actuator_design_speeds_m_s`` on the
    NLP's own frozen integral (:meth:`DesignProblem.flap_demand`, built by the solve), against
    the card's limits themselves (the NLP holds 5 % inside them); None without actuator
    constraints (none set, or a placement's relaxed problem). ``scenarios``: the same on each
    scenario bridge at its one actuator speed
    (:func:`bridgeflap.design.control.solve.scenarios.scenario_demand_speed`), with whether the
    NLP held it. A design whose demand exceeds a limit, on the nominal bridge or a scenario, is
    not feasible: the NLP did not meet its own constraint (a solve stopped at an infeasible or
    capped iterate)."""
    from bridgeflap.design.control.formulation.actuator_demand import SIGMAS

    dem = prob.callbacks.get("flap_demand")
    if not settings.actuator_design_speeds_m_s or settings.optimise_placement or dem is None:
        return None
    r = SIGMAS * dem.rms_deg(np.asarray(theta, float))
    angle, rate = r[:, :2].max(axis=1), r[:, 2:].max(axis=1)
    a_lim, r_lim = float(settings.flap_angle_limit_deg), float(settings.flap_rate_limit_deg_s)
    over = [f"flap angle 3 sigma {a:.3g} deg > {a_lim:g} deg at {u:g} m/s"
            for u, a in zip(dem.speeds_m_s, angle, strict=True) if a > a_lim]
    over += [f"flap rate 3 sigma {v:.3g} deg/s > {r_lim:g} deg/s at {u:g} m/s"
             for u, v in zip(dem.speeds_m_s, rate, strict=True) if v > r_lim]
    scen = []
    for j, v in enumerate(getattr(prob, "variants", ())):
        vd = v.callbacks.get("flap_demand") if v.demand_held is not None else None
        if vd is None:
            continue
        rv = SIGMAS * vd.rms_deg(np.asarray(theta, float))
        for u, row in zip(vd.speeds_m_s, rv, strict=True):
            a, r = float(row[:2].max()), float(row[2:].max())
            scen.append({"scenario": j, "speed_m_s": float(u), "flap_angle_3sigma_deg": a,
                         "flap_rate_3sigma_deg_s": r, "held_in_nlp": bool(v.demand_held)})
            if a > a_lim:
                over.append(f"flap angle 3 sigma {a:.3g} deg > {a_lim:g} deg at {u:g} m/s "
                            f"on scenario {j}")
            if r > r_lim:
                over.append(f"flap rate 3 sigma {r:.3g} deg/s > {r_lim:g} deg/s at {u:g} m/s "
                            f"on scenario {j}")
    return {"speeds_m_s": [float(u) for u in dem.speeds_m_s],
            "flap_angle_3sigma_deg": [float(a) for a in angle],
            "flap_rate_3sigma_deg_s": [float(v) for v in rate],
            "flap_angle_limit_deg": a_lim, "flap_rate_limit_deg_s": r_lim,
            "within_limits": not over, "exceeded": over,
            "scenarios": scen,
            "basis": "the design's own frozen spectral integral (ideal actuator), the two "
                     "flaps of largest demand; each scenario bridge at its own actuator speed "
                     "(the card's top one, or its open-loop critical speed when lower)"}


def _phase_1(res) -> bool:
    """The cuts kept the phase-1 point (its objective is not the design's)."""
    lab = res.rounds[res.chosen_round].placement if res.rounds else None
    return bool(lab and lab.startswith("phase 1"))


def _margin_at(rob, speeds):
    """The dense margin at ``speeds`` [m/s] taken from a check ``rob`` (RobustMargin) of the
    same design on a superset of speeds (the cutting-plane check at the design and reported
    speeds: same per-speed grid and peak polishing), or None when ``rob`` lacks a speed --
    not recomputed."""
    if rob is None:
        return None
    have = {float(u): i for i, u in enumerate(rob.speeds_m_s)}
    idx = [have.get(float(u)) for u in speeds]
    if not idx or any(i is None for i in idx):
        return None
    t_inf = np.asarray(rob.t_inf)[idx]
    return RobustMargin(speeds_m_s=np.asarray(speeds, float), t_inf=t_inf,
                        peak_omega_rad_s=np.asarray(rob.peak_omega_rad_s)[idx],
                        peaks=tuple(rob.peaks[i][:1] for i in idx),
                        margin=float(1.0 / t_inf.max()))




#: Verified starts whose NLP objectives lie within this relative distance of the lowest tie:
#: the one with fewer flaps, then the lower start index, is chosen. Two starts that converge
#: to one design agree to ~1e-4 (other BLAS kernels); distinct local optima 0.27 % apart were
#: ranked by last-bit differences before (the default card on four OpenBLAS kernels).
START_TIE_REL = 0.01


def select_start(records, gain_limit) -> tuple[StartRecord | None, str]:
    """Chosen start and design status from the per-start records of :func:`run_start`.

    ``converged``: the *verified* start (damping on the design model's dense grid, true peak
    gain ``max_gain <= gain_limit`` -- no tolerance, the NLP backs off by ``GAIN_BACKOFF``
    --, stable on the verification model) with the lowest NLP objective (the design's own
    objective); objectives within :data:`START_TIE_REL` of the lowest tie, and the tie goes
    to fewer flaps, then the lower start index; after them the starts without an objective
    (a phase-1 point, NaN) by the larger margin; whatever its Ipopt exit status;
    ``unverified``: feasible on the design model only; ``infeasible``: no start meets the
    damping, the gain limit and the flap demand within the actuator limits
    (:func:`flap_demand_record`; the least violating is reported, never as converged);
    ``failed``: no start produced a design.
    """
    feasible = [r for r in records if r.meets_damping and r.max_gain <= gain_limit
                and r.actuator_ok]
    verified = [r for r in feasible if r.verified]
    if verified:
        best = min((r.objective for r in verified if np.isfinite(r.objective)),
                   default=np.inf)
        tie = best + START_TIE_REL * abs(best) if np.isfinite(best) else np.inf

        def rank(r):    # ties (START_TIE_REL) by fewer flaps, then the lower start index
            ok = np.isfinite(r.objective) and r.objective <= tie
            return (not ok, len(r.flap_positions_m) if ok else 0,
                    r.start if ok else r.objective if np.isfinite(r.objective) else np.inf,
                    -r.robust_margin, r.start)

        return min(verified, key=rank), "converged"
    if feasible:
        return max(feasible, key=lambda r: r.verification.stable_to_m_s), "unverified"
    cands = [r for r in records if not r.failed]
    if not cands:
        return None, "failed"
    return min(cands, key=lambda r: (max(r.max_violation_1_s, 0.0), not r.actuator_ok,
                                     r.max_gain)), "infeasible"
