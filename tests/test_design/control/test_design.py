"""Compensator design (bridgeflap.design.control.settings, nlp, robust, driver): settings,
derivatives, a real Humber design (slow)."""

from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from bridgeflap.design.control.formulation.buffeting_term import BuffetingCost
from bridgeflap.design.control.formulation.nlp import DesignProblem
from bridgeflap.design.control.formulation.plant import plant_factors
from bridgeflap.design.control.formulation.robust import (
    refine_peaks,
    robust_point_function,
    true_t_peak,
)
from bridgeflap.design.control.results.records import RobustMargin, StartRecord, Verification
from bridgeflap.design.control.search.driver import build_model, select_start
from bridgeflap.design.control.settings import load_settings
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.errors import BridgeflapInputError

THETA = np.array([0.3, 0.25, -1.5, 0.08, 0.5])


@pytest.fixture(scope="module")
def small():
    # Humber, 6 modes, 5 flap pairs: the same code paths as the full design, small matrices
    s = load_settings(None, n_modes=6, flap_count=5, robust_design_speeds_m_s=(30.0, 60.0),
                      n_robust_omega=8)
    spec, model = build_model(s)
    return s, model


@pytest.fixture(scope="module")
def small_box():
    # humber:box (b = 11 m, where a design exists), 6 modes, 5 flap pairs
    s = load_settings(None, bridge="humber:box", n_modes=6, verification_modes=6, flap_count=5,
                      robust_design_speeds_m_s=(30.0, 60.0), n_robust_omega=8)
    spec, model = build_model(s)
    return s, model


def _central_fd(fun, p, h):
    cols = []
    for k in range(p.size):
        e = np.zeros_like(p)
        e[k] = h * max(1.0, abs(p[k]))
        cols.append((fun(p + e) - fun(p - e)) / (2.0 * e[k]))
    return np.column_stack(cols)


def test_settings_reject_bad_gain_bound(tmp_path):
    f = tmp_path / "d.toml"
    f.write_text("[constraints]\ngain_limit = 0.0\n")
    with pytest.raises(BridgeflapInputError, match="gain_limit"):
        load_settings(f)
    f.write_text("nonsense = 1\n")
    with pytest.raises(BridgeflapInputError, match="nonsense"):
        load_settings(f)


def test_cli_optimise_bad_input_writes_nothing(tmp_path):
    from bridgeflap.design.cli.main import main

    f = tmp_path / "d.toml"
    f.write_text("gain_limit = -1.0\n")
    out = tmp_path / "out"
    assert main(["optimise", str(f), "--out", str(out), "--json"]) == 2
    assert not out.exists()


def test_packaged_definition_loads():
    from pathlib import Path

    from bridgeflap.model.analysis import DEFAULT_MODES

    s = load_settings(Path(__file__).resolve().parents[3] / "runs" / "humber_flaps.toml")
    assert s.flap_count == 25 and s.gain_limit == 15.0
    assert s.flap_count * s.flap_width_m == pytest.approx(1410.0)
    # the controller is verified on the model `bridgeflap flutter` uses, finer than (or equal
    # to) the design model, so truncation errors of the design model can be caught
    assert s.verification_modes == DEFAULT_MODES and s.n_modes <= DEFAULT_MODES
    # touching strips are a valid Controller layout (no nudged pitch needed)
    Controller(Compensator(*THETA), tuple(s.positions()), s.flap_width_m)


def test_plant_factors_vanish_at_closed_loop_poles(small):
    # (c) cross-method: G(s) = Phi_a X(s) is the transfer function of the RFA state space,
    # so det(I - K(lambda) G(lambda)) = 0 at every closed-loop eigenvalue lambda that is not
    # an open-loop one. Smallest singular value vs ~1 elsewhere: round-off of the solves.
    s, model = small
    A = model.system(Compensator(*THETA)).A(50.0)
    lam = np.linalg.eigvals(A)
    lam = lam[np.argsort(-np.abs(lam.imag))][:8]          # oscillatory (structural) poles
    # not an open-loop pole: a mode the flaps cannot move (here an antisymmetric one at
    # 1e-15 relative distance since the model updating) keeps its open-loop value and
    # is no zero of det(I - K G); 1e-8 relative separates the two kinds by 7 orders
    ol = np.linalg.eigvals(model.open_loop.A(50.0))
    lam = [p for p in lam if np.min(np.abs(ol - p)) > 1e-8 * abs(p)]
    assert len(lam) >= 4
    for p in lam:
        Pa, X = plant_factors(model, 50.0, [p])
        K = np.polyval(THETA[:3], p) / np.polyval([THETA[3], THETA[4], 1.0], p)
        sv = np.linalg.svd(np.eye(model.n_flaps) - K * Pa @ X[0], compute_uv=False)
        assert sv[-1] < 1e-8 * sv[0]


def test_robust_bound_is_frobenius_of_true_t(small):
    # the NLP's ||T||_F^2 equals the Frobenius norm of the numpy T and bounds sigma_max(T)
    s, model = small
    om = np.array([0.3, 1.2, 2.5])
    Pa, X = plant_factors(model, 60.0, 1j * om)
    f = robust_point_function(Pa)
    w = np.ones(model.n_flaps)
    K = Compensator(*THETA).frequency_response(om)
    smax = true_t_peak(THETA, Pa, X, om, w)
    for k in range(3):
        v = float(f(THETA, w, om[k], X[k].real, X[k].imag))
        G = Pa @ X[k]
        T = np.linalg.solve(np.eye(5) - K[k] * G, K[k] * G)
        # same algebra (push-through identity), different order: round-off only
        assert v == pytest.approx(np.linalg.norm(T, "fro") ** 2, rel=1e-9)
        assert np.sqrt(v) >= smax[k] * (1 - 1e-12)


