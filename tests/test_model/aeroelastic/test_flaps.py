"""Flap loads and closed-loop assembly (model/aeroelastic/flaps.py). Sources:
docs/humber_data.md#flap-loads-and-t-functions, TR-496."""

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from bridgeflap.model.aero.strips import flap_section_loads
from bridgeflap.model.aero.theodorsen import flap_steady_coefficients
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.aeroelastic.flaps import (
    closed_loop_model,
    closed_loop_system,
    section_model,
)
from bridgeflap.model.cases.section import section_basis
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.stability.pk import closed_loop_pk_flutter
from bridgeflap.model.stability.sweeps import sweep
from bridgeflap.model.structure.loader import load_bridge

B, RHO, CHORD = 11.0, 1.225, 3.0
C_HINGE = (B - CHORD) / B


@pytest.fixture(scope="module")
def humber_model():
    spec = load_bridge("humber")
    pos = (np.arange(5) - 2.0) * 56.4
    return closed_loop_model(spec, pos, 56.4, n_modes=6)


def test_steady_limits_match_thin_aerofoil():
    # (a) analytic: dC_L/dbeta = 2 T10, dC_M,mid = -T4/2 (TE) and 2(theta - sin theta),
    # pi/2 + T4(e)/2 (LE); independent formulas in model.aero.theodorsen, round-off only.
    te = flap_section_loads(B, RHO, CHORD, leading_edge=False).steady(RHO, B)
    le = flap_section_loads(B, RHO, CHORD, trailing_edge=False).steady(RHO, B)
    ref_te = flap_steady_coefficients(C_HINGE, "trailing")
    ref_le = flap_steady_coefficients(-C_HINGE, "leading")
    np.testing.assert_allclose(te, ref_te, rtol=1e-12)
    np.testing.assert_allclose(le, ref_le, rtol=1e-12)
    # docs/humber_data.md#flap-loads-and-t-functions check table (4 digits quoted)
    np.testing.assert_allclose(te, (2.886, 0.129), atol=6e-4)
    np.testing.assert_allclose(le, (0.140, 0.129), atol=6e-4)


def test_antisymmetric_pair_is_moment_dominated():
    # LE by -K (LE-down positive) and TE by +K: same rotational sense, so the steady mid-chord
    # moments add (equal for e = -c, docs/humber_data.md#flap-loads-and-t-functions) while the LE
    # flap adds only 5 % lift.
    pair = flap_section_loads(B, RHO, CHORD).steady(RHO, B)
    te = flap_section_loads(B, RHO, CHORD, leading_edge=False).steady(RHO, B)
    le = flap_section_loads(B, RHO, CHORD, trailing_edge=False)
    assert pair[1] == pytest.approx(2 * te[1], rel=1e-12)
    assert pair[0] == pytest.approx(te[0] + le.steady(RHO, B)[0], rel=1e-12)
    assert pair[1] / pair[0] > 1.9 * te[1] / te[0]
    # the mirror-symmetric drive (both tips down together) has zero steady moment
    sym = (flap_section_loads(B, RHO, CHORD, leading_edge=False) + le.scaled(-1.0)).steady(RHO, B)
    assert abs(sym[1]) < 1e-12


def test_flap_chord_outside_deck_rejected():
    with pytest.raises(BridgeflapInputError, match="flap_chord_m"):
        flap_section_loads(B, RHO, 12.0)


def test_flap_outside_main_span_rejected():
    spec = load_bridge("humber")
    with pytest.raises(BridgeflapInputError, match="controller.flap_strip_positions_m"):
        closed_loop_model(spec, [700.0], 56.4, n_modes=2)


def test_zero_flap_weights_give_open_loop_exactly(humber_model):
    ol = humber_model.open_loop
    k = Compensator(0.5, 2.0, 3.0, 0.05, 0.3)
    cl = humber_model.system(k, weights=np.zeros(humber_model.n_flaps))
    n = ol.n_states
    for U in (0.0, 30.0, 70.0):
        A = cl.A(U)
        # same formulas, solve vs inverse: round-off of the 1e4-sized entries only
        np.testing.assert_allclose(A[:n, :n], ol.A(U), rtol=0, atol=1e-10 * np.abs(A).max())
        assert np.all(A[:n, n:] == 0.0)


