"""The one assembly (model/aeroelastic/assembly.py, model/aeroelastic/backend.py): one physics path,
two numerics.

Kinds of test (STYLE.md): (b) invariants of the closures, (c) cross-method agreement (the
numeric matrices against the named CasADi functions built by the same code; the frozen-C
matrix against the RFA state space; closed-loop p-k against open-loop p-k), and the import
boundary (CasADi in at most two files of model/).
"""

import ast
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from bridgeflap.model.aeroelastic.assembly import dynamic_matrices
from bridgeflap.model.aeroelastic.control import Compensator
from bridgeflap.model.aeroelastic.flaps import closed_loop_model, section_model
from bridgeflap.model.aeroelastic.statespace import build
from bridgeflap.model.aeroelastic.symbolic import build_symbolic
from bridgeflap.model.analysis import bridge_system
from bridgeflap.model.cases.section import section_basis
from bridgeflap.model.stability.pk import closed_loop_pk_flutter
from bridgeflap.model.stability.sweeps import pk_sweep

ROOT = Path(__file__).resolve().parents[3]
THETA = (0.5, 2.0, 3.0, 0.05, 0.3)
B, RHO, CHORD = 11.0, 1.225, 3.0


@pytest.fixture(scope="module")
def humber(coarse_humber):
    return coarse_humber


@pytest.fixture(scope="module")
def flap_model(humber):
    return closed_loop_model(humber, (np.arange(3) - 1.0) * 56.4, 56.4, n_modes=6)


def _matched(l1, l2):
    cost = np.abs(l1[:, None] - l2[None, :])
    r, c = linear_sum_assignment(cost)
    return cost[r, c].max()


def _rel(a, b):
    return np.abs(np.asarray(a) - np.asarray(b)).max() / np.abs(np.asarray(b)).max()


# ------------------------------------------------------------------ numeric vs CasADi, same code
@pytest.mark.parametrize("speed", [0.0, 35.0, 70.0])
def test_open_loop_numeric_equals_casadi_function(humber, speed):
    # same algebra through the backend shim, numpy vs SX evaluation: round-off only (1e-12)
    _, system = bridge_system(humber, 6)
    sm = build_symbolic(humber, 6)
    assert _rel(sm.A(speed), system.A(speed)) <= 1e-12
    assert _rel(np.array(sm.B_fun(speed + 1.0, np.ones(8))), system.B_gust(speed + 1.0)) <= 1e-12


@pytest.mark.parametrize("speed", [0.0, 45.0])
def test_closed_loop_numeric_equals_casadi_functions(flap_model, speed):
    w = np.array([1.0, 0.4, 0.8])
    fns = flap_model.casadi_functions()
    ref = flap_model.system(Compensator(*THETA), weights=w)
    assert _rel(fns["A_cl"](speed, THETA, w).full(), ref.A(speed)) <= 1e-12
    parts = [a.full() for a in fns["A_parts"](THETA, w)]
    for got, want in zip(parts, (ref.A0, ref.A1, ref.A2), strict=True):
        assert np.abs(got - want).max() <= 1e-12 * max(np.abs(want).max(), 1.0)
    assert _rel(fns["B_gust"](speed + 1.0, THETA, w).full(), ref.B_gust(speed + 1.0)) <= 1e-12


# ------------------------------------------------------------------ frozen-C form vs state space
def test_frozen_matrix_at_rfa_value_reproduces_state_space_eigenvalues(flap_model):
    # An eigenvalue p of the RFA state space solves the frozen-C equations with C = RFA(p b/U)
    # exactly (the lag states are eliminated analytically), open and closed loop. The check is
    # the smallest singular value of (frozen(U, C) - p I) relative to |frozen|: ~1e-12 for a
    # simple eigenvalue of a 30-50 state matrix; 1e-9 leaves margin for conditioning.
    U = 40.0
    b = flap_model.open_loop.aero.half_chord
    for system in (flap_model.open_loop, flap_model.system(Compensator(*THETA))):
        frozen = system.frozen()
        lam = np.linalg.eigvals(system.A(U))
        osc = lam[(lam.imag > 0.5) & (lam.imag < 5.0)]
        assert osc.size >= 4
        for p in osc:
            F = frozen.matrix(U, system.rfa.evaluate_s(p * b / U)) - p * np.eye(frozen.A0.shape[0])
            smin = np.linalg.svd(F, compute_uv=False)[-1]
            assert smin <= 1e-9 * np.abs(F).max()


