"""The coarse march's assignment of near-double pairs (bridgeflap.model.stability.tracking._assign,
``coincident``).

Great Belt's identical side spans give pairs of branches 3.6e-7 and 9e-6 rad/s apart that move
together by 1e-3 rad/s per m/s: the plain test (each branch against the next-nearest
eigenvalue) calls every step ambiguous and no halving helps. With ``coincident`` (the fast
sweep's) eigenvalues equal to round-off are one value and a pair is tested on its difference;
a pair whose difference turns, or a third eigenvalue near the pair, stays ambiguous. The dense
sweep's assignment (``coincident=0``) is unchanged.
"""

from __future__ import annotations

import numpy as np
import pytest

from bridgeflap.model.stability.tracking import COINCIDENT, UNAMBIGUOUS, _assign

OMEGA_TOL = 1e-3  # [rad/s], far below the 2 rad/s pair
CENTRE = -0.01 + 2.0j  # [1/s]
SEP = 1e-5j  # the gap between the pair [1/s] (Great Belt's: 9e-6 rad/s)
COMMON = 4e-5 + 2e-5j  # the predictor's error common to both [1/s], larger than the pair's gap


def _halves(upper):
    upper = np.asarray(upper, complex)
    return np.concatenate([upper, upper.conj()])


def _run(pred_upper, lam_upper, extra=(), coincident=COINCIDENT):
    lam = np.concatenate([_halves(lam_upper), np.asarray(extra, complex)])
    return _assign(_halves(pred_upper), lam, OMEGA_TOL, coincident)


PRED = [CENTRE - SEP / 2, CENTRE + SEP / 2]


def test_a_pair_moving_as_one_is_unambiguous():
    lam = [p + COMMON for p in PRED]
    got, ambiguous = _run(PRED, lam)
    assert not ambiguous
    assert np.allclose(got[:2], lam, rtol=0, atol=1e-15)  # the identity, not the swap
    # the plain test (the dense sweep's) calls it ambiguous: the common error exceeds the gap
    assert _run(PRED, lam, coincident=0.0)[1]
    assert abs(COMMON) > UNAMBIGUOUS * abs(SEP)


def test_a_pair_whose_difference_turns_stays_ambiguous():
    # the same centre and gap, the difference turned by 90 degrees: identity and swap are
    # equally far from the prediction
    lam = [CENTRE + COMMON - 1j * SEP / 2, CENTRE + COMMON + 1j * SEP / 2]
    assert _run(PRED, lam)[1]


def test_a_third_eigenvalue_near_the_pair_stays_ambiguous():
    lam = [p + COMMON for p in PRED]
    # an eigenvalue of no branch (a lag or a compensator state) next to the pair
    x = CENTRE + COMMON + 3 * SEP
    assert _run(PRED, lam, extra=[x, x.conjugate()])[1]


@pytest.mark.parametrize("seed", range(5))
def test_coincident_eigenvalues_are_one_value(seed):
    """Great Belt's V-sprogoe4 / V-halsskov3: 3.6e-7 rad/s apart, eigvals' scatter 2.7e-7."""
    rng = np.random.default_rng(seed)
    gap = 3.6e-7j
    pred = [CENTRE - gap / 2, CENTRE + gap / 2]
    lam = [p + 2.7e-7 * np.exp(2j * np.pi * rng.uniform()) for p in pred]
    got, ambiguous = _run(pred, lam)
    assert not ambiguous
    # whichever way the two are given out, each branch's value is within the gap and scatter
    assert np.all(np.abs(got[:2] - np.asarray(pred)) <= abs(gap) + 2 * 2.7e-7)
    # both are far below COINCIDENT of |lambda| (2e-6 here): the rule's margin
    assert abs(gap) + 2 * 2.7e-7 < COINCIDENT * abs(CENTRE)
