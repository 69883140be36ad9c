"""python-control first-class (bridgeflap.model.aeroelastic.control_interop): K(s), the controller,
the closed loop, the plant family; cross-checked against the package's own objects.
"""

from __future__ import annotations

import numpy as np
import pytest

from bridgeflap import model
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.aeroelastic.flaps import closed_loop_state_space

control = pytest.importorskip("control")

#: the compensator and layout of tests/test_plant.py (a2 > 0: second order)
K2 = Compensator(0.0, 0.1, -0.5, 0.01, 0.2)
K2B = Compensator(0.004, 0.1, -0.5, 0.01, 0.2)   # b2 != 0: a feed-through
K1 = Compensator(0.0, 0.3, -1.0, 0.0, 0.5)       # first order
CTRL = Controller(K2, (-56.4, 0.0, 56.4), 56.4)
N_MODES = 6
OMEGA = np.array([1e-3, 0.1, 0.7, 2.0, 9.0, 60.0, 1e3])  # [rad/s], across the corners


def _clusters(lam, tol):
    """Eigenvalues grouped within ``tol`` (relative): (mean, multiplicity) per group."""
    groups = []
    for x in np.sort_complex(np.asarray(lam)):
        for g in groups:
            if abs(x - g[0]) <= tol * max(1.0, abs(x)):
                g.append(x)
                break
        else:
            groups.append([x])
    return [(np.mean(g), len(g)) for g in groups]


def _same_spectrum(ref, got):
    """The eigenvalues agree to 1e-9 relative. Repeated eigenvalues (the compensator pole
    copied on every flap, the RFA lag poles) are defective, so each member of a cluster is
    known only to ~sqrt(eps) but the cluster mean to rounding: compare the means and the
    multiplicities of the clusters within 1e-6 (as tests/test_plant.py)."""
    assert len(ref) == len(got)
    cr, cg = _clusters(ref, 1e-6), _clusters(got, 1e-6)
    assert [m for _, m in cr] == [m for _, m in cg]
    for (a, _), (b, _) in zip(cr, cg, strict=True):
        assert abs(a - b) <= 1e-9 * max(1.0, abs(a))


@pytest.mark.parametrize("k", [K2, K2B, K1])
def test_compensator_tf_is_its_frequency_response(k):
    tf = k.to_control()
    assert isinstance(tf, control.TransferFunction)
    assert tf.input_labels == ["pitch"] and tf.output_labels == ["beta"]
    got = np.array([complex(tf(1j * w)) for w in OMEGA])
    # the same two quadratics evaluated at s = j omega: a few ulps apart (|K| is O(1) here
    # and no cancellation occurs), so 1e-12 relative is a bound with three orders to spare
    np.testing.assert_allclose(got, k.frequency_response(OMEGA), rtol=1e-12, atol=0)
    assert tf.poles().size == k.order


def test_controller_statespace_channels_are_plus_and_minus_k():
    ss = CTRL.to_statespace()
    nf = CTRL.n_flaps
    assert isinstance(ss, control.StateSpace)
    assert ss.input_labels == [f"pitch_flap[{f}]" for f in range(nf)]
    assert ss.output_labels == ([f"flap_te[{f}]" for f in range(nf)]
                                + [f"flap_le[{f}]" for f in range(nf)])
    for w in (0.1, 2.0, 30.0):
        g = ss(1j * w)                                 # (2 nf, nf)
        k = CTRL.compensator.frequency_response(w)
        # C (sI - A)^-1 B + D of a 2x2 companion block (poles at |s| ~ 10 rad/s): rounding
        # of the solve is ~1e-15 relative, 1e-12 leaves room for its condition number
        np.testing.assert_allclose(g, np.vstack([k * np.eye(nf), -k * np.eye(nf)]),
                                   rtol=1e-12, atol=1e-12 * abs(k))
    te_only = Controller(K2, (0.0,), 50.0, leading_edge=False).to_statespace()
    assert te_only.output_labels == ["flap_te[0]"]


@pytest.mark.parametrize("speed", [0.0, 40.0])
def test_closed_loop_has_the_package_eigenvalues(coarse_humber, speed):
    cl = model.closed_loop(coarse_humber, speed, CTRL, n_modes=N_MODES)
    assert isinstance(cl, control.StateSpace)
    A, B, C, *_ = closed_loop_state_space(coarse_humber, CTRL, speed, n_modes=N_MODES)
    assert cl.A.shape == A.shape and cl.B.shape == B.shape and cl.C.shape == C.shape
    _same_spectrum(np.linalg.eigvals(A), cl.poles())
    assert cl.input_labels[0] == "gust[0]" and cl.output_labels[-1] == "beta[2]"


def test_plant_family_closed_with_the_controller_is_the_closed_loop(coarse_humber):
    speeds = [0.0, 40.0]
    fam = model.plant_family(coarse_humber, speeds, inputs="flaps", n_modes=N_MODES,
                             controller=CTRL)
    assert list(fam) == speeds
    K = CTRL.to_statespace()
    for U, P in fam.items():
        # the same plant as model.plant at that speed (the system built once)
        np.testing.assert_array_equal(
            P.A, model.plant(coarse_humber, U, inputs="flaps", n_modes=N_MODES,
                             controller=CTRL).A)
        # closing the open-loop plant in python-control with the controller's state space
        # (positive feedback: the drives are +-K of the pitch) gives the package's loop
        Pf = P[list(K.input_labels), list(K.output_labels)]
        closed = control.feedback(Pf, K, sign=1)
        A_ref = closed_loop_state_space(coarse_humber, CTRL, U, n_modes=N_MODES)[0]
        _same_spectrum(np.linalg.eigvals(A_ref), closed.poles())


def test_plant_family_by_name_and_bad_speeds():
    from bridgeflap.model.errors import BridgeflapInputError

    fam = model.plant_family("humber", [10.0], n_modes=2)
    assert fam[10.0].input_labels[0] == "gust[0]"
    for bad in ([], [-1.0], "fast"):
        with pytest.raises(BridgeflapInputError) as e:
            model.plant_family("humber", bad, n_modes=2)
        assert e.value.field == "speeds"
    with pytest.raises(BridgeflapInputError) as e:
        model.closed_loop("humber", -3.0, CTRL)
    assert e.value.field == "speed"


def test_without_python_control_one_line(monkeypatch):
    import sys

    from bridgeflap.model.errors import BridgeflapError

    monkeypatch.setitem(sys.modules, "control", None)
    for call in (K2.to_control, CTRL.to_statespace):
        with pytest.raises(BridgeflapError, match="python-control is not installed"):
            call()