def test_dynamic_matrix_determinant_vanishes_at_state_space_eigenvalue(humber):
    # open loop: det D(p) = 0 with C = RFA(p b / U) at an eigenvalue p of A(U) (second-order
    # frozen-C form of model.aeroelastic.assembly.dynamic_matrices)
    _, system = bridge_system(humber, 6)
    U = 50.0
    b = system.aero.half_chord
    lam = np.linalg.eigvals(system.A(U))
    for p in lam[(lam.imag > 0.5) & (lam.imag < 5.0)]:
        D, F = dynamic_matrices(system.pieces, U, p, system.rfa.evaluate_s(p * b / U))
        assert F is None
        smin = np.linalg.svd(D, compute_uv=False)[-1]
        assert smin <= 1e-9 * np.abs(D).max()


def test_closed_loop_pk_with_zero_compensator_equals_open_loop_pk():
    # K = 0: the compensator states are decoupled (their poles are separate eigenvalues), so
    # every structural branch and the flutter speed equal the open-loop p-k (same routine,
    # same tolerances: the branches agree to the p-k iteration tolerance 1e-10 relative).
    basis = section_basis(7660.0, 3.75e5, 0.116, 0.30, B, 0.005)
    m = section_model(basis, B, RHO, CHORD)
    speeds = np.linspace(0.0, 150.0, 76)
    k0 = Compensator(0.0, 0.0, 0.0, 0.05, 0.3)
    u_cl, f_cl, status, branches = closed_loop_pk_flutter(m, k0, speeds, speed_tol=1e-3)
    ol = pk_sweep(m.open_loop, speeds)
    assert status == ol.flutter.status == "converged"
    assert u_cl == pytest.approx(ol.flutter.speed, rel=1e-8)
    assert f_cl == pytest.approx(ol.flutter.frequency_hz, rel=1e-8)
    np.testing.assert_allclose(branches, ol.branches, rtol=1e-8, atol=1e-10)


def test_full_order_matches_modal_order_spectrum(humber):
    # the two lag placements of the one assembly: identical spectra when all strips share b
    _, modal = bridge_system(humber, 4)
    full = build(modal.basis, modal.aero.half_chord, modal.aero.air_density, order="full")
    lm = np.linalg.eigvals(modal.A(45.0))
    lf = np.linalg.eigvals(full.A(45.0))
    structural = lm[np.abs(lm.imag) > 0.1]
    d = np.min(np.abs(structural[:, None] - lf[None, :]), axis=1)
    assert d.max() <= 1e-8 * np.abs(lm).max()


# ------------------------------------------------------------------ flap-loop plant
def test_plant_closes_to_the_closed_loop_state_space(flap_model):
    # G(s) = Pa X(s) (frozen-C form with C = RFA(s b/U)) is the exact flap-loop plant of the
    # RFA state space, so every closed-loop eigenvalue p that the flaps move (not an open-loop
    # eigenvalue: modes with no pitch at the flaps stay put) and that is not a compensator pole
    # is a zero of det(I - K(p) G(p)): beta = K alpha_f and alpha_f = G beta. The relative
    # smallest singular value is ~1e-11 (eigenvalue round-off times |dG/ds|); 1e-7 is margin.
    U = 30.0
    comp = Compensator(*THETA)
    lam = np.linalg.eigvals(flap_model.system(comp).A(U))
    open_loop = np.linalg.eigvals(flap_model.open_loop.A(U))
    poles = np.roots([comp.a2, comp.a1, 1.0])
    struct = [p for p in lam if 0.5 < p.imag < 5.0 and np.min(np.abs(p - poles)) > 1.0
              and np.min(np.abs(p - open_loop)) > 1e-6]
    assert len(struct) >= 3
    Pa, X = flap_model.plant(U, struct)
    for i, p in enumerate(struct):
        K = (comp.b2 * p * p + comp.b1 * p + comp.b0) / (comp.a2 * p * p + comp.a1 * p + 1.0)
        M = np.eye(Pa.shape[0]) - K * (Pa @ X[i])
        sv = np.linalg.svd(M, compute_uv=False)
        assert sv[-1] <= 1e-7 * sv[0]


def _reference_plant_factors(model, U, s):
    """The flap-loop plant written out independently (the pre-assembly numpy code of the
    design problem, kept here as the reference): ``D(s) q = F(s) beta`` with the RFA's C."""
    ol, fl = model.open_loop, model.flaps
    B, a, rfa = ol.basis, ol.aero, ol.rfa
    b, rho = a.half_chord, a.air_density
    sc = fl.width_m
    ld = fl.loads
    Hk = [(fl.phi_h.T * e[0] + fl.phi_a.T * e[1]) * sc for e in (ld.e0, ld.e1, ld.e2)]
    PF = (-2 * np.pi * rho * b * fl.phi_h.T + np.pi * rho * b * b * fl.phi_a.T) * sc
    s = np.atleast_1d(np.asarray(s, complex))
    X = np.zeros((len(s), B.n, fl.n_flaps), complex)
    Mt = B.M + a.M_nc
    for i, p in enumerate(s):
        sbar = p * b / U if U > 0 else 0.0
        C = 1.0 - np.sum(rfa.gains * sbar / (sbar + rfa.poles)) if U > 0 else 1.0
        D = p * p * Mt + p * (B.C + U * a.D_nc) + B.K - U * C * a.P @ (p * a.G1 + U * a.G0)
        F = (p * p * Hk[2] + U * p * Hk[1] + U * U * Hk[0]
             + U * C * PF * (U * ld.g0 + b * ld.g1 * p))
        X[i] = np.linalg.solve(D, F)
    return np.asarray(fl.phi_a, float), X


