"""Design for one-pair failure (``design_for_pair_failure``).

Each flap pair stuck at 0 is one more model of the multi-model design: weight 0 on its loads
whatever weights the multi-model checks pass (else the nominal weights would silently restore
it). Can fail: on humber:box (6 modes, 5 pairs) the design without the option leaves every
one-pair-failed loop below zeta_min = 0.5 % (0.32-0.40 %), with it every one meets it (slow).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bridgeflap.design.control.formulation.nlp import DesignProblem
from bridgeflap.design.control.search.driver import build_model
from bridgeflap.design.control.settings import load_settings
from bridgeflap.design.control.solve.pair_failure import FailedPairProblem, extra_models
from bridgeflap.model.aeroelastic.control import Compensator

THETA = np.array([0.3, 0.25, -1.5, 0.08, 0.5])


@pytest.fixture(scope="module")
def small_box():
    s = load_settings(None, bridge="humber:box", n_modes=6, verification_modes=6, flap_count=5,
                      robust_design_speeds_m_s=(30.0, 60.0), n_robust_omega=8)
    spec, model = build_model(s)
    return s, spec, model


def test_failed_pair_problem_is_the_loop_with_that_pair_off(small_box):
    s, spec, model = small_box
    q = FailedPairProblem(replace(s, design_for_pair_failure=True), model, 2, spec=spec)
    w = np.ones(model.n_flaps)
    w[2] = 0.0
    ref = model.system(Compensator(*THETA), w)
    # the nominal weights passed by a multi-model check do not restore the failed pair
    for weights in (None, np.ones(model.n_flaps)):
        A0, A1, A2, _ = q.A_parts(THETA, weights)
        for a, b in ((A0, ref.A0), (A1, ref.A1), (A2, ref.A2)):
            assert np.allclose(a, b, rtol=1e-10, atol=1e-10 * np.abs(b).max())
    U = np.array([40.0, 80.0])
    assert not np.allclose(q.constraint_values(THETA, U, np.ones(model.n_flaps)),
                           DesignProblem(s, model, spec=spec).constraint_values(THETA, U))


def test_extra_models_only_with_the_card_key(small_box, tmp_path):
    s, spec, model = small_box
    assert extra_models(s, model, spec, []) == []
    on = replace(s, design_for_pair_failure=True)
    got = extra_models(on, model, spec, [])
    assert [q.pair for q in got] == list(range(model.n_flaps))
    card = tmp_path / "card.toml"
    card.write_text("[variants]\ndesign_for_pair_failure = true\n", encoding="utf-8")
    assert load_settings(card).design_for_pair_failure is True
    from bridgeflap.model.errors import BridgeflapInputError

    with pytest.raises(BridgeflapInputError, match="design_for_pair_failure"):
        load_settings(None, design_for_pair_failure="yes")


@pytest.mark.slow
def test_design_for_pair_failure_meets_damping_with_any_pair_failed(small_box):
    s, spec, model = small_box
    out = {}
    for flag in (False, True):
        s2 = replace(s, max_iter=40, resolve_max_iter=40, cutting_plane_rounds=4,
                     design_step_m_s=10.0, weight_robust=0.0, weight_buffeting=0.0,
                     design_for_pair_failure=flag)
        prob = DesignProblem(s2, model, spec=spec)
        prob.variants = extra_models(s2, model, spec, [])
        res = prob.solve_with_cuts(THETA)
        checks = [q.verify(res.solve.theta)
                  for q in extra_models(replace(s2, design_for_pair_failure=True), model,
                                        spec, [])]
        out[flag] = (res.verification.meets_damping, [c.meets_damping for c in checks])
    assert out[False][0] and not any(out[False][1])   # the check can fail
    assert out[True][0] and all(out[True][1])