def test_lowrank_robust_form_equals_the_full_solve(small):
    # design.control.formulation.robust.lowrank_point_function (the placement design's robust
    # constraint): the push-through identity through the rank-r pitch map Phi_a = U_r S V_r^T turns
    # the n_modes solve into an r x r one. Same algebra, so values and Jacobians in theta and
    # in the flap weights agree with robust_point_function to round-off (1e-10 relative:
    # ~1e6 ulps, far below any effect, far above the ~1e-15 observed)
    from bridgeflap.design.control.formulation.robust import (
        lowrank_point_function,
        lowrank_robust_data,
    )

    s, model = small
    om = np.array([0.3, 1.2, 2.5])
    Pa, X = plant_factors(model, 60.0, 1j * om)
    US, sv, E = lowrank_robust_data(Pa, X)
    assert US.shape[1] == np.linalg.matrix_rank(Pa) <= min(Pa.shape)
    f0, f1 = robust_point_function(Pa), lowrank_point_function(US, sv)
    x = ca.MX.sym("x", 5 + model.n_flaps)
    rng = np.random.default_rng(5)
    for k in range(3):
        e0 = f0(x[:5], x[5:], om[k], X[k].real, X[k].imag)
        e1 = f1(x[:5], x[5:], om[k], E[k].real, E[k].imag)
        J = ca.Function("J", [x], [e0, e1, ca.jacobian(e0, x), ca.jacobian(e1, x)])
        p = np.concatenate([THETA, rng.uniform(0.2, 1.0, model.n_flaps)])
        v0, v1, j0, j1 = (np.asarray(v.full()) for v in J(p))
        np.testing.assert_allclose(v1, v0, rtol=1e-10)
        np.testing.assert_allclose(j1, j0, rtol=0, atol=1e-10 * np.abs(j0).max())


def test_robust_constraint_gradient_matches_finite_differences(small):
    # (d) gradient of ||T(jw, U)||_F^2 w.r.t. theta and the flap weights (CasADi AD through the
    # complex solve) against central differences
    s, model = small
    prob = DesignProblem(s, model)
    fun, pts = prob.robust_function()
    w0 = np.array([1.0, 0.8, 0.6, 0.9, 0.7])
    x = ca.MX.sym("x", 5 + model.n_flaps)
    J = ca.Function("J", [x], [ca.jacobian(fun(x[:5], x[5:]), x)])
    p0 = np.concatenate([THETA, w0])
    Jn = np.asarray(J(p0).full())

    def val(p):
        return np.asarray(fun(p[:5], p[5:]).full()).ravel()

    Jfd = _central_fd(val, p0, 1e-6)
    # central FD with relative step 1e-6: truncation ~1e-12 |f'''|, round-off ~eps |f| / h
    # ~1e-10 |f|; values are O(0.01..10): 1e-6 of the largest entry leaves a wide margin
    np.testing.assert_allclose(Jn, Jfd, rtol=0, atol=1e-6 * np.abs(Jfd).max())
    assert len(pts) == Jn.shape[0]


def test_placement_weight_gradient_matches_finite_differences(small):
    # (d) damping constraints with free flap weights: d g / d(theta, w), independent weights
    # and the symmetric ones (one per mirror pair, 3 for 5 flaps)
    s, model = small
    prob = DesignProblem(replace(s, optimise_placement=True, symmetric_layout=False), model)
    cb = prob.grid_callback([0.0, 40.0, 70.0])
    p0 = np.concatenate([THETA, [1.0, 0.8, 0.6, 0.9, 0.7]])
    sym = DesignProblem(replace(s, optimise_placement=True), model)
    assert sym.n_z == 3
    np.testing.assert_array_equal(sym.symmetry @ [0.1, 0.2, 0.3], [0.1, 0.2, 0.3, 0.2, 0.1])
    cbs = sym.grid_callback([0.0, 40.0, 70.0])
    ps = np.concatenate([THETA, [1.0, 0.6, 0.7]])
    Js = np.asarray(ca.Function("J", [x := ca.MX.sym("xs", 8)],
                                [ca.jacobian(cbs(x), x)])(ps).full())
    Jsfd = _central_fd(cbs._plain_values, ps, 1e-6)
    np.testing.assert_allclose(Js, Jsfd, rtol=0, atol=1e-6 * np.abs(Jsfd).max())
    x = ca.MX.sym("x", p0.size)
    Jn = np.asarray(ca.Function("J", [x], [ca.jacobian(cb(x), x)])(p0).full())
    Jfd = _central_fd(cb._plain_values, p0, 1e-6)
    # simple eigenvalues (no crossing within the stencil): truncation ~1e-12, round-off
    # eps |lambda| / h ~ 1e-9 for |lambda| ~ 10 1/s; 1e-6 relative to max |J| is generous
    np.testing.assert_allclose(Jn, Jfd, rtol=0, atol=1e-6 * np.abs(Jfd).max())
    # zero weight on every flap is the open loop: the weights really enter A
    assert np.abs(Jn[:, 5:]).max() > 0


def test_placement_solve_runs_and_reports_status(small):
    # a short Ipopt run with free weights (penalised): finite weights in [0, 1], a status
    s, model = small
    s2 = replace(s, optimise_placement=True, weight_flaps=0.5, max_iter=15,
                 robust_design_speeds_m_s=(40.0,))
    prob = DesignProblem(s2, model)
    res = prob.solve(THETA, np.array([0.0, 40.0, 70.0]))
    assert isinstance(res.ipopt_status, str)
    assert np.all((res.weights >= -1e-8) & (res.weights <= 1 + 1e-8))


def test_refine_peaks_finds_resonance_between_grid_points():
    # a resonance of relative half-width 1e-3 centred between two points of a 2 % log grid:
    # the sampled maximum under-reads it by > 2x, the polished one is exact (xatol 1e-9 rel.)
    w0, zeta = 1.2345, 1e-3

    def fun(w):
        w = np.atleast_1d(w)
        return 1.0 / np.sqrt((1 - (w / w0) ** 2) ** 2 + (2 * zeta * w / w0) ** 2)

    om = np.logspace(-1, 1, 233)
    pk = refine_peaks(fun, om, fun(om), 3)
    true_peak = 1.0 / (2 * zeta * np.sqrt(1 - zeta**2))
    assert fun(om).max() < 0.5 * true_peak
    # maximiser located to ~1e-9 relative: the value error is ~(1e-9 / zeta)^2 ~ 1e-12
    assert pk[0][1] == pytest.approx(true_peak, rel=1e-9)
    assert pk[0][0] == pytest.approx(w0 * np.sqrt(1 - 2 * zeta**2), rel=1e-8)