def test_plant_equals_independent_reference(flap_model):
    """Assembly plant vs the independently written reference: same matrices, so 1e-12."""
    s = 1j * np.linspace(0.1, 4.0, 7)
    for U in (0.0, 25.0):
        Pa, X = flap_model.plant(U, s)
        Pa2, X2 = _reference_plant_factors(flap_model, U, s)
        assert np.array_equal(Pa, Pa2)
        np.testing.assert_allclose(X, X2, rtol=1e-12, atol=1e-12 * np.abs(X2).max())


def test_closed_loop_abscissa_from_casadi_parts_equals_numeric(flap_model):
    """The CasADi closed-loop parts and the numeric closed loop give one abscissa (1e-10)."""
    import scipy.linalg

    from bridgeflap.model.aeroelastic.symbolic import closed_loop_functions

    speeds = np.array([0.0, 20.0, 60.0])
    comp = Compensator(*THETA)
    got = flap_model.abscissa(comp, speeds)
    parts = [a.full() for a in closed_loop_functions(flap_model)["A_parts"](THETA, np.ones(3))]
    keep = np.ones(parts[0].shape[0], bool)
    keep[flap_model.open_loop.index.aero_lag] = False
    keep0 = np.flatnonzero(keep)
    want = []
    for u in speeds:
        A = parts[0] + u * parts[1] + u * u * parts[2]
        A = A[np.ix_(keep0, keep0)] if u == 0 else A
        want.append(np.max(scipy.linalg.eigvals(A).real))
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-12)


# ------------------------------------------------------------------ the import boundary
def _casadi_importers(folder: Path) -> list[str]:
    out = []
    for path in sorted(folder.rglob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            if any(n == "casadi" or n.startswith("casadi.") for n in names):
                out.append(path.relative_to(folder).as_posix())
                break
    return out


def test_casadi_imported_in_at_most_two_model_files():
    assert _casadi_importers(ROOT / "model") == ["aeroelastic/backend.py",
                                                 "aeroelastic/symbolic.py"]


def test_ruff_banned_api_rule_rejects_casadi_elsewhere_in_model(tmp_path):
    ruff = pytest.importorskip("ruff")
    del ruff
    probe = ROOT / "model" / "_casadi_probe_for_test.py"
    probe.write_text("import casadi  # noqa: F401\n")
    try:
        res = subprocess.run(["ruff", "check", "--no-cache", "--select", "TID251", str(probe)],
                             cwd=ROOT, capture_output=True, text=True)
    finally:
        probe.unlink()
    assert res.returncode == 1 and "TID251" in res.stdout


def test_model_never_imports_its_facade_from_below():
    # model/analysis.py is the facade on top: nothing below imports it, eagerly or lazily
    for path in sorted((ROOT / "model").glob("*.py")):
        if path.name == "analysis.py":
            continue
        tree = ast.parse(path.read_text())
        mods = [n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
        assert "bridgeflap.model.analysis" not in mods, path.name


@pytest.mark.parametrize("b0", [0.0, 0.3, -0.3, 1.0])
def test_closed_loop_static_divergence_includes_the_compensator(b0):
    # Cross-method: the static check det(K - U^2 Q) = 0 with the static flap loads of
    # beta = K(0) alpha equals the real eigenvalue crossing zero in the closed-loop sweep
    # (Brent tolerance 1e-3 m/s); K(0) = b0 moves it (it used to stay at the open loop's).
    from bridgeflap.model.stability.sweeps import sweep

    basis = section_basis(7660.0, 3.75e5, 0.116, 0.30, B, 0.005)
    m = section_model(basis, B, RHO, CHORD)
    sw = sweep(m.system(Compensator(0.0, 0.0, b0, 0.05, 0.3)), np.linspace(0.0, 150.0, 301))
    assert sw.divergence.status == "converged"
    assert sw.divergence.speed == pytest.approx(sw.divergence_static_speed, abs=2e-3)
    open_loop = sweep(m.open_loop, np.linspace(0.0, 150.0, 301)).divergence_static_speed
    assert (sw.divergence_static_speed == pytest.approx(open_loop, rel=1e-12)) == (b0 == 0.0)