def test_zero_compensator_gives_open_loop_plus_compensator_poles(humber_model):
    k = Compensator(0.0, 0.0, 0.0, 0.05, 0.3)
    cl = humber_model.system(k)
    ol = humber_model.open_loop
    poles = np.roots([k.a2, k.a1, 1.0])
    U = 60.0
    expect = np.concatenate([np.linalg.eigvals(ol.A(U)), np.tile(poles, humber_model.n_flaps)])
    got = np.linalg.eigvals(cl.A(U))
    rows, cols = linear_sum_assignment(np.abs(expect[:, None] - got[None, :]))
    # repeated compensator poles (5-fold, non-defective) move by round-off only
    np.testing.assert_allclose(got[cols], expect[rows], atol=1e-6)


def test_casadi_function_matches_numeric_assembly(humber_model):
    th = [0.5, 2.0, 3.0, 0.05, 0.3]
    A_cl = humber_model.casadi_functions()["A_cl"]
    A = A_cl(45.0, th, np.ones(humber_model.n_flaps)).full()
    ref = humber_model.system(Compensator(*th)).A(45.0)
    np.testing.assert_allclose(A, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_eigenvalue_constraint_gradient_matches_finite_differences(humber_model):
    from bridgeflap.design.control.formulation.eigen import PolynomialTopRealParts

    A_parts = humber_model.casadi_functions()["A_parts"]
    p = ca.SX.sym("p", 5)
    parts = ca.Function("A_p", [p], list(A_parts(p, np.ones(humber_model.n_flaps))))
    cb = PolynomialTopRealParts(parts, [55.0], 3)
    th = np.array([0.02, 0.3, -1.0, 0.05, 0.4])
    J = cb.jacobian(th)
    h = 1e-6
    for k in range(5):
        e = np.zeros(5)
        e[k] = h * max(1.0, abs(th[k]))
        fd = (cb._plain_values(th + e) - cb._plain_values(th - e)) / (2 * e[k])
        # central differences: O(h^2) truncation + eps/h round-off ~ 1e-9 of |J| ~ 1e-2..1
        np.testing.assert_allclose(J[:, k], fd, rtol=1e-5, atol=1e-7)


def test_closed_loop_flutter_matches_pk_with_exact_theodorsen():
    # 2-DOF Humber-like section with one flap strip and a deliberately weak controller that
    # still flutters. The RFA fits C(k) to 0.0032
    # (docs/humber_data.md#lift-deficiency-approximations), which moves the flutter speed by ~0.1
    # %; 0.3 % is the tolerance.
    basis = section_basis(7660.0, 3.75e5, 0.116, 0.30, B, 0.005)
    m = section_model(basis, B, RHO, CHORD)
    k = Compensator(0.05, -1.0, -1.0, 0.05, 0.3)
    sw = sweep(m.system(k), np.linspace(0, 150, 301))
    u_pk, f_pk, status, _ = closed_loop_pk_flutter(m, k, np.linspace(0, 150, 151))
    assert sw.flutter.status == "converged" and status == "converged"
    open_loop = sweep(m.system(Compensator(0, 0, 0, 0.05, 0.3)), np.linspace(0, 150, 301))
    assert sw.flutter.speed > open_loop.flutter.speed + 2.0   # the controller does something
    assert sw.flutter.speed == pytest.approx(u_pk, rel=3e-3)
    assert sw.flutter.frequency_hz == pytest.approx(f_pk, rel=3e-3)


def test_closed_loop_system_interface():
    spec = load_bridge("humber")
    ctrl = Controller(Compensator(0.0, 0.1, -0.5, 0.01, 0.2), (-56.4, 0.0, 56.4), 56.4)
    cl = closed_loop_system(spec, ctrl, n_modes=4)
    assert cl.A(30.0).shape == (cl.n_states, cl.n_states)
    assert cl.B_gust(30.0).shape[0] == cl.n_states
    assert cl.C_out.shape[1] == cl.n_states
    assert cl.n_states == cl.basis.n * 2 + 4 * cl.basis.n + 2 * 3
    assert cl.index.compensator == slice(cl.n_states - 6, cl.n_states)


def test_cli_bad_controller_exit_2(tmp_path):
    from bridgeflap.design.cli.main import main

    bad = tmp_path / "c.toml"
    bad.write_text("b2 = 1.0\nb1 = 0.0\nb0 = 0.0\na2 = 0.0\na1 = 0.3\n"
                   "flap_strip_positions_m = [0.0]\nflap_width_m = 56.4\n")
    assert main(["flutter", "--controller", str(bad), "--json"]) == 2
    bad.write_text("b2 = 0.0\nb1 = 0.0\nb0 = 1.0\na2 = 0.1\na1 = 0.3\n"
                   "flap_strip_positions_m = [700.0]\nflap_width_m = 56.4\n")
    assert main(["flutter", "--controller", str(bad), "--modes", "2", "--json"]) == 2