def _rec(start, viol, gain, verified, margin, stable_to=85.0, objective=float("nan")):
    ver = Verification(speeds_m_s=np.zeros(1), abscissa_1_s=np.zeros(1),
                       violation_1_s=np.zeros(1), max_violation_1_s=viol,
                       stable_everywhere=True, stable_to_m_s=stable_to, max_gain=gain, modes=16,
                       step_m_s=0.25, meets_damping=viol <= 1e-6)
    rob = RobustMargin(speeds_m_s=np.array([70.0]), t_inf=np.array([1.0 / margin]),
                       peak_omega_rad_s=np.array([1.0]), peaks=(), margin=margin)
    return StartRecord(start=start, theta0=(0.0,) * 5, ipopt_status="Solve_Succeeded",
                       success=True, time_s=1.0, theta=(0.0,) * 5, max_violation_1_s=viol,
                       max_gain=gain, meets_damping=viol <= 1e-6, gain_ok=gain <= 15.0,
                       verified=verified, robust=rob, verification=ver, objective=objective)


def test_select_start_best_verified_and_gain_never_converged():
    recs = [_rec(0, -1e-5, 4.0, True, 0.40), _rec(1, -1e-5, 3.0, True, 0.45),
            _rec(2, -1e-5, 15.03, True, 0.90)]          # best margin but above the gain limit
    best, status = select_start(recs, 15.0)
    assert status == "converged" and best.start == 1
    best, status = select_start([recs[2]], 15.0)
    assert status == "infeasible" and best.start == 2
    best, status = select_start([_rec(0, -1e-5, 15.0 * (1 + 1e-9), True, 0.4)], 15.0)
    assert status == "infeasible"                       # no tolerance on the true peak
    failed = StartRecord(start=0, theta0=(0.0,) * 5, ipopt_status="failed: x", success=False,
                         time_s=0.0)
    assert select_start([failed], 15.0) == (None, "failed")


def test_a_design_beyond_its_actuator_limits_is_not_converged():
    # the flap demand the NLP holds within the limits is checked a posteriori: a solution that
    # left it beyond a limit (an infeasible or capped iterate) is no design, whatever its
    # damping, gain and verification; measured: the default quick card on a deck with GJ -10 %
    # and mass +5 % ended on such an iterate (3 sigma flap angle 25 deg at 74 m/s, limit 20)
    # and was reported converged before its acceptance failed
    from dataclasses import replace as repl
    from types import SimpleNamespace

    from bridgeflap.design.control.solve.start import flap_demand_record

    ok, over = _rec(0, -1e-5, 4.0, True, 0.40), _rec(1, -1e-5, 3.0, True, 0.45)
    over = repl(over, actuator_ok=False)
    assert select_start([ok, over], 15.0)[0].start == 0
    best, status = select_start([over], 15.0)
    assert status == "infeasible" and best.start == 1
    # the record: 3 sigma of the RMS per speed (two flaps, angle then rate), the limits
    # themselves (the NLP's 5 % back-off is not a limit)
    s = SimpleNamespace(actuator_design_speeds_m_s=(60.0, 74.0), optimise_placement=False,
                        flap_angle_limit_deg=20.0, flap_rate_limit_deg_s=40.0)
    rms = np.array([[3.0, 2.0, 5.0, 4.0], [6.8, 6.0, 13.0, 14.0]])     # deg, deg/s
    dem = SimpleNamespace(speeds_m_s=np.array([60.0, 74.0]), rms_deg=lambda th: rms)
    prob = SimpleNamespace(callbacks={"flap_demand": dem})
    rec = flap_demand_record(s, prob, np.zeros(5))
    assert rec["flap_angle_3sigma_deg"] == pytest.approx([9.0, 20.4])
    assert rec["flap_rate_3sigma_deg_s"] == pytest.approx([15.0, 42.0])
    assert not rec["within_limits"] and len(rec["exceeded"]) == 2
    assert "74 m/s" in rec["exceeded"][0] and "angle" in rec["exceeded"][0]
    rms[1] = [6.6, 6.0, 13.0, 13.3]                      # 19.8 deg, 39.9 deg/s: within
    assert flap_demand_record(s, prob, np.zeros(5))["within_limits"]
    # no actuator constraints: no record, and the design is judged without one
    assert flap_demand_record(repl_ns(s, actuator_design_speeds_m_s=()), prob, None) is None
    assert flap_demand_record(s, SimpleNamespace(callbacks={}), None) is None


def repl_ns(ns, **kw):
    from types import SimpleNamespace

    return SimpleNamespace(**{**vars(ns), **kw})


def test_select_start_ranks_verified_starts_by_objective():
    # the design's own objective decides, not the margin (start 1 has the
    # larger margin but the worse objective); an unverified start never wins on objective
    recs = [_rec(0, -1e-5, 4.0, True, 0.40, objective=2.0),
            _rec(1, -1e-5, 3.0, True, 0.45, objective=2.5),
            _rec(2, -1e-5, 3.0, False, 0.60, objective=1.0)]
    best, status = select_start(recs, 15.0)
    assert status == "converged" and best.start == 0
    # a NaN objective ranks last; equal objectives tie and the lower start index wins (a
    # fixed rule: the margins of two starts on one optimum differ only in their last bits)
    recs = [_rec(0, -1e-5, 4.0, True, 0.50), _rec(1, -1e-5, 4.0, True, 0.40, objective=3.0),
            _rec(2, -1e-5, 4.0, True, 0.45, objective=3.0)]
    assert select_start(recs, 15.0)[0].start == 1


def test_a_phase_1_point_has_no_design_objective():
    # the default card's start 1 ends on its phase-1 point (objective of the feasibility
    # solve, 1.4 against start 0's design objective): it must not win on that number
    from types import SimpleNamespace

    from bridgeflap.design.control.solve.start import _phase_1

    rounds = (SimpleNamespace(placement="phase 1 (feasibility, no robust epigraph)"),
              SimpleNamespace(placement=None))
    assert _phase_1(SimpleNamespace(rounds=rounds, chosen_round=0))
    assert not _phase_1(SimpleNamespace(rounds=rounds, chosen_round=1))
    assert not _phase_1(SimpleNamespace(rounds=(), chosen_round=0))


