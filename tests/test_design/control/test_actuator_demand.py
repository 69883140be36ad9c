"""The actuator-demand constraints of the design
(bridgeflap.design.control.formulation.actuator_demand): the frozen CasADi integral against the
acceptance's numpy flap demand, and its gradient against finite differences."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from bridgeflap.design.control.formulation.nlp import DesignProblem
from bridgeflap.design.control.search.driver import build_model
from bridgeflap.design.control.settings import load_settings
from bridgeflap.model.aeroelastic.control import Compensator, Controller

THETA = np.array([-0.33, -0.05, -3.7, 0.15, 0.27])
SPEEDS = (40.0, 60.0)


@pytest.fixture(scope="module")
def problem():
    # Humber, 8 modes, 5 flap pairs: the design's code path on small matrices
    s = load_settings(None, n_modes=8, flap_count=5, robust_design_speeds_m_s=(30.0, 60.0),
                      n_robust_omega=8, actuator_design_speeds_m_s=SPEEDS)
    spec, model = build_model(s)
    return s, spec, model, DesignProblem(s, model, spec=spec)


def test_frozen_integral_matches_the_acceptance_flap_demand(problem):
    from bridgeflap.design.assessment.usable_speed import _Demand, flap_demand_loop

    s, spec, model, prob = problem
    fd = prob.flap_demand(THETA)
    ctrl = Controller(Compensator(*THETA), tuple(float(x) for x in model.flaps.position_m),
                      s.flap_width_m, s.leading_edge, s.trailing_edge, s.gain_limit,
                      flap_chord_m=s.flap_chord_m)
    loop, gust = flap_demand_loop(spec, ctrl, s.n_modes)
    demand = _Demand(loop, gust, 10.0)
    for i, U in enumerate(SPEEDS):
        angle, rate = demand(U)                     # largest over every flap, with the servo
        ours = fd.rms_deg(THETA)[i]
        # the largest flap is among the two constrained; the ideal actuator against the 10 rad/s
        # servo and the frozen grid against the adaptive one: within 3 % (measured 0.3 % on
        # 16 modes), inside the 5 % back-off of the constraint
        assert ours[0] == pytest.approx(angle, rel=0.03)
        assert max(ours[2], ours[3]) == pytest.approx(rate, rel=0.03)


def test_demand_gradient_matches_finite_differences(problem):
    s, spec, model, prob = problem
    fd = prob.flap_demand(THETA)
    x = ca.MX.sym("x", 5)
    g = fd.constraints(x)
    jac = ca.Function("j", [x], [ca.jacobian(g, x)])
    J = np.asarray(jac(THETA).full())
    f = ca.Function("g", [x], [g])
    cols = []
    for k in range(5):
        e = np.zeros(5)
        e[k] = 1e-6 * max(1.0, abs(THETA[k]))
        cols.append((np.asarray(f(THETA + e).full()).ravel()
                     - np.asarray(f(THETA - e).full()).ravel()) / (2 * e[k]))
    # central differences of a smooth closed form: truncation ~1e-12, round-off ~1e-10 of
    # O(1) values; 1e-6 relative to the largest entry
    assert np.allclose(J, np.column_stack(cols), rtol=1e-5, atol=1e-6 * np.abs(J).max())
