"""Fast paths of the compensator design against the reference paths."""

import casadi as ca
import numpy as np
import pytest
import scipy.linalg

from bridgeflap.design.control.formulation.eigen import inverse_iteration
from bridgeflap.design.control.formulation.nlp import DesignProblem
from bridgeflap.design.control.search.driver import build_model
from bridgeflap.design.control.settings import load_settings

THETA = np.array([0.3, 0.25, -1.5, 0.08, 0.5])


@pytest.fixture(scope="module")
def small():
    s = load_settings(None, n_modes=6, flap_count=5, robust_design_speeds_m_s=(30.0, 60.0),
                      n_robust_omega=8)
    return s, build_model(s)[1]


@pytest.fixture(scope="module")
def small_box_fresh():
    # humber:box, 6 modes, 5 flap pairs; fresh variants checked on 6 modes, 1 m/s grid
    return load_settings(None, bridge="humber:box", n_modes=6, verification_modes=6, flap_count=5,
                         fresh_variant_modes=6, check_step_m_s=1.0)


def test_analytic_robust_constraint_equals_the_exact_solve(small):
    # ||T||_F^2 as a closed-form expression of K(jw) (eigendecomposition of N = X W Pa per
    # point, once) against the real 2n solve, values and theta-Jacobian, cuts included.
    # Same algebra in another order: round-off only (cond(V) < 1e4 here), so 1e-9 relative.
    s, model = small
    prob = DesignProblem(s, model)
    prob.robust_cuts = [(70.0, 1.51), (85.0, 0.9)]
    w = np.ones(model.n_flaps)
    out = {}
    for analytic in (False, True):
        fun, pts = prob.robust_function(analytic=analytic)
        x = ca.MX.sym("x", 5)
        J = np.asarray(ca.Function("J", [x], [ca.jacobian(fun(x, w), x)])(THETA).full())
        v = np.asarray(fun(THETA, w).full()).ravel()
        out[analytic] = {p: (v[i], J[i]) for i, p in enumerate(pts)}
    assert set(out[False]) == set(out[True])
    for p, (v, J) in out[False].items():
        va, Ja = out[True][p]
        assert va == pytest.approx(v, rel=1e-9)
        np.testing.assert_allclose(Ja, J, rtol=0, atol=1e-9 * max(np.abs(J).max(), 1e-12))


def test_inverse_iteration_gives_the_eigenvectors_of_eig():
    # eigvals + shifted inverse iteration: the eigenvalue derivative w^H dA v / w^H v from
    # its vectors equals the one from scipy's eig vectors (a random 40x40, 3 eigenvalues;
    # two steps from a 1e-10 shift converge to round-off: 1e-8 relative)
    rng = np.random.default_rng(3)
    A = rng.standard_normal((40, 40))
    dA = rng.standard_normal((40, 40))
    lam, vl0, vr0 = scipy.linalg.eig(A, left=True, right=True)
    idx = np.argsort(-lam.real)[:3]
    vl, vr = inverse_iteration(A, lam[idx])
    for k, i in enumerate(idx):
        ref = vl0[:, i].conj() @ dA @ vr0[:, i] / (vl0[:, i].conj() @ vr0[:, i])
        got = vl[:, k].conj() @ dA @ vr[:, k] / (vl[:, k].conj() @ vr[:, k])
        assert got == pytest.approx(ref, rel=1e-8)
        np.testing.assert_allclose(A @ vr[:, k], lam[i] * vr[:, k], atol=1e-9)
        np.testing.assert_allclose(vl[:, k].conj() @ A, lam[i] * vl[:, k].conj(), atol=1e-9)


def test_fd_fallback_only_at_flagged_speeds(small):
    # a defect tolerance of 1 flags every row: the fallback then recomputes each speed once
    # per difference (2 n_p evaluations of one speed each, not of the whole grid), and the
    # differenced Jacobian matches the analytic one: central FD with step 1e-6 on eigvals
    # whose round-off is ~eps ||A|| ~ 1e-14 1/s leaves ~1e-8 absolute (4.5e-9 seen)
    s, model = small
    prob = DesignProblem(s, model)
    cb = prob.grid_callback(np.array([20.0, 50.0]))
    J = cb.jacobian(THETA)
    cb.defect_tol = 1.0
    cb._key = None
    Jfd = cb.jacobian(THETA)
    assert cb.fd_speed_evaluations == 2
    np.testing.assert_allclose(Jfd, J, rtol=0, atol=2e-8)
    assert np.abs(J).max() > 1e-6       # the entries compared are not all round-off


