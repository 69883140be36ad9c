"""The fast do-no-harm check against its reference path.

(c) cross-method agreement: ``method="fast"`` (critical crossings only, the static shortcut,
the screening) gives the reference's critical speeds and verdicts; the screening's bookkeeping
is tested on hand-made rows. Small models (6-10 modes) keep the file well under a minute.

Tolerance of a critical speed, 2e-3 m/s: each method stops a crossing either by Newton (to
round-off) or by Brent's method on the 0.5 m/s grid bracket (``xtol`` 1e-3 m/s, the sweeps'
``speed_tol``); two such estimates of one root differ by at most the sum of their widths.
"""

from __future__ import annotations

import numpy as np
import pytest

from bridgeflap.design.assessment.harm import (
    SCREEN_CHECK_FRACTION,
    SCREEN_MARGIN_REL,
    _extreme_candidates,
    do_no_harm,
    harm_row,
    near_decision,
)
from bridgeflap.design.assessment.harm_fast import static_crossing
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.aeroelastic.flaps import closed_loop_model
from bridgeflap.model.stability.sweeps import sweep
from bridgeflap.model.structure.loader import load_bridge

#: the default design's K(s) and layout (as tests/test_harm.py)
K = Compensator(-1.0520215923792988, 0.724204088492299, -4.9906722869878095,
                0.24572479364985136, 0.19628837741003988)
POSITIONS = tuple(56.4 * i for i in range(-12, 13) if abs(i) >= 4)
U = np.arange(0.0, 127.5 + 1e-9, 0.5)
#: Brent's 1e-3 m/s on each side (module docstring)
SPEED_TOL = 2e-3
VERDICT = ("open_loop_mechanism", "closed_loop_mechanism", "stable_to_design_speed", "harmed",
           "resolved", "open_loop_beyond_grid", "closed_loop_beyond_grid")


def _c(k=K):
    return Controller(k, POSITIONS, 56.4, flap_chord_m=3.0)


@pytest.fixture(scope="module")
def humber():
    return load_bridge("humber")


def _same(fast, ref):
    for key in VERDICT:
        assert fast[key] == ref[key], key
    for key in ("open_loop_critical_speed_m_s", "closed_loop_critical_speed_m_s"):
        if ref[key] is None:
            assert fast[key] is None, key
        else:
            assert fast[key] == pytest.approx(ref[key], abs=SPEED_TOL), key


def test_fast_rows_equal_the_reference(humber):
    """Four fresh variants and the nominal bridge, 8 modes, no screening: the critical speeds to
    the crossings' tolerance and the same verdicts, for the designed loop and the reversed one
    (harm)."""
    from bridgeflap.design.assessment.harm import _sample
    from bridgeflap.design.studies.screening import DEFAULT_UNCERTAIN_RANGES

    ranges = {k: v for k, v in DEFAULT_UNCERTAIN_RANGES.items()
              if k not in ("deck.half_chord_m", "aero.coherence_decay")}
    specs = [humber] + [v for _, v in _sample(humber, ranges, 4, 11)]
    wrong = Compensator(-K.b2, -K.b1, -K.b0, K.a2, K.a1)
    for spec in specs:
        _same(harm_row(spec, _c(), U, 8, 85.0, method="fast"),
              harm_row(spec, _c(), U, 8, 85.0, method="reference"))
    bad = harm_row(humber, _c(wrong), U, 8, 85.0, method="fast")
    _same(bad, harm_row(humber, _c(wrong), U, 8, 85.0, method="reference"))
    assert bad["harmed"]


