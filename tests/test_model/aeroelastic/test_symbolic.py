"""Symbolic CasADi A(U, p) against the numpy assembly (cross-method agreement)."""

import casadi as ca
import numpy as np
import pytest
from conftest import coarse
from scipy.optimize import linear_sum_assignment

from bridgeflap.model.aeroelastic.symbolic import SYMBOLIC_PARAMETERS, build_symbolic
from bridgeflap.model.analysis import bridge_system
from bridgeflap.model.structure.loader import load_bridge
from bridgeflap.model.structure.spec import get_path

N_MODES = 10


@pytest.fixture(scope="module")
def case():
    # coarse mesh (30 elements on the main span) keeps the module fast; the comparison is
    # between two assemblies of the same discretisation, so mesh accuracy does not matter
    spec = coarse(load_bridge("humber"))
    return spec, build_symbolic(spec, N_MODES)


def _matched_distance(l1, l2):
    cost = np.abs(l1[:, None] - l2[None, :])
    r, c = linear_sum_assignment(cost)
    return cost[r, c].max()


@pytest.mark.parametrize("speed", [0.0, 30.0, 70.0])
def test_nominal_equals_numpy(case, speed):
    spec, sm = case
    _, system = bridge_system(spec, N_MODES)
    A_num = system.A(speed)
    # both are the same algebra evaluated in floating point: agreement to rounding (1e-12
    # relative leaves room for the different evaluation order of CasADi's SX graph)
    assert np.abs(sm.A(speed) - A_num).max() <= 1e-12 * np.abs(A_num).max()


def test_half_chord_and_density_enter_exactly(case):
    spec, sm = case
    p = np.ones(len(SYMBOLIC_PARAMETERS))
    p[SYMBOLIC_PARAMETERS.index("deck.half_chord_m")] = 1.1
    p[SYMBOLIC_PARAMETERS.index("aero.air_density_kg_m3")] = 0.9
    changed = spec.replace(**{"deck.half_chord_m": spec.deck.half_chord_m * 1.1,
                              "aero.air_density_kg_m3": spec.aero.air_density_kg_m3 * 0.9})
    _, system = bridge_system(changed, N_MODES)
    # b and rho do not touch the structure, so the symbolic model is exact: rounding only
    A_num = system.A(50.0)
    assert np.abs(sm.A(50.0, p) - A_num).max() <= 1e-12 * np.abs(A_num).max()


@pytest.mark.parametrize("path", ["deck.mass_kg_per_m", "deck.mass_inertia_kgm2_per_m",
                                  "deck.gj_nm2", "deck.ei_vertical_nm2", "cable.main_sag_m"])
def test_ritz_projection_close_to_resolved_modes(case, path):
    """A 2 % change through the Ritz projection vs re-solving the modes.

    The projection is exact within the nominal basis; re-solved modes differ from the nominal
    ones by O(2 %) in shape, which moves eigenvalues by O((2 %)^2) relative: 1e-3 of the
    largest |lambda| is a generous bound for that second-order term.
    """
    spec, sm = case
    p = np.ones(len(SYMBOLIC_PARAMETERS))
    p[SYMBOLIC_PARAMETERS.index(path)] = 1.02
    _, system = bridge_system(spec.replace(**{path: get_path(spec, path) * 1.02}), N_MODES)
    l_sym = np.linalg.eigvals(sm.A(50.0, p))
    l_num = np.linalg.eigvals(system.A(50.0))
    assert _matched_distance(l_sym, l_num) <= 1e-3 * np.abs(l_num).max()
    # and the change is real (the parameter does act): not equal to the nominal spectrum
    l_nom = np.linalg.eigvals(sm.A(50.0))
    assert _matched_distance(l_sym, l_nom) > 1e-6 * np.abs(l_num).max()


def test_jacobian_matches_finite_differences(case):
    spec, sm = case
    U = ca.SX.sym("U")
    p = ca.SX.sym("p", len(SYMBOLIC_PARAMETERS))
    J = ca.Function("J", [U, p], [ca.jacobian(ca.vec(sm.A_fun(U, p)), p)])
    p0 = np.ones(len(SYMBOLIC_PARAMETERS))
    jac = np.array(J(40.0, p0))
    h = 1e-6
    for k in range(len(p0)):
        dp = np.zeros_like(p0)
        dp[k] = h
        fd = (sm.A(40.0, p0 + dp) - sm.A(40.0, p0 - dp)).ravel(order="F") / (2 * h)
        # central differences: truncation O(h^2) and rounding O(eps |A| / h) ~ 1e-10 |A|;
        # 1e-6 of the largest entry covers both
        scale = max(np.abs(jac[:, k]).max(), 1e-12)
        assert np.abs(jac[:, k] - fd).max() <= 1e-6 * max(scale, np.abs(sm.A(40.0)).max())