def test_gain_cuts_enforce_true_peak(small):
    # a 4-point gain grid misses the compensator peak; after the cut rounds the chosen design
    # meets the true sup |K| <= gain_limit, or is flagged (gain_ok False), never hidden
    s, model = small
    s2 = replace(s, gain_limit=2.0, n_omega=4, max_iter=25, resolve_max_iter=15,
                 cutting_plane_rounds=2, design_step_m_s=20.0, weight_robust=0.0)
    prob = DesignProblem(s2, model)
    res = prob.solve_with_cuts(np.array([0.2, 0.3, -1.0, 0.05, 0.1]))
    kmax = Compensator(*res.theta).max_gain()
    assert res.gain_ok == (kmax <= 2.0)
    cut_rounds = [r for r in res.rounds if r.placement is None]     # not the phase-1 solve
    for r in cut_rounds[:-1]:
        c = Compensator(*r.theta)
        finite = [w for w in c.stationary_frequencies() if abs(c.frequency_response(w)) > 2.0]
        if finite:      # a peak between grid points (not at 0 or infinity, constrained exactly)
            assert set(finite) <= set(prob.gain_cuts)
    assert res.rounds[res.chosen_round].chosen


def test_robust_cuts_report_dense_peak(small):
    # robust cut loop on the small model: the reported dense peak is the sigma_max check of
    # the chosen design, and the flag is exactly dense peak <= gamma_T (1 + robust_cut_tol)
    s, model = small
    s2 = replace(s, max_iter=30, resolve_max_iter=15, cutting_plane_rounds=1,
                 design_step_m_s=20.0, robust_speeds_m_s=(30.0, 60.0))
    prob = DesignProblem(s2, model)
    res = prob.solve_with_cuts(THETA)
    peak = res.robust.peak
    chk = prob.robust_margin(res.theta, speeds=prob.robust_check_speeds())
    assert peak == pytest.approx(chk.peak, rel=1e-12)
    assert res.robust_bound_holds == (peak <= res.solve.gamma_T * (1 + s2.robust_cut_tol))


def test_buffeting_callback_value_and_gradient(buffeting_problem):
    from bridgeflap.model.response.buffeting import buffeting

    s, spec, model = buffeting_problem
    prob = DesignProblem(s, model, spec=spec)
    ctrl = Controller(Compensator(*THETA), tuple(s.positions()), s.flap_width_m)
    ref = buffeting(spec, list(s.buffeting_speeds_m_s), n_modes=6, controller=ctrl)
    ol = buffeting(spec, list(s.buffeting_speeds_m_s), n_modes=6)
    z, a = prob.buffeting_rms(THETA)
    # same closed loop, same quadrature: equal to round-off (1e-10 relative)
    np.testing.assert_allclose(z, ref.rms_vertical, rtol=1e-10)
    np.testing.assert_allclose(a, ref.rms_torsion, rtol=1e-10)
    cb = BuffetingCost(prob, 5)
    # J_buf is normalised by K = 0 with the flaps fitted (same state space and quadrature
    # grid construction as the closed loop); the bare deck differs only by the adaptive grid
    # (convergence tolerance 5e-3, observed ~1e-5): 1e-3 relative
    z0, a0 = prob.buffeting_rms([0.0, 0.0, 0.0, 1.0, 1.0])
    np.testing.assert_allclose(z0, ol.rms_vertical, rtol=1e-3)
    np.testing.assert_allclose(a0, ol.rms_torsion, rtol=1e-3)
    j_expected = 0.5 * np.mean((ref.rms_vertical / z0) ** 2 + (ref.rms_torsion / a0) ** 2)
    assert float(cb(THETA)) == pytest.approx(j_expected, rel=1e-10)
    x = ca.MX.sym("x", 5)
    g_cb = np.asarray(ca.Function("J", [x], [ca.jacobian(cb(x), x)])(THETA).full()).ravel()
    f = prob.buffeting_cost
    g_c, d2 = np.empty(5), np.empty(5)
    for k in range(5):
        e = np.zeros(5)
        h = 1e-5 * max(1.0, abs(THETA[k]))
        e[k] = h
        g_c[k] = (f(THETA + e) - f(THETA - e)) / (2 * h)
        h2 = 1e-3 * max(1.0, abs(THETA[k]))
        e[k] = h2
        d2[k] = (f(THETA + e) - 2 * f(THETA) + f(THETA - e)) / h2**2
    # forward difference with h_k = 1e-4 max(1, |p_k|): error h_k/2 |f''_k| (truncation) +
    # 2 eps_f / h_k (eps_f ~ 1e-13 quadrature round-off on J ~ 1, i.e. ~2e-9); the central
    # reference errs by ~h^2 |f'''| ~ 1e-10. Allowed: twice the truncation term + 1e-8.
    hk = cb.step * np.maximum(1.0, np.abs(THETA))
    np.testing.assert_array_less(np.abs(g_cb - g_c), hk * np.abs(d2) + 1e-8)
    assert np.all(np.abs(g_c) > 1e-4)                 # a non-trivial gradient


def test_buffeting_weight_lowers_rms(buffeting_problem):
    # a short solve with the buffeting term (weighted speed 20 m/s) against weight 0, same
    # start and iteration budget: the closed-loop RMS at 20 m/s is not higher
    s, spec, model = buffeting_problem
    base = replace(s, buffeting_speeds_m_s=(20.0,), max_iter=12,
                   robust_design_speeds_m_s=(40.0,), n_robust_omega=6)
    speeds = np.array([0.0, 20.0, 40.0, 60.0])
    out = {}
    for wb in (0.0, 2.0):
        prob = DesignProblem(replace(base, weight_buffeting=wb), model, spec=spec)
        res = prob.solve(THETA, speeds)
        z, a = prob.buffeting_rms(res.theta)
        out[wb] = (float(z[0]), float(a[0]), prob.buffeting_cost(res.theta))
    # J_buf (the weighted quantity, the mean of both squared RMS ratios) strictly lower, and
    # at least one RMS lower: J_buf may trade a little of one for more of the other (damping
    # constraints: vertical +1e-4 relative, torsion lower), which the sum permits
    assert out[2.0][2] < out[0.0][2]
    assert out[2.0][0] < out[0.0][0] or out[2.0][1] < out[0.0][1]