def test_fresh_variants_reported_stable_are_stable(small_box_fresh):
    # every fresh variant that fresh_variant_check counts as
    # stable 0..speed_max is stable in an independent sweep (model.stability.sweeps.sweep on the
    # closed-loop system of that variant, same grid and modes), and every one it counts as
    # unstable is not -- so the reported fraction is the sweep's
    from bridgeflap.design.control.search.driver import fresh_variant_check, sample_variants
    from bridgeflap.model.aeroelastic.control import Compensator, Controller
    from bridgeflap.model.stability.sweeps import sweep
    from bridgeflap.model.structure.loader import load_bridge

    s = small_box_fresh
    base = load_bridge(s.bridge)
    fresh = sample_variants(s, base, 3, s.variant_seed + 1000)
    theta = (0.0, 0.5, -1.0, 0.05, 0.5)
    ctrl = Controller(Compensator(*theta), tuple(s.positions()), s.flap_width_m,
                      s.leading_edge, s.trailing_edge, s.gain_limit)
    out = fresh_variant_check(s, ctrl, fresh)
    assert out["count"] == 3
    for row, spec in zip(out["variants"], fresh, strict=True):
        _, model = build_model(s, n_modes=s.fresh_variant_modes, spec=spec)
        sw = sweep(model.system(Compensator(*theta)), s.check_speeds())
        stable = bool(np.all(sw.eigenvalues.real.max(axis=1) < 0))
        assert row["stable_everywhere"] == stable
    assert out["fraction_stable"] == pytest.approx(
        sum(r["stable_everywhere"] for r in out["variants"]) / 3)


def test_flap_count_search_in_two_processes_equals_the_serial_one(small_box_fresh):
    # the parallel same-K search (two counts in flight) gives the serial search's rows and
    # minimum, the stopping rule applied count by count (exact: same computation per count)
    from dataclasses import replace

    from bridgeflap.design.control.search.driver import minimum_flap_count

    s = small_box_fresh
    theta = (0.0, 0.5, -1.0, 0.05, 0.5)
    ser = minimum_flap_count(replace(s, parallel=False), theta)
    par = minimum_flap_count(replace(s, parallel=True), theta)
    assert par == ser
    assert len(ser.counts) >= 1
    # the full layout's check already made (a start's verification) is reused as its row:
    # the same computation, so the same search to the last bit
    from bridgeflap.design.control.search.driver import verify_layout

    ver = verify_layout(s, theta, s.positions())
    assert minimum_flap_count(replace(s, parallel=True), theta,
                              known={s.flap_count: ver}) == ser


def test_damping_callback_lazy_vectors_values_and_jacobian(small):
    # the eigenvectors are computed only when the Jacobian asks (inverse iteration on the
    # cached matrices): values-only evaluations leave them unset, the values equal the
    # numeric dense check (same matrices, eigvals: round-off, 1e-10 1/s on |lambda| ~ 1-10),
    # and the analytic Jacobian matches central differences: step 1e-5 relative, truncation
    # ~h^2 and round-off ~1e-14/h ~ 1e-9 relative to the largest entry (1.6e-6 seen on this
    # weakly coupled 5-flap model), so 1e-4 of the largest entry
    s, model = small
    prob = DesignProblem(s, model)
    speeds = np.array([0.0, 20.0, 50.0, 70.0])
    cb = prob.grid_callback(speeds)
    v = cb.values(THETA)
    assert all(r[1] is None for r in cb._store)
    ref = prob.constraint_values(THETA, speeds)
    np.testing.assert_allclose(v.reshape(len(speeds), -1)[:, 0], ref, rtol=0, atol=1e-10)
    J = cb.jacobian(THETA)
    assert all(r[1] is not None for r in cb._store)
    np.testing.assert_array_equal(cb.values(THETA), v)      # same cache entry, same values
    Jfd = np.empty_like(J)
    for k in range(5):
        h = 1e-5 * max(1.0, abs(THETA[k]))
        e = np.zeros(5)
        e[k] = h
        Jfd[:, k] = (cb.values(THETA + e) - cb.values(THETA - e)) / (2 * h)
    scale = np.abs(J).max()
    assert scale > 1e-5                 # not all round-off
    np.testing.assert_allclose(J, Jfd, rtol=0, atol=1e-4 * scale)