def test_static_shortcut_is_the_sweeps_divergence(humber):
    """The closed loop's divergence from its static condition (the fast method's confirmation)
    is the fast sweep's Newton root; the sweep no longer falls back to the dense sweep there
    (the interpolated start left the bracket; the static root seeds it) and agrees with it."""
    c = _c()
    model = closed_loop_model(humber, c.flap_strip_positions_m, c.flap_width_m, 8, c.chord_m)
    system = model.system(c.compensator)
    fast = sweep(system, U, method="fast")
    dense = sweep(system, U, method="dense")
    assert fast.fallback_reason == "" and fast.divergence.status == "converged"
    assert fast.divergence.speed == pytest.approx(dense.divergence.speed, abs=SPEED_TOL)
    u = static_crossing(system, fast.divergence.speed, SCREEN_MARGIN_REL)
    # both are Newton's converged root of A(U) v = 0: round-off apart (1e-9 relative is loose)
    assert u == pytest.approx(fast.divergence.speed, rel=1e-9)
    # a hint outside the margin of the first static root is refused, not moved to
    assert static_crossing(system, 1.1 * u, SCREEN_MARGIN_REL) is None


def test_screened_summary_equals_the_reference(humber):
    """Six variants on 10 modes, screened on 8: the same summary as the reference on 10 modes
    (fractions, status, worst variant, the worst ratio and lowest speed to the crossings'
    tolerance); every row on 10 modes has the reference's numbers."""
    ref = do_no_harm(_c(), humber, count=6, n_modes=10, speeds=U, method="reference")
    fast = do_no_harm(_c(), humber, count=6, n_modes=10, speeds=U, method="fast",
                      screen_modes=8)
    a, b = fast.summary(), ref.summary()
    for key in ("fraction_stable_to_design_speed", "fraction_harmed", "status",
                "unresolved_variants", "worst_variant"):
        assert a[key] == b[key], key
    assert a["worst_closed_over_open"] == pytest.approx(b["worst_closed_over_open"],
                                                        abs=SPEED_TOL / 50.0)  # ~50 m/s
    assert a["worst_closed_loop_critical_speed_m_s"] == pytest.approx(
        b["worst_closed_loop_critical_speed_m_s"], abs=SPEED_TOL)
    assert a["screen_modes"] == 8 and "passed" in a["screen_check"]
    for r, s in zip(fast.rows, ref.rows, strict=True):
        for k in VERDICT:
            assert r[k] == s[k], k
        for loop in ("open_loop", "closed_loop"):
            if r[f"{loop}_modes"] == 10:
                assert r[f"{loop}_critical_speed_m_s"] == pytest.approx(
                    s[f"{loop}_critical_speed_m_s"], abs=SPEED_TOL)


def _row(ol, cl, resolved=True, on=(16, 16)):
    return {"open_loop_critical_speed_m_s": ol, "closed_loop_critical_speed_m_s": cl,
            "closed_over_open": cl / ol, "resolved": resolved,
            "open_loop_modes": on[0], "closed_loop_modes": on[1]}


def test_near_decision_names_the_loops_to_recompute():
    m = SCREEN_MARGIN_REL
    assert near_decision(_row(70.0, 100.0), 85.0) == ()
    assert near_decision(_row(70.0, 85.0 * (1 + 0.9 * m)), 85.0) == ("closed_loop",)
    both = ("open_loop", "closed_loop")
    assert near_decision(_row(70.0, 70.0 * (1 + 1.9 * m)), 85.0) == both  # near harm
    assert near_decision(_row(70.0, 100.0, resolved=False), 85.0) == both


def test_extremes_are_recomputed_within_the_check_limit():
    lim = SCREEN_CHECK_FRACTION * SCREEN_MARGIN_REL
    rows = [_row(70.0, 80.0, on=(30, 30)),               # the worst ratio, on 30 modes
            _row(70.0, 80.0 * (1 + 1.5 * lim)),          # its ratio within 2 lim: both loops
            _row(60.0, 80.0 * (1 + 0.5 * lim) + 20.0),   # far in ratio, not an extreme speed
            _row(60.0, 150.0),                           # the highest closed-loop speed
            _row(60.0, 150.0 * (1 - 0.5 * lim))]         # within lim of it: the closed loop
    got = _extreme_candidates(rows, 30)
    assert got == {1: ("open_loop", "closed_loop"), 3: ("closed_loop",),
                   4: ("closed_loop",)}