@pytest.mark.slow
def test_humber_design_stable_on_16_modes(tmp_path, capsys):
    # The packaged design (16 modes, 1 start, scenarios, cutting planes) through the CLI:
    # stable on the 16-mode model of `bridgeflap flutter` at every 0.25 m/s speed up to the
    # card's design speed, gain <= 15, every start's Ipopt status reported.
    import json

    from bridgeflap.design.cli.main import main
    from bridgeflap.model.aeroelastic.controller_file import load_controller
    from bridgeflap.model.analysis import DEFAULT_MODES, closed_loop_flutter
    from bridgeflap.model.structure.loader import load_bridge

    out = tmp_path / "opt"
    # the acceptance checks that judge the status, at a test's size: the independent closed
    # loop and 50 fresh variants (the default 1000 and the failure and actuator checks are
    # measured in bench.design)
    rc = main(["optimise", "--out", str(out), "--json", "--checks",
               "independent_check,robustness", "--check-samples", "50"])
    payload = json.loads(capsys.readouterr().out)
    # The scenario design does no harm by construction: the verdict is "passed" and the
    # status "converged" on every machine (the same layout and critical speed on other BLAS
    # kernels and thread counts, tests/test_design/control/test_reproducible.py)
    assert payload["acceptance"]["status"] == "passed", payload["acceptance"]["status"]
    assert rc == 0 and payload["status"] == "converged"
    rob = payload["acceptance"]["robustness"]
    assert rob["harmed_count"] == 0 and rob["variants"] == 50
    assert len(payload["starts"]) == 1     # the card's nominal start
    assert all(isinstance(st["status"], str) and st["status"] for st in payload["starts"])
    assert payload["verification"]["modes"] == DEFAULT_MODES
    # the compensator's poles keep the card's damping (30 %): no resonant peak
    assert payload["starts"][0]["compensator_damping_ratio"] >= 0.3 * (1 - 1e-5)
    ctrl = load_controller(out / "controller.toml")
    # 1e-9 relative: the reported sup is a root-polished stationary point
    assert ctrl.compensator.max_gain() <= 15.0 * (1 + 1e-9)
    # on the bridge the design definition names (runs/humber_flaps.toml: humber:box)
    from bridgeflap.design.cli.optimise import DEFAULT_DEFINITION

    s = load_settings(DEFAULT_DEFINITION)
    res = closed_loop_flutter(load_bridge(s.bridge), ctrl,
                              np.arange(0.0, s.speed_max_m_s + 1e-4, 0.25),
                              n_modes=DEFAULT_MODES)
    summ = res.summary()
    assert summ["flutter_status"] == "no_crossing_in_range"
    assert summ["divergence_status"] == "no_crossing_in_range"
    prob = DesignProblem(s, build_model(s, positions=ctrl.flap_strip_positions_m)[1])
    theta = np.array([getattr(ctrl.compensator, n) for n in ("b2", "b1", "b0", "a2", "a1")])
    ver = prob.verify(theta)
    # prob.verify is the design model's own dense check (16 modes); the 30-mode verification
    # is the payload's, asserted above
    assert ver.modes == s.n_modes and ver.step_m_s == 0.25
    assert ver.stable_everywhere and ver.stable_to_m_s == s.speed_max_m_s
    assert ver.max_violation_1_s <= 1e-6      # the minimum damping too (VIOLATION_TOL)
    # the margin at the robust speeds is the true sigma_max one (1e-9: the same SVDs), and
    # the headline, the minimum over the whole speed range, can only be lower
    at = prob.robust_margin(theta).margin
    assert payload["robust_margin_at_robust_speeds"] == pytest.approx(at, rel=1e-9)
    assert payload["robust_margin"] <= at * (1 + 1e-12)
    assert payload["robust_margin_basis"] == "speed_grid"
    # humber:box flutters at 70.89 m/s open loop (README): inside the 0-85 m/s design range
    assert summ["open_loop_flutter_status"] == "converged"
    assert summ["open_loop_flutter_speed_m_s"] < 85.0


def test_failed_design_summary_keeps_the_optimise_contract():
    # a design with no usable start: the same top-level keys as a converged one (the golden
    # optimise case), NaN numbers, the failure as data in starts and start_table
    import json
    from dataclasses import FrozenInstanceError
    from pathlib import Path

    from bridgeflap.design.control.results.result import DesignResult

    s = load_settings(None)
    failed = StartRecord(start=0, theta0=(0.0,) * 5, ipopt_status="failed: x", success=False,
                         time_s=0.5)
    with pytest.raises(FrozenInstanceError):
        failed.max_gain = 1.0
    res = DesignResult(status="failed", settings=s, controller=None, candidate=None,
                       starts=(failed,),
                       best=None, abscissa_speeds_m_s=s.check_speeds(),
                       abscissa_1_s=np.full(s.check_speeds().shape, np.nan),
                       min_flaps=None, wall_time_s=1.0)
    summ = json.loads(json.dumps(res.summary(), allow_nan=False))  # strict JSON
    golden = Path(__file__).resolve().parents[2] / "golden" / "optimise_quick.json"
    # robust_margin_speed_grid only in a design that reached its checks (the golden did), and
    # best_achievable only in one with a best start that is not usable (this one has none; the
    # golden's is usable); the acceptance block is part of every summary (not_run here: the
    # design failed)
    assert set(summ) | {"robust_margin_speed_grid"} == set(
        json.loads(golden.read_text())["stdout"]) | {"wall_time_s"}
    assert summ["usable_speed_m_s"] is None and summ["usable_speed_limited_by"] is None
    assert summ["acceptance"]["status"] == "not_run"
    assert summ["status"] == "failed" and summ["chosen_start"] is None
    assert summ["max_gain"] is None and summ["robust_margin"] is None  # not a number
    assert summ["verification"] == {} and summ["robust_T_inf_by_speed"] == {}
    assert summ["minimum_flaps"] == {"minimum": None, "counts": []}
    assert summ["starts"] == [{"start": 0, "theta0": [0.0] * 5, "status": "failed: x",
                               "success": False, "time_s": 0.5}]
    row = summ["start_table"][0]
    assert (row["status"], row["iterations"], row["cut_rounds"], row["verified"],
            row["chosen"]) == ("failed: x", 0, 0, False, False)


def test_round_layout_keeps_whole_mirror_pairs_within_budget():
    # 5 flaps, 3 groups (outer pair, inner pair, centre): w = S z
    from bridgeflap.design.control.search.driver import round_layout

    S = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 1, 0], [1, 0, 0]], float)
    # budget 3: the inner pair (0.9) and the centre (0.8) fit, the outer pair (0.85) would not
    np.testing.assert_array_equal(round_layout(S, [0.85, 0.9, 0.8], 3), [0, 1, 1, 1, 0])
    # no budget: every group above 0.5
    np.testing.assert_array_equal(round_layout(S, [0.6, 0.2, 0.9]), [1, 0, 1, 0, 1])
    # nothing above 0.5: the largest group is kept (a layout never loses every flap)
    np.testing.assert_array_equal(round_layout(S, [0.1, 0.4, 0.2]), [0, 1, 0, 1, 0])
    # the result is symmetric whatever z is
    w = round_layout(S, [0.3, 0.7, 0.55], 4)
    np.testing.assert_array_equal(w, w[::-1])