def test_closed_form_compensator_poles_equal_numpy_roots():
    # the copy test's compensator poles in closed form: the roots np.roots gives (real pair,
    # complex pair, double root), to round-off (1e-15 relative)
    from bridgeflap.design.control.formulation.eigen import _quadratic_roots

    for a2, a1 in [(0.05, 0.5), (0.0268, 0.8375), (1.0, 0.1), (1e-3, 10.0), (0.25, 1.0)]:
        got = np.sort_complex(np.array(_quadratic_roots(a2, a1), complex))
        ref = np.sort_complex(np.roots([a2, a1, 1.0]).astype(complex))
        np.testing.assert_allclose(got, ref, rtol=1e-15 * 10, atol=0)


def test_numeric_verification_equals_the_symbolic_parts(small):
    # the checks-only problem (numeric=True) takes the closed loop from ClosedLoopModel.system
    # instead of the CasADi parts: same assembly, parts equal to round-off (~1e-15 relative),
    # so the dense check's abscissa and damping measures agree to 1e-9 1/s (eigenvalues of
    # magnitude <= ~50 1/s moved by round-off) and every flag is the same
    s, model = small
    sym = DesignProblem(s, model)
    num = DesignProblem(s, model, numeric=True)
    for a, b in zip(sym.A_parts(THETA), num.A_parts(THETA), strict=True):
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-12 * max(np.abs(a).max(), 1.0))
    assert num._functions is None           # nothing symbolic built
    vs, vn = sym.verify(THETA), num.verify(THETA)
    np.testing.assert_allclose(vn.abscissa_1_s, vs.abscissa_1_s, rtol=0, atol=1e-9)
    np.testing.assert_allclose(vn.violation_1_s, vs.violation_1_s, rtol=0, atol=1e-9)
    assert (vn.meets_damping, vn.stable_everywhere, vn.stable_to_m_s, vn.max_gain) == (
        vs.meets_damping, vs.stable_everywhere, vs.stable_to_m_s, vs.max_gain)


@pytest.mark.parametrize("placement", [False, True])
def test_compensator_reduction_keeps_every_constraint_and_derivative(small, placement):
    # design.control.formulation.plant.compensator_reduction: the per-flap compensator states of 5
    # flaps on 6 modes (rank Phi_a < 5) projected on their invariant subspace. The reduced A(U) has
    # exactly the eigenvalues of the full one minus copies of the compensator poles (the 0 m/s and
    # 60 m/s matrices, sorted, to 1e-9 relative: eigenvalue round-off of a 50-state matrix), and the
    # damping constraints and their Jacobians equal the full-state ones (the same eigenvalues
    # and, T being constant, the same derivatives; 1e-9 relative: FD rows use 1e-6 steps,
    # identical in both paths, the analytic rows agree to round-off).
    import bridgeflap.design.control.formulation.nlp as nlp
    from bridgeflap.design.control.formulation.plant import compensator_reduction

    s, model = small
    s = s if not placement else load_settings(None, n_modes=6, flap_count=5,
                                              optimise_placement=True,
                                              robust_design_speeds_m_s=(30.0, 60.0),
                                              n_robust_omega=8)
    red = compensator_reduction(model, model.casadi_functions()["A_cl"].size1_out(0))
    assert red is not None and red[0].shape[1] < red[0].shape[0]
    speeds = np.array([0.0, 30.0, 60.0, 85.0])
    out = {}
    try:
        for flag in (False, True):
            nlp.REDUCE_COMPENSATORS = flag
            prob = DesignProblem(s, model)
            cb = prob.grid_callback(speeds)
            p = THETA if not placement else np.concatenate([THETA, 0.7 * np.ones(prob.n_z)])
            out[flag] = (cb.values(p), cb.jacobian(p), cb.matrices(p))
    finally:
        nlp.REDUCE_COMPENSATORS = True
    np.testing.assert_allclose(out[True][0], out[False][0], rtol=1e-9, atol=1e-12)
    J0 = out[False][1]
    np.testing.assert_allclose(out[True][1], J0, rtol=0, atol=1e-9 * np.abs(J0).max())
    poles = np.roots([THETA[3], THETA[4], 1.0])
    for k in (0, 2):
        full = np.linalg.eigvals(out[False][2][k])
        reduced = list(np.linalg.eigvals(out[True][2][k]))
        # remove each reduced eigenvalue from the full set; what is left: compensator poles
        rest = list(full)
        for lam in reduced:
            j = int(np.argmin(np.abs(np.asarray(rest) - lam)))
            assert abs(rest[j] - lam) <= 1e-9 * max(1.0, abs(lam))
            rest.pop(j)
        assert len(rest) == out[False][2][k].shape[0] - out[True][2][k].shape[0] > 0
        assert all(np.min(np.abs(poles - lam)) <= 1e-6 * max(1.0, abs(lam)) for lam in rest)


