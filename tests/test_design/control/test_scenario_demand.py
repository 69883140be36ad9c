"""The flap demand on the scenario bridges (design.control.solve.scenarios,
design.control.formulation.variants.demand_checks): each scenario held at its own actuator
speed, lazily, on the same frozen integral as the nominal bridge's."""

from __future__ import annotations

import numpy as np
import pytest

from bridgeflap.design.control.formulation import variants
from bridgeflap.design.control.formulation.actuator_demand import SIGMAS
from bridgeflap.design.control.search.driver import build_model
from bridgeflap.design.control.settings import load_settings
from bridgeflap.design.control.solve.pair_failure import extra_models
from bridgeflap.design.control.solve.scenarios import (
    corner_specs,
    open_loop_limit,
    scenario_demand_speed,
    scenario_settings,
)

THETA = np.array([-0.33, -0.05, -3.7, 0.15, 0.27])
SPEEDS = (40.0, 60.0)


@pytest.fixture(scope="module")
def small():
    # Humber, 8 modes, 5 flap pairs, the two GJ corners as scenarios: the design's code path
    # on small matrices
    s = load_settings(None, n_modes=8, flap_count=5, actuator_design_speeds_m_s=SPEEDS,
                      variant_rule="no_harm", variant_corners=("deck.gj_nm2",))
    spec, model = build_model(s)
    from bridgeflap.design.control.formulation.nlp import DesignProblem

    prob = DesignProblem(s, model, spec=spec)
    prob.variants = extra_models(s, model, spec, corner_specs(s, spec))
    return s, spec, model, prob


def test_scenario_demand_speed_is_the_top_speed_or_the_open_loop_limit():
    s = load_settings(None, actuator_design_speeds_m_s=(50.0, 74.0, 60.0))
    assert scenario_demand_speed(s) == (74.0,)
    assert scenario_demand_speed(s, 69.5) == (69.5,)
    assert scenario_demand_speed(s, 90.0) == (74.0,)
    assert scenario_demand_speed(load_settings(None, actuator_design_speeds_m_s=())) == ()


def test_each_scenario_is_held_at_its_own_speed(small):
    s, spec, model, prob = small
    assert len(prob.variants) == 2
    for v, c in zip(prob.variants, corner_specs(s, spec), strict=True):
        u = open_loop_limit(s, c, v.model)
        assert v.settings.actuator_design_speeds_m_s == (min(max(SPEEDS), u),)
        assert v.demand_held is False          # checked, not yet in the NLP
    # no actuator speeds on the card: no scenario carries a demand
    s0 = load_settings(None, n_modes=8, flap_count=5, variant_corners=("deck.gj_nm2",))
    v0 = extra_models(s0, model, spec, corner_specs(s0, spec))
    assert all(v.demand_held is None for v in v0)
    assert scenario_settings(s0, corner_specs(s0, spec)[0], model).actuator_design_speeds_m_s \
        == ()


def test_demand_checks_hold_the_scenarios_near_a_limit(small, monkeypatch):
    s, spec, model, prob = small
    for v in prob.variants:
        v.demand_held = False
    ok, new = variants.demand_checks(prob, THETA)
    fr = [v.flap_demand().fraction(THETA) for v in prob.variants]
    # the fraction is the largest 3 sigma angle or rate over the limit (the card's own)
    for v, f in zip(prob.variants, fr, strict=True):
        r = SIGMAS * v.flap_demand().rms_deg(THETA)
        want = max(r[:, :2].max() / s.flap_angle_limit_deg,
                   r[:, 2:].max() / s.flap_rate_limit_deg_s)
        assert f == pytest.approx(want, rel=1e-9)   # the same numbers, two formulae
    assert ok == all(f <= 1.0 for f in fr)
    assert new == sum(f > variants.DEMAND_NEAR for f in fr)
    # a threshold below every fraction holds them all; the set only grows
    monkeypatch.setattr(variants, "DEMAND_NEAR", 0.0)
    ok2, new2 = variants.demand_checks(prob, THETA)
    assert ok2 == ok and new + new2 == len(prob.variants)
    monkeypatch.setattr(variants, "DEMAND_NEAR", 10.0)
    assert variants.demand_checks(prob, THETA)[1] == 0
    assert variants.demand_held_count(prob) == len(prob.variants)


def test_held_scenarios_enter_the_nlp(small, monkeypatch):
    """The NLP carries each held scenario's constraints, with the values of its own frozen
    integral, after the nominal bridge's; a scenario not held adds none."""
    import casadi as ca

    from bridgeflap.design.control.formulation import nlp as nlp_module

    s, spec, model, prob = small
    variants.demand_checks(prob, THETA)     # built at THETA (as a design's start)
    seen = []

    def capture(name, solver, nlp, opts):   # the NLP as built, not solved
        seen.append(nlp)
        raise RuntimeError("captured")

    monkeypatch.setattr(nlp_module.ca, "nlpsol", capture)
    sizes = []
    for held in ((False, False), (True, False), (True, True)):
        for v, h in zip(prob.variants, held, strict=True):
            v.demand_held = h
        with pytest.raises(RuntimeError, match="captured"):
            prob.solve(THETA, np.array([40.0, 60.0]))
        g = ca.Function("g", [seen[-1]["x"]], [seen[-1]["g"]])
        sizes.append(int(seen[-1]["g"].size1()))
        if held == (True, True):
            x = np.append(THETA, 1.0)
            gv = np.asarray(g(x).full()).ravel()
            want = np.concatenate([np.asarray(v.flap_demand().constraints(
                ca.DM(THETA)).full()).ravel() for v in prob.variants])
            nom = np.asarray(prob.flap_demand().constraints(ca.DM(THETA)).full()).ravel()
            # the nominal block, then the scenarios' blocks, at the end (no variant damping
            # speeds here): the same CasADi expressions evaluated twice
            assert np.allclose(gv[-(nom.size + want.size):], np.concatenate([nom, want]),
                               rtol=1e-12, atol=1e-12)
    # each held scenario adds 4 constraints (angle and rate of two flaps at its one speed)
    assert np.diff(sizes).tolist() == [4, 4]