def test_placement_budget_constraint_holds(small):
    # relaxed weights with a flap-count budget of 2 (of 5): the solution's weights sum to <= 2
    # (Ipopt constr_viol_tol 1e-6) and stay symmetric (one variable per mirror pair)
    s, model = small
    s2 = replace(s, optimise_placement=True, flap_budget=2, max_iter=15,
                 robust_design_speeds_m_s=(40.0,))
    prob = DesignProblem(s2, model)
    res = prob.solve(THETA, np.array([0.0, 40.0, 70.0]))
    assert res.weights.sum() <= 2.0 + 1e-6
    np.testing.assert_allclose(res.weights, res.weights[::-1], rtol=0, atol=1e-12)


def test_damping_constraint_is_active_when_only_regularised(small_box):
    # objective |theta/scale|^2 only (no robust term): it pulls K towards 0, the open loop
    # (K = 0) flutters at 70 m/s on this model, so the NLP optimum must sit on a damping
    # constraint -- the constraints act (earlier, the decay-rate constraints never did)
    from bridgeflap.design.control.search.driver import (
        ACTIVE_ABS_TOL_1_S,
        active_constraints,
        nlp_active_speeds,
    )

    s, model = small_box
    s2 = replace(s, weight_robust=0.0, max_iter=80)
    prob = DesignProblem(s2, model)
    speeds = s2.design_speeds()
    assert prob.verify(np.array([0.0, 0.0, 0.0, 1e-3, 1e-2])).stable_to_m_s < 85.0
    res = prob.solve(THETA, speeds)
    assert res.success, res.ipopt_status
    act_speeds = nlp_active_speeds(res, speeds, s2.n_eig)
    assert act_speeds, res.constraints_eig_1_s.max()
    assert res.constraints_eig_1_s.max() <= ACTIVE_ABS_TOL_1_S      # and none violated
    rec = StartRecord(start=0, theta0=tuple(THETA), ipopt_status=res.ipopt_status,
                      success=True, time_s=0.0, theta=tuple(res.theta),
                      max_gain=Compensator(*res.theta).max_gain(),
                      nlp_active_speeds_m_s=act_speeds)
    act = active_constraints(s2, rec, prob.verify(res.theta))
    assert act["stability_or_gain_active"]
    assert act["nlp_active_damping_speeds_m_s"] == list(act_speeds)


def test_copies_of_lag_and_compensator_poles_are_excluded(small):
    # the excluded eigenvalues are exactly the fixed copies: -p_i U / b and the roots of
    # a2 s^2 + a1 s + 1; every other eigenvalue is kept
    from bridgeflap.design.control.formulation.eigen import fixed_pole_copies
    from bridgeflap.design.control.formulation.plant import lag_rates

    s, model = small
    prob = DesignProblem(s, model)
    A0, A1, A2, _ = prob.A_parts(THETA)
    U = 40.0
    lam = np.linalg.eigvals(A0 + U * A1 + U * U * A2)
    mask = fixed_pole_copies(lam, lag_rates(model), U, THETA)
    targets = np.concatenate([-lag_rates(model) * U, np.roots([THETA[3], THETA[4], 1.0])])
    dist = np.min(np.abs(lam[:, None] - targets[None, :]) / np.abs(targets[None, :]), axis=1)
    np.testing.assert_array_equal(mask, dist <= 1e-7)
    # 5 flaps on 6 modes: at least the lag states of the modes no load reaches are copies
    assert mask.sum() > 0 and (~mask).sum() >= 2 * model.open_loop.basis.n


def test_peak_tracking_margin_matches_verified_within_one_percent(small_box):
    # robust peak tracking to convergence: the optimiser's margin 1/gamma_T equals the dense
    # sigma_max margin at the check speeds within 1 %. gamma_T bounds the
    # Frobenius norm >= sigma_max, so 1/gamma_T <= the true margin; near a resonance T is
    # nearly rank one and the two meet -- the 1 % is the acceptance tolerance.
    s, model = small_box
    # the default card's re-solve budget (8 rounds of 150 iterations): with 5 x 60, since the
    # model updating, rounds 3-5 end 0.02 % over the gain limit and the kept round's bound
    # does not hold (measured); with 8 x 150 round 4 converges, 0.6045 against 0.6035
    s2 = replace(s, max_iter=60, resolve_max_iter=150, cutting_plane_rounds=8,
                 design_step_m_s=10.0)
    prob = DesignProblem(s2, model)
    res = prob.solve_with_cuts(THETA)
    assert res.robust_bound_holds
    opt = 1.0 / res.solve.gamma_T
    ver = 1.0 / res.robust.peak
    assert opt == pytest.approx(ver, rel=0.01)


def test_symbolic_buffeting_term_matches_numeric_and_is_differentiable(buffeting_problem):
    # the CasADi spectral integral (frozen grid) against model.response.buffeting's adaptive one at
    # the reference design, and its AD gradient against central differences of itself
    from bridgeflap.design.control.formulation.buffeting_term import SymbolicBuffeting
    from bridgeflap.model.response.buffeting import buffeting

    s, spec, model = buffeting_problem
    prob = DesignProblem(s, model, spec=spec)
    sb = SymbolicBuffeting(prob, THETA)
    w1 = np.ones(model.n_flaps)
    sys_cl = model.system(Compensator(*THETA))
    ref = buffeting(sys_cl, list(s.buffeting_speeds_m_s), spec=spec, n_modes=6)
    sys_0 = model.system(Compensator(0.0, 0.0, 0.0, THETA[3], THETA[4]))
    ref0 = buffeting(sys_0, list(s.buffeting_speeds_m_s), spec=spec, n_modes=6)
    ns = ref.strip_x.size
    want = []
    for i, (jv, jt) in enumerate(sb.rows):
        want.append((ref.rms_heave[i, jv] / ref0.rms_heave[i, jv]) ** 2
                    + (ref.rms_pitch[i, jt - ns] / ref0.rms_pitch[i, jt - ns]) ** 2)
    j_num = 0.5 * np.mean(want)
    # frozen coarse grid (n_base 40, 15 points per peak) vs the converged adaptive grid
    # (tolerance 5e-3 on each RMS): ratios of squares agree to ~2 x 2 x 5e-3; 3 % allowed
    assert float(sb(THETA, w1)) == pytest.approx(j_num, rel=0.03)
    th = ca.MX.sym("th", 5)
    g = np.asarray(ca.Function("g", [th], [ca.gradient(sb(th, w1), th)])(THETA).full()).ravel()
    f = lambda p: float(sb(p, w1))  # noqa: E731
    gfd = np.array([(f(THETA + e) - f(THETA - e)) / (2 * 1e-6) for e in np.eye(5) * 1e-6])
    # exact AD vs central differences of the same function: truncation ~h^2 f''' ~ 1e-10,
    # round-off ~eps J / h ~ 1e-10; 1e-6 relative to the largest entry is generous
    np.testing.assert_allclose(g, gfd, rtol=0, atol=1e-6 * np.abs(gfd).max())
    assert np.abs(g).max() > 1e-4


