"""A design you can install: the acceptance verdict is part of the status (harm is never
``converged``), the certificate's Clopper-Pearson bound, independent fresh draws, and the public
:func:`bridgeflap.design.accept` on a controller that does harm
(bridgeflap.design.assessment.accept)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.stats import binom

from bridgeflap.design.assessment.accept import ACCEPTANCE_STATUS, accept
from bridgeflap.design.assessment.acceptance import AcceptanceOptions
from bridgeflap.design.assessment.harm import _sample, clopper_pearson_upper
from bridgeflap.design.control.settings import load_settings
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.structure.loader import load_bridge

#: the designed K of tests/test_design/assessment/test_harm.py (18 placed pairs) and its sign
#: reversed, which drives the flaps the wrong way (flutter 68.85 -> 57.33 m/s on 8 modes)
K = Compensator(-1.0520215923792988, 0.724204088492299, -4.9906722869878095,
                0.24572479364985136, 0.19628837741003988)
WRONG = Compensator(-K.b2, -K.b1, -K.b0, K.a2, K.a1)
POSITIONS = tuple(56.4 * i for i in range(-12, 13) if abs(i) >= 4)


def test_clopper_pearson_upper_bound():
    # analytic for 0 events: 1 - 0.05^(1/n); 0 of 1000 gives the 0.30 % bound
    assert clopper_pearson_upper(0, 1000) == pytest.approx(1 - 0.05 ** 1e-3, rel=1e-12)
    assert clopper_pearson_upper(0, 1000) == pytest.approx(0.0030, abs=1e-4)
    # its defining property (cross-method: the binomial CDF): P(X <= k | p_upper) = 0.05
    for k, n in ((1, 1000), (5, 200), (33, 100)):
        p = clopper_pearson_upper(k, n)
        assert binom.cdf(k, n, p) == pytest.approx(0.05, rel=1e-6)
        assert p > k / n
    assert clopper_pearson_upper(7, 7) == 1.0 and clopper_pearson_upper(0, 0) is None


def test_certificate_draws_are_independent_uniform_and_reproducible():
    spec = load_bridge("humber")
    ranges = {"deck.gj_nm2": (4.7e11, 7.1e11), "cable.main_sag_m": (110.0, 125.0)}
    a = _sample(spec, ranges, 400, 11, "random")
    b = _sample(spec, ranges, 400, 11, "random")
    assert [p for p, _ in a] == [p for p, _ in b]           # a seed gives the same draws
    gj = np.array([p["deck.gj_nm2"] for p, _ in a])
    assert gj.min() >= 4.7e11 and gj.max() <= 7.1e11
    # none of them is a Sobol' point of the design's scenarios (seed 7)
    sob = {p["deck.gj_nm2"] for p, _ in _sample(spec, ranges, 16, 7, "sobol")}
    assert not sob & set(gj)
    # uniform: each decile holds 40 +- 4 sigma (sigma = sqrt(400 * 0.1 * 0.9) = 6)
    counts = np.histogram((gj - 4.7e11) / 2.4e11, bins=10, range=(0, 1))[0]
    assert np.all(np.abs(counts - 40) < 24)
    assert AcceptanceOptions().sampling == "random" and AcceptanceOptions().samples == 1000


def test_harm_is_a_status_of_the_design():
    # every verdict that is not a pass takes the design's status; none of them is converged
    assert set(ACCEPTANCE_STATUS) == {"harm", "failed", "unresolved"}
    assert "converged" not in ACCEPTANCE_STATUS.values()


@pytest.fixture(scope="module")
def small_card():
    # 8 modes on the variants: the verdict's path at a test's cost
    return load_settings("default", fresh_variant_modes=8, verification_modes=8)


def test_accept_flags_a_reversed_controller_as_harm(small_card, tmp_path):
    bad = Controller(WRONG, POSITIONS, 56.4, flap_chord_m=3.0)
    res = accept(bad, small_card, checks="independent_check,robustness", samples=4)
    assert res.status == "harm"
    rob = res.block["robustness"]
    assert rob["harmed_count"] >= 1 and rob["sampling"] == "random"
    assert rob["harm_probability_upper_95"] == pytest.approx(
        clopper_pearson_upper(rob["harmed_count"], 4))
    # the independent closed loop still agrees: the loop is wrong, not its arithmetic
    assert res.block["independent_check"]["status"] == "agrees"
    json.dumps(res.summary(), allow_nan=False)
    good = accept(Controller(K, POSITIONS, 56.4, flap_chord_m=3.0), small_card,
                  checks="robustness", samples=4)
    # the designed sign lifts every one of the same variants above the reversed one
    g, b = good.block["robustness"]["rows"], rob["rows"]
    assert all(x["closed_loop_critical_speed_m_s"] > y["closed_loop_critical_speed_m_s"]
               for x, y in zip(g, b, strict=True))
    assert good.block["robustness"]["harmed_count"] < rob["harmed_count"]


def test_accept_refuses_bad_arguments(small_card):
    c = Controller(K, POSITIONS, 56.4, flap_chord_m=3.0)
    with pytest.raises(BridgeflapInputError, match="controller"):
        accept(42, small_card)
    with pytest.raises(BridgeflapInputError, match="checks"):
        accept(c, small_card, checks="everything")
    with pytest.raises(BridgeflapInputError, match="samples"):
        accept(c, small_card, samples=0)
    assert accept(c, small_card, checks="none").status == "not_run"