def test_robust_check_plant_cache_is_exact(small):
    # design.control.formulation.robust.cached_plant: the dense robust check of every cutting-plane
    # round reuses the theta-independent plant factors of its fixed grid. Exactness is bitwise (each
    # frequency is solved on its own in both paths), so the margins, peaks and the factors
    # themselves must be identical, at a first theta (cache filled) and a second (reused),
    # and the cache must actually hold the fixed grid after the first call.
    from bridgeflap.design.control.formulation.plant import plant_factors
    from bridgeflap.design.control.formulation.robust import cached_plant, robust_margin

    s, model = small
    prob = DesignProblem(s, model)
    speeds = prob.robust_check_speeds()
    for th in (THETA, THETA * 1.05):
        cached = prob.robust_margin(th, speeds=speeds, peaks=3)
        plain = robust_margin(model, th, speeds, prob.weights,
                              lambda U, th=th: prob.robust_dense_omega(th, U), peaks=3)
        assert np.array_equal(cached.t_inf, plain.t_inf)
        assert cached.peaks == plain.peaks
    cache = prob.callbacks["plant factors"]
    assert set(cache) == {float(u) for u in speeds}
    U = float(speeds[0])
    om = cache[U][0][::7]
    Pa, X = cached_plant(model, U, om, cache)
    Pa0, X0 = plant_factors(model, U, 1j * om)
    assert np.array_equal(Pa, Pa0) and np.array_equal(X, X0)


def _feed(cb, violations, ub=0.0):
    """Drive an IterationCallback with iterates whose one constraint violates by ``v``."""
    stops = []
    for v in violations:
        stops.append(cb.eval([np.zeros(1), 0.0, np.array([ub + v])])[0])
    return stops


@pytest.mark.parametrize("stall", [True, False])
def test_divergence_watchdog_stops_a_stall_not_a_falling_violation(stall):
    from bridgeflap.design.control.formulation.ipopt_hooks import (
        DIVERGE_ITERATIONS,
        DIVERGE_LEVEL,
        IterationCallback,
    )

    cb = IterationCallback("w", 1, 1, watch=([-np.inf], [0.0], DIVERGE_LEVEL,
                                             DIVERGE_ITERATIONS))
    n = DIVERGE_ITERATIONS + 1
    # stall: start 1 round 1 of the default card, flat at ~30 (design.control.formulation.nlp)
    if stall:
        seq = [0.0] * 5 + [30.0] * (n + 3)
    else:           # start 0 round 0: 390 -> 11 above the level, halving on the way
        seq = [0.0] * 3 + list(np.geomspace(390.0, 6.0, n + 3)) + [0.0] * 5
    stops = _feed(cb, seq)
    assert cb.stopped_diverged is stall
    if stall:       # fires on the first iterate that completes the stalled window
        assert stops.index(1) == 5 + DIVERGE_ITERATIONS   # the (its + 1)-th iterate above
    assert len(cb.violations) == len(stops)


@pytest.mark.parametrize("theta", [
    (0.0, 0.0, 0.0, 1.0, 1.0),                  # open loop: flutter inside the grid
    tuple(THETA),
    (-0.8376, 0.3004, -2.7004, 0.2818, 0.0323),  # the default card's design
    (0.0, 0.5, -1.0, 0.05, 0.5),                 # the nominal start (violates the damping)
    (-3.0, 2.0, -8.0, 0.5, 0.3),                 # high gain
])
def test_refined_check_takes_the_dense_checks_decisions(small_box_fresh, theta):
    # the refined check is a subset of the dense grid: where it agrees it agrees exactly, so
    # the maximum violation, the first unstable speed and the verdicts must be equal (no
    # tolerance); and it must check fewer speeds than the dense grid
    from dataclasses import replace

    s = replace(small_box_fresh, check_step_m_s=0.25)
    prob = DesignProblem(s, build_model(s)[1], numeric=True)
    dense = prob.verify(np.asarray(theta, float))
    fast = prob.verify(np.asarray(theta, float), refined=True)
    assert set(fast.speeds_m_s) <= set(dense.speeds_m_s)
    assert len(fast.speeds_m_s) < len(dense.speeds_m_s)
    assert fast.max_violation_1_s == dense.max_violation_1_s
    assert (fast.meets_damping, fast.stable_everywhere, fast.stable_to_m_s) == \
        (dense.meets_damping, dense.stable_everywhere, dense.stable_to_m_s)