def test_multi_model_design_constrains_every_variant(small_box):
    # two variants of the small humber:box model (Sobol' over the estimated-input ranges,
    # half-chord held): the NLP carries one damping block per model, and a short solve_with_cuts
    # reports feasibility only when every variant's dense check meets zeta_min
    from bridgeflap.design.control.search.driver import sample_variants
    from bridgeflap.model.structure.loader import load_bridge

    s, model = small_box
    s2 = replace(s, max_iter=30, resolve_max_iter=20, cutting_plane_rounds=1,
                 design_step_m_s=10.0, weight_robust=0.0, variant_speeds="all")
    base = load_bridge(s2.bridge)
    specs = sample_variants(s2, base, 2, s2.variant_seed)
    assert len(specs) == 2 and all(v.deck.half_chord_m == base.deck.half_chord_m for v in specs)
    assert specs[0].deck.gj_nm2 != base.deck.gj_nm2
    prob = DesignProblem(s2, model, spec=base)
    prob.variants = [DesignProblem(s2, build_model(s2, spec=v)[1], spec=v) for v in specs]
    res = prob.solve(THETA, s2.design_speeds())
    n = len(s2.design_speeds()) * s2.n_eig
    assert len(res.constraints_eig_1_s) == n          # the nominal block is reported
    # every variant's damping block was evaluated by Ipopt (its own callback, same grid)
    key = tuple(float(u) for u in s2.design_speeds())
    assert all(q.callbacks[key].evaluations > 0 for q in prob.variants)
    if res.success:     # a converged solve is feasible on every variant's design grid
        for q in prob.variants:
            assert np.max(q.constraint_values(res.theta, s2.design_speeds())) <= 1e-6


def test_closed_loop_limits_reported_with_mechanism(small_box):
    # the reported limits are model.analysis.closed_loop_flutter's, searched to 2 x 85 m/s,
    # and the governing one is the lower of the sweep's critical speed and the static check
    from bridgeflap.design.control.search.driver import closed_loop_limits
    from bridgeflap.model.analysis import closed_loop_flutter
    from bridgeflap.model.structure.loader import load_bridge

    s, model = small_box
    ctrl = Controller(Compensator(*THETA), tuple(s.positions()), s.flap_width_m)
    lim = closed_loop_limits(s, ctrl)
    grid = np.arange(0.0, 170.0001, 0.5)
    ref = closed_loop_flutter(load_bridge(s.bridge), ctrl, grid, n_modes=6,
                              sweep_method="fast").summary()
    dense = closed_loop_flutter(load_bridge(s.bridge), ctrl, grid, n_modes=6).summary()
    assert lim["searched_to_m_s"] == 170.0 and lim["modes"] == 6
    for k in ("flutter_speed_m_s", "divergence_speed_m_s", "divergence_static_speed_m_s"):
        assert lim[k] == ref[k] or (np.isnan(lim[k]) and np.isnan(ref[k]))
        # the fast path (the limits' method) against the dense reference sweep: 1e-4
        # relative, the required agreement (both refine to round-off / 1e-3 m/s)
        assert (np.isnan(ref[k]) and np.isnan(dense[k])) or \
            abs(ref[k] - dense[k]) <= 1e-4 * abs(dense[k])
    for k in ("flutter_status", "divergence_status", "critical_mechanism"):
        assert ref[k] == dense[k]
    assert lim["flutter_status"] in ("converged", "no_crossing_in_range", "bracket_failed",
                                     "unstable_at_first_speed")
    cands = [v for v in (ref["critical_speed_m_s"], ref["divergence_static_speed_m_s"])
             if np.isfinite(v)]
    assert lim["governing_speed_m_s"] == min(cands)
    assert lim["governing_mechanism"] in ("flutter", "divergence", "divergence (static)")


@pytest.mark.slow
def test_b1425_with_5m_flaps_is_stable_to_85(tmp_path):
    # the built-in b = 14.25 m Humber with 5 m flaps (design/studies/humber_b1425_flaps5m.toml,
    # one start): stable 0..85 m/s on the 16-mode model (0.25 m/s grid) with the closed-loop
    # limit above 85 m/s and the gain limit met (3 m flaps: no such K found, the golden case)
    from pathlib import Path

    from bridgeflap.design.control.search.driver import design

    card = Path(__file__).resolve().parents[3] / "design" / "studies" / "humber_b1425_flaps5m.toml"
    s = load_settings(card, starts=1, parallel=False)
    assert s.bridge == "humber" and s.flap_chord_m == 5.0
    res = design(s, progress_bar=False)
    d = res.summary()
    assert d["verification"]["stable_everywhere"] and d["closed_loop_stable_to_m_s"] == 85.0
    assert d["closed_loop_limits"]["governing_speed_m_s"] > 85.0
    assert d["max_gain"] <= 15.0


def test_iteration_callback_history_and_warm_start(small_box):
    # the Ipopt iteration callback fires once per iteration (and once for iteration 0), the
    # saved history has one entry per call, and a warm start is parsed from a Controller
    from bridgeflap.design.control.search.driver import warm_start_theta

    s, model = small_box
    prob = DesignProblem(replace(s, max_iter=6), model)
    seen = []
    prob.on_iteration = lambda i, f, x: seen.append((i, f))
    res = prob.solve(THETA, np.array([0.0, 40.0, 80.0]))
    assert len(seen) == res.iterations + 1
    assert len(res.history["obj"]) == len(seen)
    assert [f for _, f in seen] == pytest.approx(res.history["obj"], rel=1e-12)
    ctrl = Controller(Compensator(*THETA), tuple(s.positions()), s.flap_width_m)
    np.testing.assert_array_equal(warm_start_theta(ctrl), THETA)
    np.testing.assert_array_equal(warm_start_theta(ctrl.compensator), THETA)
    with pytest.raises(BridgeflapInputError, match="warm_start"):
        warm_start_theta([1.0, 2.0])


