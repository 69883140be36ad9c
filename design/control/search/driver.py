"""Multistart driver of the compensator design: starts, per-start runs, selection, checks.

:func:`design` runs one :class:`bridgeflap.design.control.formulation.nlp.DesignProblem` per start
(a nominal start and screened Sobol points, optionally in processes), selects one
(:func:`select_start`), checks it on the verification model, searches the minimum flap count and
compares buffeting.

Verification. Every solution is checked a posteriori on the dense ``check_step_m_s`` grid
(cutting planes: violating speeds join the design grid and the problem is re-solved) and, when
the design model is reduced, on the ``verification_modes`` model that ``bridgeflap flutter``
uses (:data:`bridgeflap.model.analysis.DEFAULT_MODES`); the result reports both honestly.

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

Parallel starts use a process pool (:func:`bridgeflap.model.workers.process_pool`), not the Dask
cluster of the DOE (:mod:`bridgeflap.design.batch.cluster`). A design runs two to four long tasks
once, inside one call, on the local machine: the executor starts in 0.16 s, while a Dask
``LocalCluster`` of two workers took 10.0 s to start and 2.3 s to close on the loaded
2-core machine (load 11), a fifth of the 60 s budget, and would import dask/distributed on a
command that otherwise does not. Dask's retries, time limits and remote
schedulers serve batches of many short cases; a failed start here is already a record.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from bridgeflap.design.control.formulation.nlp import DesignProblem
from bridgeflap.design.control.formulation.plant import closed_loop_abscissa
from bridgeflap.design.control.formulation.problem_model import (  # noqa: F401 - re-exported (tests, API)
    NOMINAL_START,
    build_model,
    verify_layout,
    warm_start_theta,
)
from bridgeflap.design.control.results.records import (
    BuffetingComparison,
)
from bridgeflap.design.control.results.result import DesignResult
from bridgeflap.design.control.review.checks import (  # noqa: F401 - re-exported (tests, API)
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

# re-exported
from bridgeflap.design.control.review.flap_count import MISSES_TO_STOP, minimum_flap_count  # noqa: F401
from bridgeflap.design.control.settings import DesignSettings
from bridgeflap.design.control.solve.scenarios import scenario_specs
from bridgeflap.design.control.solve.start import (  # noqa: F401 - re-exported (tests, API)
    SCREEN_FACTOR,
    _progress_bar,
    layout_record,
    round_layout,
    run_start,
    screened_starts,
    select_start,
    sobol_starts,
    solve_fixed_layout,
)
from bridgeflap.design.io.api_args import check_design_args
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.progress import Eta
from bridgeflap.model.structure.loader import load_bridge
from bridgeflap.model.vocabulary import renamed

NAN = float("nan")
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


def open_loop_abscissa(settings: DesignSettings, spec, speeds) -> np.ndarray:
    """The spectral abscissa [1/s] of the open loop (``K = 0``) on the verification model at
    ``speeds`` [m/s] (a job of :func:`design`: it does not depend on K)."""
    _, model_ol = build_model(settings, n_modes=settings.verification_modes, spec=spec)
    ol_parts = DesignProblem(settings, model_ol, numeric=True).A_parts(
        np.array([0.0, 0.0, 0.0, 1.0, 1.0]))
    return closed_loop_abscissa(ol_parts, np.asarray(speeds, float))


def _early_jobs(settings, given, variants, spec):
    """``(pool, open-loop abscissa job)`` of :func:`design`: with ``settings.parallel`` a pool of
    two workers, which computes the scenarios' open-loop limits in two halves (adopted into this
    process's cache before the starts need them; a worker's failure leaves them to this process)
    and then the open-loop abscissa; ``(None, None)`` otherwise or when the starts are given."""
    if not settings.parallel or given:
        return None, None
    from bridgeflap.design.control.solve.scenarios import adopt_limits, open_loop_limits
    from bridgeflap.model.workers import process_pool

    pool = process_pool(2)
    try:
        parts = []
        if variants and settings.variant_rule == "no_harm":
            h = (len(variants) + 1) // 2
            parts = [pool.submit(open_loop_limits, settings, part)
                     for part in (variants[:h], variants[h:]) if part]
        ol_job = _job(pool, open_loop_abscissa, settings, spec, settings.check_speeds())
        for f in parts:
            try:
                adopt_limits(f.result())
            except Exception:  # noqa: BLE001 - computed here instead (scenario_settings)
                pass
    except BaseException:
        pool.shutdown(cancel_futures=True)
        raise
    return pool, ol_job


def _run_starts(settings, records, starts0, spec, progress_bar, variants, progress, finished):
    """The start records of :func:`design`: ``records`` when given, else every start of
    ``starts0`` run (in two processes with ``settings.parallel`` and several starts)."""
    n = len(starts0)
    if records is not None:
        return list(records)
    if settings.parallel and settings.starts > 1:
        from bridgeflap.model.workers import process_pool

        records = []
        with process_pool(min(2, settings.starts)) as ex:
            for r in ex.map(run_start, [settings] * n, starts0, range(n), [spec] * n,
                            [progress_bar] * n, [variants] * n):
                records.append(r)
                finished(r, len(records))
    else:
        records = []
        for i, th in enumerate(starts0):
            records.append(run_start(settings, th, i, spec, progress_bar, variants,
                                     say=progress))
            finished(records[-1], len(records))
    return records


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
    bridge : bridgeflap.model.structure.spec.BridgeSpec, name or bridge TOML path, optional
        The bridge (default ``settings.bridge``), e.g. a variant; every model is built on it.
    warm_start : Controller, Compensator or array_like, optional
        Start 0 from this compensator instead of :data:`NOMINAL_START` (e.g. a design of a
        neighbouring bridge); the other starts are Sobol points as usual.
    progress_bar : bool, optional
        tqdm bars of the Ipopt iterations on stderr (default: when stderr is a terminal).
    records : sequence of StartRecord, optional
        Starts already run on ``settings`` (:func:`run_start`): only the selection and the
        checks follow. ``objective = "critical_speed"`` without them runs
        :func:`bridgeflap.design.control.search.critical_speed.critical_speed_design`, which calls
        this with its chosen inner design.
    """
    check_design_args(settings, progress, bridge, warm_start, progress_bar, records)
    spec = None if bridge is None else load_bridge(bridge)  # a name, a file or a BridgeSpec
    if records is None and settings.objective == "critical_speed":
        from bridgeflap.design.control.search.critical_speed import critical_speed_design

        # this function is the search's inner design (passed in: no import back)
        return critical_speed_design(settings, progress=progress, spec=spec,
                                     warm_start=warm_start, progress_bar=progress_bar,
                                     design=design)
    t0, log = time.perf_counter(), progress or (lambda msg: None)
    # start 0 is a nominal phase-lead-free design (K ~ -1 static, light lag) or the warm
    # start, the others Sobol
    first = NOMINAL_START if warm_start is None else warm_start_theta(warm_start)
    base = load_bridge(settings.bridge if spec is None else spec)
    variants = scenario_specs(settings, base)  # corners, then Sobol draws
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
    # the work that does not depend on K runs in two worker processes while this one designs:
    # the scenarios' open-loop limits (needed first: waited for below) and the open-loop
    # abscissa of the check; the same pool then takes the chosen design's checks
    pool, ol_job = _early_jobs(settings, given, variants, spec)
    if pool is not None:
        mark("scenario open-loop limits (wait)")
    if not given:  # minutes of Ipopt before the next line: say what runs
        log(f"{n} start(s), each at most {settings.iteration_cap()} Ipopt iterations ...")
    eta = Eta(n)

    def finished(r, k):  # one line per start (the k-th), with the time left at the rate so far
        log(f"start {r.start} finished ({k}/{n}): {r.ipopt_status} {eta.text(k)}")

    try:
        records = _run_starts(settings, records, starts0, spec, progress_bar, variants,
                              progress, finished)
    except BaseException:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
        raise
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
    if settings.layout_neighbours:  # design.control.search.layout_search
        from bridgeflap.design.control.search.layout_search import design_step

        best, status, extras["layout_neighbours"] = design_step(settings, best, status, spec,
                                                                variants, log)
        mark("layout neighbours (K re-optimised)")
    absc_u = settings.check_speeds()
    absc = np.full(absc_u.shape, np.nan)
    min_flaps = None
    if best is not None:
        theta = np.asarray(best.theta)
        positions = np.asarray(best.flap_positions_m)
        from bridgeflap.model.aeroelastic.controller_file import plant_record

        controller = Controller(Compensator(*(float(v) for v in theta)),
                                tuple(float(x) for x in positions),
                                settings.flap_width_m, settings.leading_edge,
                                settings.trailing_edge, settings.gain_limit,
                                flap_chord_m=settings.flap_chord_m,
                                plant=plant_record(settings.bridge, settings.n_modes, spec))
        ok = status in ("converged", "unverified")
        # the closed-loop limits, the buffeting comparison and the fresh
        # variants (two halves) run in two worker processes while this one checks the chosen
        # design; the flap counts follow them in the same workers (phase times: each task's
        # own time, marked "worker")
        if pool is None and settings.parallel:
            from bridgeflap.model.workers import process_pool

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
            extras["open_loop_abscissa"] = (
                _done(ol_job, phases, "open-loop abscissa") if ol_job is not None
                else open_loop_abscissa(settings, spec, absc_u))
            extras["closed_loop"] = model.system(Compensator(*(float(v) for v in theta)))
            ver_d = best.design_verification
            if ver_d is None:
                _, model_d = build_model(settings, positions=positions, spec=spec)
                ver_d = DesignProblem(replace(settings, optimise_placement=False),
                                      model_d, numeric=True).verify(theta)
            extras["active_constraints"] = active_constraints(settings, best, ver_d)
            mark("chosen design checks")
            # the chosen start's check of its full evenly spaced layout is count flap_count
            even = settings.positions(settings.flap_count)
            full = (len(positions) == len(even) and np.allclose(np.sort(positions), even))
            if ok and not full:
                # a placed layout (the card's flap_positions_m, or a placement's) is its own
                # flap-count answer: the same-K check of evenly spaced counts asks about
                # another layout family, and with K designed for this one (and no actuator
                # limit) its count says nothing about how few strips would do
                extras["minimum_flaps_note"] = (
                    "not searched: the layout is placed (not the evenly spaced candidates); "
                    "the fewest strips with K re-optimised per layout and the actuator limits: "
                    "bridgeflap placement")
            elif ok and not settings.optimise_placement:
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
    elif pool is not None:          # no design to check: the early pool's work is not needed
        pool.shutdown(cancel_futures=True)
    extras["phase_times_s"] = phases
    usable = controller if status == "converged" else None
    return DesignResult(status=status, settings=settings, controller=usable,
                        candidate=controller,
                        starts=tuple(records), best=best, abscissa_speeds_m_s=absc_u,
                        abscissa_1_s=absc, min_flaps=min_flaps,
                        wall_time_s=time.perf_counter() - t0, extras=extras)


