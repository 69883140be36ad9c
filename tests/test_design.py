"""Compensator design (design/problem.py): settings, derivatives, a real Humber design (slow)."""

from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from design.problem import (
    DesignProblem,
    _build_model,
    load_settings,
    plant_factors,
    robust_point_function,
    true_t_peak,
)
from model.control import Compensator, Controller
from model.errors import BridgeflapInputError

THETA = np.array([0.3, 0.25, -1.5, 0.08, 0.5])


@pytest.fixture(scope="module")
def small():
    # Humber, 6 modes, 5 flap pairs: the same code paths as the full design, small matrices
    s = load_settings(n_modes=6, flap_count=5, robust_design_speeds_m_s=(30.0, 60.0),
                      n_robust_omega=8)
    spec, model = _build_model(s)
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
    from design.cli import main

    f = tmp_path / "d.toml"
    f.write_text("gain_limit = -1.0\n")
    out = tmp_path / "out"
    assert main(["optimise", str(f), "--out", str(out), "--json"]) == 2
    assert not out.exists()


def test_packaged_definition_loads():
    from pathlib import Path

    from model.analysis import DEFAULT_MODES

    s = load_settings(Path(__file__).resolve().parents[1] / "runs" / "humber_flaps.toml")
    assert s.flap_count == 25 and s.gain_limit == 15.0
    assert s.flap_count * s.flap_width_m == pytest.approx(1410.0)
    # the controller is designed and verified on the model `bridgeflap flutter` uses
    assert s.n_modes == DEFAULT_MODES and s.verification_modes == DEFAULT_MODES
    # touching strips are a valid Controller layout (no nudged pitch needed)
    Controller(Compensator(*THETA), tuple(s.positions()), s.flap_width_m)


def test_plant_factors_vanish_at_closed_loop_poles(small):
    # (c) cross-method: G(s) = Phi_a X(s) is the transfer function of the RFA state space,
    # so det(I - K(lambda) G(lambda)) = 0 at every closed-loop eigenvalue lambda that is not
    # an open-loop one. Smallest singular value vs ~1 elsewhere: round-off of the solves.
    s, model = small
    A = model.system(Compensator(*THETA)).A(50.0)
    lam = np.linalg.eigvals(A)
    lam = lam[np.argsort(-np.abs(lam.imag))][:4]          # oscillatory (structural) poles
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
    # (d) eigenvalue constraints with free flap weights: d Re lambda / d(theta, w)
    s, model = small
    prob = DesignProblem(replace(s, optimise_placement=True), model)
    cb = prob.grid_callback([0.0, 40.0, 70.0])
    p0 = np.concatenate([THETA, [1.0, 0.8, 0.6, 0.9, 0.7]])
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
    assert isinstance(res["status"], str)
    assert np.all((res["weights"] >= -1e-8) & (res["weights"] <= 1 + 1e-8))


@pytest.mark.slow
def test_humber_design_stable_on_16_modes(tmp_path, capsys):
    # The packaged design (16 modes, 2 starts, cutting planes) through the CLI: stable on the
    # 16-mode model of `bridgeflap flutter` at every 0.25 m/s speed 0..85 m/s, gain <= 15,
    # every start's Ipopt status reported.
    import json

    from design.cli import main
    from model.analysis import DEFAULT_MODES
    from model.control import load_controller
    from model.flaps import closed_loop_flutter
    from model.spec import load_bridge

    out = tmp_path / "opt"
    assert main(["optimise", "--out", str(out), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["status"] == "converged"
    assert len(payload["starts"]) == 2
    assert all(isinstance(st["status"], str) and st["status"] for st in payload["starts"])
    assert payload["verification"]["modes"] == DEFAULT_MODES
    ctrl = load_controller(out / "controller.toml")
    # 1e-9 relative: the reported sup is a root-polished stationary point
    assert ctrl.compensator.max_gain() <= 15.0 * (1 + 1e-9)
    res = closed_loop_flutter(load_bridge("humber"), ctrl, np.arange(0.0, 85.0001, 0.25),
                              n_modes=DEFAULT_MODES)
    summ = res.summary()
    assert summ["flutter_status"] == "no_crossing_in_range"
    assert summ["divergence_status"] == "no_crossing_in_range"
    s = load_settings()
    prob = DesignProblem(s, _build_model(s, positions=ctrl.flap_strip_positions_m)[1])
    theta = np.array([getattr(ctrl.compensator, n) for n in ("b2", "b1", "b0", "a2", "a1")])
    ver = prob.verify(theta)
    assert ver["modes"] == DEFAULT_MODES and ver["step_m_s"] == 0.25
    assert ver["stable_everywhere"] and ver["stable_to_m_s"] == 85.0
    assert ver["max_violation"] <= 1e-6      # the decay rate too (VIOLATION_TOL)
    # the reported margin is the true sigma_max one, and the open loop really flutters
    assert payload["robust_margin"] == pytest.approx(prob.robust_margin(theta)["margin"],
                                                     rel=1e-9)
    assert summ["open_loop_flutter_speed_m_s"] < 70.0