def test_pareto_points_are_each_verified(small_box):
    # K re-optimised per count; each point's "verified" is recomputed here from an
    # independent dense check of its own theta on its own layout (damping, gain, stability)
    from bridgeflap.design.control.search.driver import flap_count_pareto, verify_layout

    s, _ = small_box
    s2 = replace(s, max_iter=40, resolve_max_iter=20, cutting_plane_rounds=1,
                 design_step_m_s=10.0)
    out = flap_count_pareto(s2, THETA, counts=[5, 3])
    assert [p["flap_count"] for p in out["points"]][:1] == [5]
    for p in out["points"]:
        ver = verify_layout(s2, np.array(p["theta"]), s2.positions(p["flap_count"]))
        ok = ver.meets_damping and ver.max_gain <= s2.gain_limit and ver.stable_everywhere
        assert p["verified"] == ok
        assert np.isfinite(p["robust_margin"])
    good = [p["flap_count"] for p in out["points"] if p["verified"]]
    assert out["minimum_verified"] == (min(good) if good else None)


@pytest.mark.slow
def test_closed_loop_limits_fast_path_on_the_default_design():
    # the default card's design on its 30-mode verification model (230 states): the fast
    # sweep of the closed-loop limits against the dense reference sweep, 1e-4 relative (the
    # required agreement), the same statuses and mechanism
    from bridgeflap.design.cli.optimise import DEFAULT_DEFINITION
    from bridgeflap.model.analysis import closed_loop_flutter
    from bridgeflap.model.structure.loader import load_bridge

    s = load_settings(DEFAULT_DEFINITION)
    # the default card's design (built-in b = 14.25 m, 18 placed pairs, README
    # "Control": closed-loop flutter 107.42 m/s, static divergence 87.33 m/s on 30 modes)
    positions = tuple(56.4 * i for i in range(-12, 13) if abs(i) >= 4)
    ctrl = Controller(Compensator(-1.0520215923792988, 0.724204088492299, -4.9906722869878095,
                                  0.24572479364985136, 0.19628837741003988), positions,
                      s.flap_width_m, flap_chord_m=s.flap_chord_m)
    grid = np.arange(0.0, 170.0001, 0.5)
    out = {m: closed_loop_flutter(load_bridge(s.bridge), ctrl, grid, n_modes=30,
                                  sweep_method=m).summary() for m in ("fast", "dense")}
    f, d = out["fast"], out["dense"]
    assert d["flutter_status"] == "converged" and 100.0 < d["flutter_speed_m_s"] < 115.0
    assert abs(f["flutter_speed_m_s"] - d["flutter_speed_m_s"]) <= 1e-4 * d["flutter_speed_m_s"]
    for k in ("flutter_status", "divergence_status", "critical_mechanism"):
        assert f[k] == d[k]


def test_lazy_variant_constraints_meet_every_variant(small_box):
    # design.control.formulation.variants: the lazy (variant, speed) sets carry fewer damping
    # constraints than the full multi-model NLP ("all": every variant at every design speed), and
    # the lazy loop reaches a design that meets zeta_min on the nominal bridge and on every
    # variant's dense check -- the constraints left out are verified, not assumed. The loop's own
    # test (the refined check) gives the dense check's maximum violation on every variant.
    from bridgeflap.design.control.formulation.nlp_tolerances import VIOLATION_TOL
    from bridgeflap.design.control.search.driver import sample_variants
    from bridgeflap.model.structure.loader import load_bridge

    s, model = small_box
    base = load_bridge(s.bridge)
    out = {}
    for mode in ("lazy", "all"):
        s2 = replace(s, max_iter=40, resolve_max_iter=40, cutting_plane_rounds=4,
                     design_step_m_s=10.0, weight_robust=0.0, weight_buffeting=0.0,
                     variant_speeds=mode)
        specs = sample_variants(s2, base, 3, s2.variant_seed)
        prob = DesignProblem(s2, model, spec=base)
        prob.variants = [DesignProblem(s2, build_model(s2, spec=v)[1], spec=v) for v in specs]
        res = prob.solve_with_cuts(THETA)
        out[mode] = (res, res.rounds[res.chosen_round].n_variant_constraints, prob)
    res, n_lazy, prob = out["lazy"]
    assert res.verification.meets_damping
    for q in prob.variants:
        dense = q.verify(res.solve.theta)
        assert dense.max_violation_1_s <= VIOLATION_TOL
        # the refined subset keeps the dense maximum
        # (design.control.formulation.plant.damping_check_refined)
        assert q.verify(res.solve.theta, refined=True).max_violation_1_s == pytest.approx(
            dense.max_violation_1_s, rel=1e-12, abs=1e-15)
    assert n_lazy <= sum(len(v.lazy_speeds) for v in prob.variants)
    res_all, n_all, _ = out["all"]
    assert n_all == 3 * len(res_all.design_speeds_m_s)
    assert 0 < n_lazy < n_all


def test_design_cards_load_and_the_multimodel_card_is_the_default_plus_variants():
    # every packaged card validates (a card broken by a renamed setting fails here, not in a
    # user's run), and the multi-model card's header claim holds: the default design with
    # the variants switched on, nothing else changed
    from dataclasses import asdict
    from pathlib import Path

    cards = [c for c in sorted((Path(__file__).resolve().parents[3] / "design"
                                / "studies").glob("*.toml"))
             if c.read_text(encoding="utf-8").startswith("# bridgeflap optimise")]
    assert len(cards) >= 4
    loaded = {c.name: load_settings(c) for c in cards}
    # the humber:box card, the default when the multi-model card was made (the default card is
    # now on the built-in b = 14.25 m bridge; the multi-model card keeps humber:box)
    default = asdict(loaded["humber_box_flaps.toml"])
    multi = asdict(loaded["humber_flaps_multimodel.toml"])
    diff = {k for k in default if default[k] != multi[k]}
    assert diff == {"variants", "fresh_variants"}
    assert multi["variants"] >= 8 and multi["variant_speeds"] == "lazy"
