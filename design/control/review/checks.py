"""Checks and reports around a compensator design
(:func:`bridgeflap.design.control.search.driver.design`).

Closed-loop flutter/divergence limits and mechanism, the constraints active at the optimum,
the flap-count Pareto with K re-optimised per count, and the multi-model variants (sampling
and the a posteriori check on fresh variants). Split from
:mod:`bridgeflap.design.control.search.driver` (one job per file); the driver re-exports these
names.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from bridgeflap.design.control.formulation.nlp import DesignProblem
from bridgeflap.design.control.results.records import BuffetingComparison, ParetoPoint
from bridgeflap.design.control.settings import DesignSettings
from bridgeflap.model.aeroelastic.control import Controller

NAN = float("nan")


def _driver():
    """The design problem's model and checks
    (:mod:`bridgeflap.design.control.formulation.problem_model`; imported on use: it loads the
    NLP)."""
    import bridgeflap.design.control.formulation.problem_model as problem_model

    return problem_model


def flap_count_pareto(settings: DesignSettings, theta0, counts=None, spec=None,
                      log=None) -> dict:
    """Flap count against robust margin and stable speed, K(s) re-optimised for every count.

    Counts from ``flap_count`` down (``counts`` overrides; default every count
    ``pareto_step`` apart down to 1), each the evenly spaced symmetric layout
    :meth:`DesignSettings.positions`; each is designed by
    :meth:`bridgeflap.design.control.formulation.nlp.DesignProblem.solve_with_cuts` warm-started
    from the previous count's K (the first from ``theta0``) and verified like a design (damping and
    gain on the design model, stability on the verification model). The search stops after two
    consecutive counts that do not verify (fewer flaps have less authority). Returns ``{"points":
    [...], "minimum_verified": count or None}``.
    """
    log = log or (lambda msg: None)
    if counts is None:
        counts = list(range(settings.flap_count, 0, -max(1, settings.pareto_step)))
    pts, theta, fails = [], np.asarray(theta0, float), 0
    for c in counts:
        t0 = time.perf_counter()
        pos = settings.positions(c)
        _, model = _driver().build_model(settings, positions=pos, spec=spec)
        prob = DesignProblem(replace(settings, optimise_placement=False), model, spec=spec)
        try:
            res = prob.solve_with_cuts(theta)
        except Exception as exc:  # noqa: BLE001 - a failed count is a point (STYLE)
            pts.append(ParetoPoint(c, f"failed: {exc}", False, NAN, NAN, NAN, NAN, 0,
                                   time.perf_counter() - t0, tuple(theta)))
            fails += 1
            if fails >= 2:
                break
            continue
        th = res.theta
        ver = res.verification
        ver16 = (_driver().verify_layout(settings, th, pos, spec=spec)
                 if settings.verification_modes != settings.n_modes else ver)
        ok = bool(ver.meets_damping and ver.max_gain <= settings.gain_limit
                  and ver16.stable_everywhere)
        rob = prob.robust_margin(th)
        pts.append(ParetoPoint(
            flap_count=int(c), ipopt_status=res.solve.ipopt_status, verified=ok,
            robust_margin=rob.margin, max_gain=ver.max_gain,
            min_damping_ratio=ver.min_damping_ratio, stable_to_m_s=ver16.stable_to_m_s,
            iterations=sum(r.iterations for r in res.rounds),
            time_s=time.perf_counter() - t0, theta=tuple(float(v) for v in th)))
        log(f"pareto: {c} flaps {'verified' if ok else 'not verified'}, margin "
            f"{rob.margin:.3g}, stable to {ver16.stable_to_m_s} m/s")
        if ok:
            theta, fails = th, 0
        else:
            fails += 1
            if fails >= 2:
                break
    good = [p.flap_count for p in pts if p.verified]
    return {"points": [p.to_dict() for p in pts],
            "minimum_verified": min(good) if good else None,
            "criterion": "K(s) re-optimised per count; verified = damping >= zeta_min and "
                         "gain <= gain_limit on the design model, stable on the "
                         "verification model (dense grids)"}


#: Closed-loop limits are searched on 0 .. LIMIT_SPEED_FACTOR * speed_max_m_s (step
#: ``LIMIT_STEP_M_S``; crossings refined by Brent's method in :func:`model.stability.sweeps.sweep`).
LIMIT_SPEED_FACTOR = 2.0
LIMIT_STEP_M_S = 0.5
#: A damping constraint counts as active when the smallest damping ratio of the movable
#: branches is within this relative distance of ``zeta_min`` (Ipopt's constr_viol_tol 1e-6
#: and tol 1e-6 on the x100-scaled constraint put an active one at ~1e-8 1/s, i.e. ~1e-6
#: relative for |lambda| ~ 1 rad/s; 1 % also names the nearly active speeds an engineer
#: would call binding).
ACTIVE_REL_TOL = 0.01


def closed_loop_limits(settings: DesignSettings, controller: Controller, spec=None) -> dict:
    """Closed-loop flutter and divergence speeds and mechanisms on the verification model.

    ``bridgeflap.model.analysis.closed_loop_flutter`` on 0 .. ``LIMIT_SPEED_FACTOR * speed_max_m_s``
    (the one stability sweep of the package) with the open-loop limits for reference; the
    critical speed is the lower converged limit (``bridgeflap.model.analysis.critical_speed``), the
    static divergence check ``det(K - U^2 P G0(K(0)))`` included.
    """
    from bridgeflap.model.analysis import closed_loop_flutter
    from bridgeflap.model.structure.loader import load_bridge

    spec = load_bridge(settings.bridge if spec is None else spec)
    U = np.arange(0.0, LIMIT_SPEED_FACTOR * settings.speed_max_m_s + 1e-9, LIMIT_STEP_M_S)
    # the fast path (coarse tracked sweep, Newton on the critical eigenpairs, dense fallback
    # when unsure; the flutter command's default): on the default design (30 modes) 96.99256
    # m/s against the dense sweep's 96.99250, in 1.4-2.5x less time (tests/test_design.py)
    r = closed_loop_flutter(spec, controller, U, n_modes=settings.verification_modes,
                            flap_chord_m=settings.flap_chord_m, sweep_method="fast").summary()
    keys = ("flutter_speed_m_s", "flutter_frequency_hz", "flutter_status",
            "divergence_speed_m_s", "divergence_status", "divergence_static_speed_m_s",
            "critical_speed_m_s", "critical_mechanism", "critical_participation",
            "flutter_participation",
            "open_loop_flutter_speed_m_s", "open_loop_divergence_speed_m_s",
            "divergence_static_verified_status", "divergence_static_verified_reason",
            "divergence_static_verified_direction",
            "divergence_static_verified_is_stability_limit")
    out = {k: r.get(k) for k in keys if k in r}
    crit, stat = r.get("critical_speed_m_s"), r.get("divergence_static_speed_m_s")
    crit = float("nan") if crit is None else float(crit)
    stat = float("nan") if stat is None else float(stat)
    # the sweep's divergence can fail to bracket a root that the static check finds (a real
    # root that grazes zero): the lower of the two governs
    if np.isfinite(stat) and not (np.isfinite(crit) and crit <= stat):
        out["governing_speed_m_s"], out["governing_mechanism"] = stat, "divergence (static)"
    else:
        out["governing_speed_m_s"] = crit
        out["governing_mechanism"] = r.get("critical_mechanism")
    out["searched_to_m_s"] = float(U[-1])
    out["modes"] = settings.verification_modes
    return out


#: A damping constraint of the NLP is active at its solution when within this [1/s] of 0
#: (the constraint enters scaled by EIG_SCALE = 100; Ipopt's tol 1e-6 on the scaled
#: complementarity leaves an active one at ~1e-8 1/s; 1e-5 1/s is 0.2 % of zeta_min |lambda|
#: at the flutter frequency ~1 rad/s).
ACTIVE_ABS_TOL_1_S = 1e-5


def nlp_active_speeds(solve, speeds, n_eig) -> tuple:
    """Design speeds [m/s] where a damping constraint of the NLP solution is active."""
    g = np.asarray(solve.constraints_eig_1_s, float).reshape(-1, n_eig)
    sp = np.asarray(sorted(speeds), float)
    if g.shape[0] != sp.size:
        return ()
    return tuple(float(u) for u, row in zip(sp, g, strict=True)
                 if np.max(row) >= -ACTIVE_ABS_TOL_1_S)


def active_constraints(settings: DesignSettings, start, ver) -> dict:
    """Which constraints bind at the chosen design (``ver``: its dense design-model check).

    ``damping_speeds_m_s``: check-grid speeds where the smallest damping ratio of the movable
    branches is within ``ACTIVE_REL_TOL`` of ``zeta_min``; ``gain_limit``: the true peak gain
    within that of the limit; ``coefficient_bounds``: theta entries at their box bounds;
    ``objective_bound``: the robust epigraph ``gamma_T`` (the objective) is the bound that
    stops the optimiser when nothing else is active.
    """
    s = settings
    z = np.asarray(ver.damping_ratio)
    U = np.asarray(ver.speeds_m_s)
    damp = U[z <= s.zeta_min * (1.0 + ACTIVE_REL_TOL)]
    gain = bool(start.max_gain >= s.gain_limit * (1.0 - ACTIVE_REL_TOL))
    th = np.asarray(start.theta)
    lo = [-s.b_bound] * 3 + [s.a2_bounds[0], s.a1_bounds[0]]
    hi = [s.b_bound] * 3 + [s.a2_bounds[1], s.a1_bounds[1]]
    names = ("b2", "b1", "b0", "a2", "a1")
    bounds = [f"{n} {'lower' if abs(v - a) <= 1e-6 * max(1.0, abs(a)) else 'upper'}"
              for n, v, a, b in zip(names, th, lo, hi, strict=True)
              if abs(v - a) <= 1e-6 * max(1.0, abs(a)) or abs(v - b) <= 1e-6 * max(1.0, abs(b))]
    nlp = list(getattr(start, "nlp_active_speeds_m_s", ()))
    any_active = bool(damp.size or gain or bounds or nlp)
    return {"damping_speeds_m_s": [float(u) for u in damp],
            "nlp_active_damping_speeds_m_s": nlp,
            "min_damping_ratio": float(np.min(z)),
            "min_damping_speed_m_s": float(U[int(np.argmin(z))]),
            "gain_limit": gain, "coefficient_bounds": bounds,
            "objective_bound": ("robust epigraph gamma_T (the objective: max margin)"
                                if s.weight_robust > 0 else "regularisation"),
            "stability_or_gain_active": any_active,
            "active_tolerance_relative": ACTIVE_REL_TOL}


def sample_variants(settings: DesignSettings, spec, count: int, seed: int) -> list:
    """``count`` bridge variants of ``spec``: a scrambled Sobol' sample of the estimated-input
    ranges of the global sensitivity study
    (:data:`bridgeflap.design.control.uncertainty.DEFAULT_UNCERTAIN_RANGES`)
    without the ``variant_fixed`` parameters (held at ``spec``'s values)."""
    from bridgeflap.design.batch.designs import sobol
    from bridgeflap.design.control.uncertainty import DEFAULT_UNCERTAIN_RANGES

    if count <= 0:
        return []
    ranges = {k: v for k, v in DEFAULT_UNCERTAIN_RANGES.items()
              if k not in settings.variant_fixed}
    return [spec.replace(**{k: v for k, v in case.items() if k in ranges})
            for case in sobol(ranges, int(count), int(seed))]


def fresh_variant_check(settings: DesignSettings, controller: Controller, specs) -> dict:
    """A posteriori check of a design on fresh variants (not in the design set) on the finer
    ``fresh_variant_modes`` model: the fraction stable 0..speed_max and meeting ``zeta_min``.
    On the refined subset of the check grid
    (:func:`bridgeflap.design.control.formulation.plant.damping_check_refined`: the dense check's
    decisions at ~1/5 of its eigenvalues; ``min_damping_ratio`` is the smallest over the speeds
    checked)."""
    return fresh_variant_summary(settings, fresh_variant_rows(settings, controller, specs))


def fresh_variant_rows(settings: DesignSettings, controller: Controller, specs) -> list:
    """The per-variant rows of :func:`fresh_variant_check` (a chunk of them can run in a
    worker process: :func:`bridgeflap.design.control.search.driver.design` splits them over its
    pool)."""
    rows = []
    th = _driver().warm_start_theta(controller)
    for v in specs:
        ver = _driver().verify_layout(settings, th, controller.flap_strip_positions_m,
                                      n_modes=settings.fresh_variant_modes, spec=v,
                                      refined=True)
        rows.append({"stable_everywhere": ver.stable_everywhere,
                     "stable_to_m_s": ver.stable_to_m_s, "meets_damping": ver.meets_damping,
                     "min_damping_ratio": ver.min_damping_ratio})
    return rows


def fresh_variant_summary(settings: DesignSettings, rows) -> dict:
    """:func:`fresh_variant_check`'s result from its rows."""
    n = max(len(rows), 1)
    return {"count": len(rows), "modes": settings.fresh_variant_modes,
            "fraction_stable": sum(r["stable_everywhere"] for r in rows) / n,
            "fraction_meeting_damping": sum(r["meets_damping"] for r in rows) / n,
            "variants": rows}


#: spacing [m/s] of the speed grid on which the reported robust margin is re-checked; the worst
#: grid speed is then refined by a bounded scalar search to :data:`MARGIN_SPEED_XTOL_M_S`
MARGIN_GRID_STEP_M_S = 0.5
MARGIN_SPEED_XTOL_M_S = 0.01


def margin_on_speed_grid(settings: DesignSettings, controller: Controller, spec=None,
                         gamma_T=None) -> dict:
    """The small-gain margin over the whole speed range, not only at
    ``robust_speeds_m_s``: ``1 / max sigma_max(T)`` every :data:`MARGIN_GRID_STEP_M_S` from
    that step to ``speed_max_m_s`` (and at the robust speeds), the worst grid speed refined by
    a bounded scalar search over its two neighbouring intervals, on the design model of the
    built layout. This is the reported margin (``robust_margin``), with the speed where it
    occurs; ``margin_at_robust_speeds`` is the margin the optimiser's cuts check,
    ``margin_verification_model`` the margin at the worst speed on the verification model
    (``verification_modes``), and ``optimiser_bound_holds`` whether the optimiser's epigraph
    bound ``gamma_T`` (when given) covers the whole range within ``robust_cut_tol``:
    ``max sigma_max(T) <= gamma_T (1 + robust_cut_tol)``."""
    from scipy.optimize import minimize_scalar

    theta = np.asarray(_driver().warm_start_theta(controller), float)
    positions = np.asarray(controller.flap_strip_positions_m)
    _, model = _driver().build_model(settings, positions=positions, spec=spec)
    prob = DesignProblem(replace(settings, optimise_placement=False), model, numeric=True)
    step, hi = MARGIN_GRID_STEP_M_S, float(settings.speed_max_m_s)
    grid = np.unique(np.concatenate([np.arange(step, hi + 1e-9, step),
                                     np.asarray(settings.robust_speeds_m_s, float)]))
    dense = prob.robust_margin(theta, speeds=grid)
    at = prob.robust_margin(theta)
    i = int(np.argmax(dense.t_inf))
    u_grid, t_grid = float(grid[i]), float(dense.t_inf[i])
    lo_u, hi_u = float(grid[max(i - 1, 0)]), float(grid[min(i + 1, grid.size - 1)])
    u_worst, t_worst = u_grid, t_grid
    if hi_u > lo_u:
        opt = minimize_scalar(lambda u: -prob.robust_margin(theta, speeds=[u]).peak,
                              bounds=(lo_u, hi_u), method="bounded",
                              options={"xatol": MARGIN_SPEED_XTOL_M_S})
        if -opt.fun > t_grid:
            u_worst, t_worst = float(opt.x), float(-opt.fun)
    _, model_v = _driver().build_model(settings, n_modes=settings.verification_modes,
                                       positions=positions, spec=spec)
    prob_v = DesignProblem(replace(settings, optimise_placement=False), model_v, numeric=True)
    t_v = prob_v.robust_margin(theta, speeds=[u_worst]).peak
    tol = settings.robust_cut_tol
    out = {"speeds_m_s": f"{step:g}:{hi:g}:{step:g}", "speed_count": int(grid.size),
           "margin": 1.0 / t_worst, "worst_speed_m_s": u_worst,
           "margin_grid_points_only": 1.0 / t_grid, "worst_grid_speed_m_s": u_grid,
           "margin_at_robust_speeds": float(at.margin),
           "margin_verification_model": 1.0 / float(t_v),
           "verification_modes": int(settings.verification_modes),
           "reported_margin_holds": bool(1.0 / t_worst >= at.margin * (1.0 - tol))}
    if gamma_T is not None and np.isfinite(gamma_T) and gamma_T > 0:
        out["optimiser_gamma_T"] = float(gamma_T)
        out["optimiser_bound_holds"] = bool(t_worst <= gamma_T * (1.0 + tol))
    return out


def limits_text(lim) -> str:
    """One log line of :func:`closed_loop_limits` (a limit not found within the searched
    range as such, never "nan m/s")."""
    from bridgeflap.design.io.text import speed_text

    def sp(k):
        status = lim.get(k.replace("_speed_m_s", "_status"), "no_crossing_in_range")
        return speed_text(lim.get(k), none=(
            f"none below {lim.get('searched_to_m_s', 0):g} m/s"
            if status in (None, "no_crossing_in_range") else "not determined"))
    return (f"closed loop: flutter {sp('flutter_speed_m_s')} ({lim.get('flutter_status')}), "
            f"divergence {sp('divergence_speed_m_s')} ({lim.get('divergence_status')}; static "
            f"{sp('divergence_static_speed_m_s')}), governing {sp('governing_speed_m_s')} "
            f"{lim.get('governing_mechanism') or ''}").rstrip()


def buffeting_comparison(settings: DesignSettings, controller: Controller, speeds=None,
                         spec=None) -> BuffetingComparison:
    """Open- vs closed-loop max RMS response (``bridgeflap.model.response.buffeting``, verification
    model) at ``speeds`` [m/s] (default ``buffeting_speeds_m_s``) on ``spec`` (default the built-in
    ``settings.bridge``)."""
    from bridgeflap.model.response.buffeting import buffeting
    from bridgeflap.model.structure.loader import load_bridge

    spec = load_bridge(settings.bridge if spec is None else spec)
    speeds = np.asarray(settings.buffeting_speeds_m_s if speeds is None else speeds, float)
    nm = settings.verification_modes
    ol = buffeting(spec, speeds, n_modes=nm)
    cl = buffeting(spec, speeds, n_modes=nm, controller=controller)
    return BuffetingComparison(
        status="ok", speeds_m_s=tuple(speeds.tolist()), modes=nm,
        open_loop_rms_vertical_m=tuple(ol.rms_vertical.tolist()),
        closed_loop_rms_vertical_m=tuple(cl.rms_vertical.tolist()),
        open_loop_rms_torsion_rad=tuple(ol.rms_torsion.tolist()),
        closed_loop_rms_torsion_rad=tuple(cl.rms_torsion.tolist()))
