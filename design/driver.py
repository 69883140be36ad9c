"""Multistart driver of the compensator design: starts, per-start runs, selection, checks.

:func:`design` runs one :class:`design.nlp.DesignProblem` per start (a nominal start and
screened Sobol points, optionally in processes), selects one (:func:`select_start`), checks it
on the verification model, searches the minimum flap count and compares buffeting.

Verification. Every solution is checked a posteriori on the dense ``check_step_m_s`` grid
(cutting planes: violating speeds join the design grid and the problem is re-solved) and, when
the design model is reduced, on the ``verification_modes`` model that ``bridgeflap flutter``
uses (:data:`model.analysis.DEFAULT_MODES`); the result reports both honestly.

Placement. With ``optimise_placement`` the per-flap weights ``w`` (load factor, 1 = fitted;
one per mirror pair with ``symmetric_layout``) are NLP variables with an optional budget
``sum(w) <= flap_budget`` and penalty ``weight_flaps * sum(w)/n_flaps``; the solution is
rounded by whole pairs (:func:`round_layout`), ``theta`` re-solved for the rounded layout and
re-verified. :func:`minimum_flap_count` checks every evenly spaced count with the same K;
:func:`flap_count_pareto` (``pareto = true``) re-optimises and verifies K for every count.

Every result reports the closed-loop flutter and divergence limits and mechanism
(:func:`closed_loop_limits`) and the constraints active at the optimum
(:func:`active_constraints`). Multi-model (``variants`` > 0): damping constraints on bridge
variants sampled over the estimated-input ranges, fresh variants checked a posteriori.

Parallel starts use a process pool (:func:`model.workers.process_pool`), not the Dask cluster of
the DOE (:mod:`design.cluster`; issue 15 item 7). A design runs two to four long tasks once,
inside one call, on the local machine: the executor starts in 0.16 s, while a Dask
``LocalCluster`` of two workers took 10.0 s to start and 2.3 s to close on the loaded
2-core machine (load 11), a fifth of the 60 s budget, and would import dask/distributed on a
command that otherwise does not (issue 16 goal 5). Dask's retries, time limits and remote
schedulers serve batches of many short cases; a failed start here is already a record.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from design.checks import (  # noqa: F401 - re-exported (tests, API)
    ACTIVE_ABS_TOL_1_S,
    ACTIVE_REL_TOL,
    LIMIT_SPEED_FACTOR,
    LIMIT_STEP_M_S,
    active_constraints,
    buffeting_comparison,
    closed_loop_limits,
    flap_count_pareto,
    fresh_variant_check,
    fresh_variant_rows,
    fresh_variant_summary,
    limits_text,
    margin_on_speed_grid,
    nlp_active_speeds,
    sample_variants,
)
from design.flap_count import MISSES_TO_STOP, minimum_flap_count  # noqa: F401 - re-exported
from design.layout_search import round_layout  # noqa: F401 - re-exported (tests, API)
from design.nlp import EIG_SCALE, DesignProblem
from design.plant import closed_loop_abscissa
from design.problem_model import build_model  # noqa: F401 - re-exported (tests, API)
from design.records import (
    BuffetingComparison,
    RobustMargin,
    StartRecord,
    Verification,
)
from design.result import DesignResult
from design.settings import DesignSettings
from model.control import Compensator, Controller
from model.spec import load_bridge
from model.vocabulary import renamed

NAN = float("nan")
#: Nominal first start (b2, b1, b0, a2, a1): static gain -1 (flap against pitch), mild rate.
NOMINAL_START = np.array([0.0, 0.5, -1.0, 0.05, 0.5])
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


def verify_layout(settings: DesignSettings, theta, positions, n_modes=None,
                  spec=None, refined=False) -> Verification:
    """Dense check of ``theta`` on the layout ``positions`` [m] with ``n_modes`` (default: the
    verification model, ``settings.verification_modes``), as ``bridgeflap flutter`` sees it;
    ``spec`` the bridge (default ``settings.bridge``); ``refined``: on the refined subset of
    the check grid (:func:`design.plant.damping_check_refined`: the same decisions)."""
    nm = settings.verification_modes if n_modes is None else int(n_modes)
    _, model = build_model(settings, n_modes=nm, positions=positions, spec=spec)
    return DesignProblem(replace(settings, optimise_placement=False), model,
                         numeric=True).verify(theta, refined=refined)


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
              progress_bar=None, variants=()) -> StartRecord:
    """One start: solve with cuts (placement: round the weights, re-solve), then the dense
    robust margin and the check on the verification model. A failure is a record (STYLE).
    ``spec``: the bridge (default ``settings.bridge``); ``progress_bar``: a tqdm bar of the
    Ipopt iterations on stderr (None: when stderr is a terminal); ``variants``: bridge
    variants (BridgeSpec) of a multi-model design -- every damping constraint and check on
    every variant as well."""
    from design.pair_failure import extra_models

    t0 = time.perf_counter()
    spec, model = build_model(settings, spec=spec)
    relaxed = settings
    if settings.optimise_placement and settings.placement_cut_rounds >= 0:
        # the relaxed rounds only choose the layout: their own cut budget
        relaxed = replace(settings, cutting_plane_rounds=settings.placement_cut_rounds)
    prob = DesignProblem(relaxed, model, spec=spec)
    # multi-model with placement: the relaxed solve chooses the layout on the nominal bridge,
    # the variants join the rounded layout's K (fixed layout: 5 parameters per variant block,
    # not 5 + the flap weights; measured: variants in the relaxed solve too took the default
    # card to 3.4 min, round 0 capped infeasible, against ~1 min)
    if not settings.optimise_placement:
        prob.variants = extra_models(settings, model, spec, variants)
    bar = _progress_bar(index, progress_bar, settings.iteration_cap())
    if bar is not None:
        def tick(i, f, x):
            bar.update(1)
            bar.set_postfix_str(f"objective {f:.4g}", refresh=False)
        prob.on_iteration = tick
    theta0 = tuple(float(v) for v in theta0)
    w_cont = None
    try:
        res = prob.solve_with_cuts(np.asarray(theta0))
        rounds = list(res.rounds)
        positions = settings.positions()
        if settings.optimise_placement:
            w_cont = tuple(float(v) for v in res.solve.weights)
            rounded = round_layout(prob.symmetry, prob.z_of(w_cont), settings.flap_budget)
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
    return _start_record(settings, prob, res, rounds, positions, theta0, index, t0, w_cont,
                         spec)


def solve_fixed_layout(settings: DesignSettings, positions, theta0, spec=None, variants=(),
                       on_iteration=None):
    """K(s) re-optimised with cutting planes on the flaps at ``positions`` [m] only, from
    ``theta0`` (the rounded layout's step of :func:`run_start`; also
    :mod:`design.layout_search`). The candidates left out are not built, so the flap loop
    (and its robust margin) has no channel for them. ``variants``: multi-model bridges.
    Returns ``(problem, CutsOutcome)``; raises what the solve raises."""
    from design.pair_failure import extra_models
    from model.spec import load_bridge

    spec = load_bridge(settings.bridge if spec is None else spec)
    fixed_s = replace(settings, optimise_placement=False)
    fixed = DesignProblem(fixed_s, build_model(settings, positions=positions, spec=spec)[1],
                          spec=spec)
    fixed.on_iteration = on_iteration
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
    from design.pair_failure import pair_label

    theta = res.theta
    ver = res.verification
    rob = _margin_at(res.robust, settings.robust_speeds_m_s)
    if rob is None:
        rob = prob.robust_margin(theta)
    ver16 = (verify_layout(settings, theta, positions, spec=spec)
             if settings.verification_modes != settings.n_modes else ver)
    gain_ok = bool(ver.max_gain <= settings.gain_limit)
    # the design variants on the refined check grid (the dense check's decisions: damping
    # met, first unstable speed; the smallest damping ratio over the speeds checked)
    vchecks = [q.verify(theta, refined=True) for q in prob.variants]
    variants_ok = all(v.meets_damping for v in vchecks)
    return StartRecord(
        start=index, theta0=theta0, theta=tuple(float(v) for v in theta),
        ipopt_status=res.solve.ipopt_status, success=res.solve.success,
        iterations=sum(r.iterations for r in rounds), time_s=time.perf_counter() - t0,
        rounds=tuple(rounds), max_violation_1_s=ver.max_violation_1_s,
        stable_to_m_s=ver.stable_to_m_s, stable_everywhere=ver.stable_everywhere,
        max_gain=ver.max_gain, meets_damping=ver.meets_damping, gain_ok=gain_ok,
        # verified: every a posteriori check holds, whatever Ipopt's exit status
        verified=bool(ver.meets_damping and gain_ok and ver16.stable_everywhere
                      and variants_ok),
        gamma_T_frobenius=res.solve.gamma_T, phase_1_point=_phase_1(res),
        objective=NAN if _phase_1(res) else float(res.solve.objective),
        dense_t_peak_check_speeds=res.robust.peak if res.robust is not None else float("nan"),
        robust_bound_holds=res.robust_bound_holds, robust=rob, verification=ver16,
        robust_cuts=res.robust_cuts, gain_cuts=res.gain_cuts,
        flap_positions_m=tuple(float(x) for x in positions),
        design_speeds_m_s=res.design_speeds_m_s, weights_continuous=w_cont,
        nlp_active_speeds_m_s=nlp_active_speeds(res.solve, res.design_speeds_m_s,
                                                settings.n_eig),
        variant_checks=tuple({**pair_label(q), "meets_damping": v.meets_damping,
                              "min_damping_ratio": v.min_damping_ratio,
                              "stable_to_m_s": v.stable_to_m_s}
                             for q, v in zip(prob.variants, vchecks, strict=True)),
        design_verification=ver, nlp_objective=float(res.solve.objective))


def _phase_1(res) -> bool:
    """The cuts kept the phase-1 point (its objective is not the design's, issue 32 item 4)."""
    lab = res.rounds[res.chosen_round].placement if res.rounds else None
    return bool(lab and lab.startswith("phase 1"))


def _margin_at(rob, speeds):
    """The dense margin at ``speeds`` [m/s] taken from a check ``rob`` (RobustMargin) of the
    same design on a superset of speeds (the cutting-plane check at the design and reported
    speeds: same per-speed grid and peak polishing), or None when ``rob`` lacks a speed --
    not recomputed (issue 16 goal 3)."""
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




def _timed(fun, *args, **kw):
    """``(fun(*args, **kw), seconds)`` (a worker task of :func:`design`)."""
    t0 = time.perf_counter()
    return fun(*args, **kw), time.perf_counter() - t0


def _job(pool, fun, *args, **kw):
    """``fun(*args, **kw)`` submitted to ``pool`` (a future), or run later here (a tuple)."""
    return pool.submit(_timed, fun, *args, **kw) if pool is not None else (fun, args, kw)


def _done(job, phases, name):
    """The result of a :func:`_job`; a worker's own time is recorded as ``name (worker)``."""
    if isinstance(job, tuple):
        return job[0](*job[1], **job[2])
    value, sec = job.result()
    phases[f"{name} (worker)"] = sec
    return value


def select_start(records, gain_limit) -> tuple[StartRecord | None, str]:
    """Chosen start and design status from the per-start records of :func:`run_start`.

    ``converged``: the *verified* start (damping on the design model's dense grid, true peak
    gain ``max_gain <= gain_limit`` -- no tolerance, the NLP backs off by ``GAIN_BACKOFF`` --,
    stable on the verification model) with the lowest NLP objective (the design's own
    objective, issue 32 item 4; after them the starts without one -- a phase-1 point, NaN --
    and ties, by the larger margin), whatever its
    Ipopt exit status; ``unverified``: feasible on the design model only; ``infeasible``: no
    start meets the damping and the gain limit (the least violating is reported, never as
    converged); ``failed``: no start produced a design.
    """
    feasible = [r for r in records if r.meets_damping and r.max_gain <= gain_limit]
    verified = [r for r in feasible if r.verified]
    if verified:
        return min(verified, key=lambda r: (r.objective if np.isfinite(r.objective)
                                            else np.inf, -r.robust_margin)), "converged"
    if feasible:
        return max(feasible, key=lambda r: r.verification.stable_to_m_s), "unverified"
    cands = [r for r in records if not r.failed]
    if not cands:
        return None, "failed"
    return min(cands, key=lambda r: (max(r.max_violation_1_s, 0.0), r.max_gain)), "infeasible"


def warm_start_theta(warm_start) -> np.ndarray:
    """Coefficients (b2, b1, b0, a2, a1) of a warm start: a :class:`model.control.Controller`,
    a :class:`model.control.Compensator` or five numbers."""
    k = getattr(warm_start, "compensator", warm_start)
    if isinstance(k, Compensator):
        return np.array([k.b2, k.b1, k.b0, k.a2, k.a1], float)
    th = np.asarray(warm_start, float).ravel()
    if th.size != 5 or not np.all(np.isfinite(th)):
        from model.errors import BridgeflapInputError

        raise BridgeflapInputError("warm_start", "needs a Controller, a Compensator or five "
                                                 "finite coefficients (b2, b1, b0, a2, a1)")
    return th


@renamed
def design(settings: DesignSettings, progress=None, bridge=None, warm_start=None,
           progress_bar=None, records=None) -> DesignResult:
    """Multistart design with cutting planes, 16-mode verification and flap-count search.

    Status: ``converged`` (a start meets the damping on the design model's dense grid, the
    gain limit, and is stable on the verification model's dense grid), ``unverified`` (the
    design model is satisfied but the verification model is not stable everywhere -- only
    possible with a reduced design model), ``infeasible`` or ``failed``.

    Parameters
    ----------
    settings : DesignSettings
    progress : callable, optional
        ``str -> None``, called with one line per start and step.
    bridge : model.spec.BridgeSpec, name or bridge TOML path, optional
        The bridge (default ``settings.bridge``), e.g. a variant; every model is built on it.
    warm_start : Controller, Compensator or array_like, optional
        Start 0 from this compensator instead of :data:`NOMINAL_START` (e.g. a design of a
        neighbouring bridge); the other starts are Sobol points as usual.
    progress_bar : bool, optional
        tqdm bars of the Ipopt iterations on stderr (default: when stderr is a terminal).
    records : sequence of StartRecord, optional
        Starts already run on ``settings`` (:func:`run_start`): only the selection and the
        checks follow. ``objective = "critical_speed"`` without them runs
        :func:`design.critical_speed.critical_speed_design`, which calls this with its
        chosen inner design.
    """
    spec = None if bridge is None else load_bridge(bridge)  # a name, a file or a BridgeSpec
    if records is None and settings.objective == "critical_speed":
        from design.critical_speed import critical_speed_design

        return critical_speed_design(settings, progress=progress, spec=spec,
                                     warm_start=warm_start, progress_bar=progress_bar)
    t0, log = time.perf_counter(), progress or (lambda msg: None)
    # start 0 is a nominal phase-lead-free design (K ~ -1 static, light lag) or the warm
    # start, the others Sobol
    first = NOMINAL_START if warm_start is None else warm_start_theta(warm_start)
    base = load_bridge(settings.bridge if spec is None else spec)
    variants = sample_variants(settings, base, settings.variants, settings.variant_seed)
    given = records is not None
    starts0 = [] if given else np.vstack(
        [first, screened_starts(settings, settings.starts - 1, spec=spec)])[:settings.starts]
    n = len(starts0)
    phases, tp = {}, [time.perf_counter()]

    def mark(name):
        now = time.perf_counter()
        phases[name] = phases.get(name, 0.0) + now - tp[0]
        tp[0] = now

    mark("screening starts")
    if not given:  # minutes of Ipopt before the next line: say what runs (issue 29 item 5)
        log(f"{n} start(s), each at most {settings.iteration_cap()} Ipopt iterations ...")
    if given:
        records = list(records)
    elif settings.parallel and settings.starts > 1:
        from model.workers import process_pool

        with process_pool(min(2, settings.starts)) as ex:
            records = list(ex.map(run_start, [settings] * n, starts0, range(n), [spec] * n,
                                  [progress_bar] * n, [variants] * n))
    else:
        records = [run_start(settings, th, i, spec, progress_bar, variants)
                   for i, th in enumerate(starts0)]
    for r in records:
        log(f"start {r.start}: {r.ipopt_status} in {r.time_s:.1f} s, "
            f"{r.iterations} iterations, {r.cut_rounds} cut rounds, "
            f"violation {r.max_violation_1_s:.2e}, max gain {r.max_gain:.4g}, margin "
            f"{r.robust_margin:.3g} (gamma_T {r.gamma_T_frobenius:.3g}), "
            f"{settings.verification_modes}-mode check stable: "
            f"{r.verification.stable_everywhere if r.verification else None}, verified: "
            f"{r.verified}")
    mark("starts (Ipopt, cuts, verification)")
    best, status = select_start(records, settings.gain_limit)
    extras, controller = {}, None
    if settings.layout_neighbours:  # issue 32 item 5 (design.layout_search)
        from design.layout_search import design_step

        best, status, extras["layout_neighbours"] = design_step(settings, best, status, spec,
                                                                variants, log)
        mark("layout neighbours (K re-optimised)")
    absc_u = settings.check_speeds()
    absc = np.full(absc_u.shape, np.nan)
    min_flaps = None
    if best is not None:
        theta = np.asarray(best.theta)
        positions = np.asarray(best.flap_positions_m)
        from model.controller_file import plant_record

        controller = Controller(Compensator(*(float(v) for v in theta)),
                                tuple(float(x) for x in positions),
                                settings.flap_width_m, settings.leading_edge,
                                settings.trailing_edge, settings.gain_limit,
                                flap_chord_m=settings.flap_chord_m,
                                plant=plant_record(settings.bridge, settings.n_modes, spec))
        ok = status in ("converged", "unverified")
        # issue 16 goal 3: the closed-loop limits, the buffeting comparison and the fresh
        # variants (two halves) run in two worker processes while this one checks the chosen
        # design; the flap counts follow them in the same workers (phase times: each task's
        # own time, marked "worker")
        pool = None
        if settings.parallel:
            from model.workers import process_pool

            pool = process_pool(2)
        try:
            lim_job = _job(pool, closed_loop_limits, settings, controller, spec=spec)
            grid_job = _job(pool, margin_on_speed_grid, settings, controller, spec=spec,
                            gamma_T=best.gamma_T_frobenius)
            buf_job = _job(pool, buffeting_comparison, settings, controller, spec=spec) if ok \
                else None
            fresh_jobs = []         # the fresh variants in two halves, in the workers too
            if ok and settings.fresh_variants > 0:
                fresh = sample_variants(settings, base, settings.fresh_variants,
                                        settings.variant_seed + 1000)
                h = (len(fresh) + 1) // 2
                fresh_jobs = [_job(pool, fresh_variant_rows, settings, controller, part)
                              for part in (fresh[:h], fresh[h:]) if part]
            _, model = build_model(settings, n_modes=settings.verification_modes,
                                   positions=positions, spec=spec)
            ver_best = best.verification      # run_start's check on this model: not recomputed
            absc = ver_best.abscissa_1_s
            extras["damping_ratio"] = ver_best.damping_ratio
            _, model_ol = build_model(settings, n_modes=settings.verification_modes, spec=spec)
            ol_parts = DesignProblem(settings, model_ol, numeric=True).A_parts(
                np.array([0.0, 0.0, 0.0, 1.0, 1.0]))
            extras["open_loop_abscissa"] = closed_loop_abscissa(ol_parts, absc_u)
            extras["closed_loop"] = model.system(Compensator(*(float(v) for v in theta)))
            ver_d = best.design_verification
            if ver_d is None:
                _, model_d = build_model(settings, positions=positions, spec=spec)
                ver_d = DesignProblem(replace(settings, optimise_placement=False),
                                      model_d, numeric=True).verify(theta)
            extras["active_constraints"] = active_constraints(settings, best, ver_d)
            mark("chosen design checks")
            if ok and not settings.optimise_placement:
                # (a placed layout is its own flap-count answer: the same-K check of evenly
                # spaced counts does not apply to it)
                # the chosen start's check of its full evenly spaced layout is count flap_count
                full = (not settings.optimise_placement
                        and len(positions) == settings.flap_count
                        and np.allclose(positions, settings.positions()))
                min_flaps = minimum_flap_count(
                    settings, theta, spec=spec, pool=pool,
                    known={settings.flap_count: ver_best} if full else None)
                log(f"minimum flap count (same K): {min_flaps.minimum}")
                mark("flap-count check (same K)")
            try:
                lim = _done(lim_job, phases, "closed-loop limits")
                log(limits_text(lim))
            except Exception as exc:  # noqa: BLE001 - a report item, not the design
                lim = {"status": f"failed: {exc}"}
            extras["closed_loop_limits"] = lim
            try:
                extras["robust_margin_speed_grid"] = _done(grid_job, phases, "margin grid")
            except Exception as exc:  # noqa: BLE001 - the headline falls back, said so
                extras["robust_margin_speed_grid"] = {"status": f"failed: {exc}"}
            mark("closed-loop limits" + (" (wait)" if pool else ""))
            if fresh_jobs:
                rows = [r for k, j in enumerate(fresh_jobs)
                        for r in _done(j, phases, f"fresh-variant check {k}")]
                extras["fresh_variants"] = fresh_variant_summary(settings, rows)
                extras["fresh_variants"]["design_variants"] = len(variants)
                log(f"fresh variants: {extras['fresh_variants']['fraction_stable']:.2f} "
                    f"stable 0..{settings.speed_max_m_s} m/s")
                mark("fresh-variant check" + (" (wait)" if pool else ""))
            if ok and settings.pareto:
                extras["pareto"] = flap_count_pareto(settings, theta, spec=spec, log=log)
                mark("flap-count Pareto (K re-optimised)")
            if ok:
                try:
                    extras["buffeting"] = _done(buf_job, phases, "buffeting comparison")
                except Exception as exc:  # noqa: BLE001 - a report item, not the design
                    extras["buffeting"] = BuffetingComparison(status=f"failed: {exc}")
                mark("buffeting comparison" + (" (wait)" if pool else ""))
        finally:
            if pool is not None:
                pool.shutdown(cancel_futures=True)
    extras["phase_times_s"] = phases
    usable = controller if status == "converged" else None
    return DesignResult(status=status, settings=settings, controller=usable,
                        candidate=controller,
                        starts=tuple(records), best=best, abscissa_speeds_m_s=absc_u,
                        abscissa_1_s=absc, min_flaps=min_flaps,
                        wall_time_s=time.perf_counter() - t0, extras=extras)