def test_multi_model_design_in_two_processes_reports_every_variant(small_box_fresh):
    # design() with variants and fresh variants, parallel: the fresh variants checked in two
    # halves in the worker pool give the serial check's rows (the same computation per
    # variant, in order), and the design variants' checks are reported one per variant
    from dataclasses import replace

    from bridgeflap.design.control.search.driver import design, fresh_variant_check, sample_variants
    from bridgeflap.model.structure.loader import load_bridge

    # 3 rounds of 60 iterations: since the model updating 1 x 30 ends infeasible (max
    # gain 58.5) and leaves no candidate to check; 3 x 60 converges (measured, gain 15.00)
    s = replace(small_box_fresh, starts=1, parallel=True, variants=2, fresh_variants=3,
                design_step_m_s=10.0, cutting_plane_rounds=3, max_iter=60,
                resolve_max_iter=60, weight_buffeting=0.0, min_flap_counts=(5,))
    res = design(s, progress_bar=False)
    assert res.best is not None and len(res.best.variant_checks) == 2
    fv = res.extras["fresh_variants"]
    assert fv["count"] == 3 and fv["design_variants"] == 2
    fresh = sample_variants(s, load_bridge(s.bridge), 3, s.variant_seed + 1000)
    ser = fresh_variant_check(s, res.candidate, fresh)
    assert fv["variants"] == ser["variants"]
    assert fv["fraction_stable"] == ser["fraction_stable"]


def test_the_speed_guard_checks_the_damping_just_above_the_design_speed(small):
    # a start's design model checks the damping at speed_max (1 + SPEED_GUARD_REL) too: there a
    # crossing just above speed_max fails the check (and becomes a cutting plane), while the
    # grid to speed_max alone passes; the guard's value is the dense check's at that speed
    from dataclasses import replace

    from bridgeflap.design.control.formulation.nlp_tolerances import SPEED_GUARD_REL, VIOLATION_TOL
    from bridgeflap.design.control.formulation.plant import damping_check, lag_rates

    s, model = small
    prob = DesignProblem(s, model, numeric=True)
    dense = prob.verify(THETA)
    bad = np.flatnonzero(dense.violation_1_s > VIOLATION_TOL)
    assert bad.size and bad[0] > 0, "THETA must fail the damping somewhere above 0 m/s"
    parts = prob.A_parts(THETA)
    rates = lag_rates(model)

    def excess(u):
        return damping_check(parts, [u], rates, THETA, s.zeta_min)["measure_1_s"][0] \
            - VIOLATION_TOL

    lo, hi = float(dense.speeds_m_s[bad[0] - 1]), float(dense.speeds_m_s[bad[0]])
    for _ in range(60):                 # the first crossing of the tolerance, to ~1e-16 m/s
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if excess(mid) <= 0 else (lo, mid)
    # the design speed just below the crossing: 0.1 guard widths below it
    top = replace(s, speed_max_m_s=hi / (1.0 + 0.1 * SPEED_GUARD_REL))
    plain = DesignProblem(top, model, numeric=True)
    guarded = DesignProblem(top, model, numeric=True)
    guarded.speed_guard_rel = SPEED_GUARD_REL
    v0, v1 = plain.verify(THETA), guarded.verify(THETA)
    assert v0.meets_damping and np.isnan(v0.guard_speed_m_s)
    assert not v1.meets_damping
    assert v1.guard_speed_m_s == pytest.approx(top.speed_max_m_s * (1 + SPEED_GUARD_REL),
                                               rel=1e-15)
    # the same eigenvalues (verify's parts are reduced by the compensator copies: round-off)
    assert v1.guard_violation_1_s == pytest.approx(excess(v1.guard_speed_m_s) + VIOLATION_TOL,
                                                   rel=0, abs=1e-12)
    assert v1.max_violation_1_s == v1.guard_violation_1_s
    # the grid's arrays are the plain check's: the guard sits beside them
    np.testing.assert_array_equal(v1.speeds_m_s, v0.speeds_m_s)
    np.testing.assert_array_equal(v1.violation_1_s, v0.violation_1_s)
    assert v1.to_dict()["guard_speed_m_s"] == v1.guard_speed_m_s
    assert "guard_speed_m_s" not in v0.to_dict()
