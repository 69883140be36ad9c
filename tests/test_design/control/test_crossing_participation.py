"""The participation reported with a closed-loop crossing is that of the root that crosses.

An earlier default design's K(s) on its 20 outer strips (|x| from 169.2 to 676.8 m, the
default card's layout before it fixed the placement search's central strips): the closed loop's
governing limit is a torsional divergence at 87.32 m/s, a symmetric heave-twist root; its
flutter crossing, far above (119 m/s), is an antisymmetric VA1 branch. The participation
beside the divergence must be the divergence root's, checked here against an independent
eigen-solution at the refined crossing speed.
"""

from __future__ import annotations

import numpy as np
import pytest

from bridgeflap.design.control.review.checks import closed_loop_limits
from bridgeflap.design.control.settings import load_settings
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.aeroelastic.flaps import closed_loop_model
from bridgeflap.model.structure.loader import load_bridge

K = Compensator(b2=-0.7263784036092082, b1=-0.3438703710282411, b0=-3.7120362195429366,
                a2=0.27264373670970943, a1=0.31329235292884927)
#: the layout K was designed on (the default card's earlier one)
OUTER = tuple(s * x for s in (-1.0, 1.0) for x in (676.8, 620.4, 564.0, 507.6, 451.2, 394.8,
                                                   338.4, 282.0, 225.6, 169.2))


def test_divergence_reports_the_participation_of_the_crossing_root():
    s = load_settings("default")
    ctrl = Controller(K, tuple(sorted(OUTER)), s.flap_width_m, True, True, s.gain_limit,
                      s.flap_chord_m)
    lim = closed_loop_limits(s, ctrl)
    assert lim["critical_mechanism"] == "divergence"
    u = lim["critical_speed_m_s"]
    # independent: the real eigenvalue of the closed loop nearest 0 at the refined crossing,
    # its eigenvector's strain-energy shares K_jj |q_j|^2 (a static root has no kinetic energy)
    m = closed_loop_model(load_bridge(s.bridge), ctrl.flap_strip_positions_m, ctrl.flap_width_m,
                          s.verification_modes, ctrl.chord_m, True, True)
    cl = m.system(ctrl.compensator)
    lam, V = np.linalg.eig(cl.A(u))
    i = np.argmin(np.where(np.abs(lam.imag) < 1e-9, np.abs(lam.real), np.inf))
    # the crossing: Re lambda at the refined speed is a root (|lambda| ~ 1e-15 1/s measured)
    assert abs(lam[i]) < 1e-8
    q = V[cl.index.q, i]
    share = np.real(np.diag(cl.basis.K)) * np.abs(q) ** 2
    share /= share.sum()
    top = np.argsort(-share)[:4]
    expect = {cl.basis.labels[j]: share[j] for j in top}
    got = lim["critical_participation"]
    assert list(got) == list(expect)   # VS2, TS1, VS3, VS1: symmetric heave-twist
    # 1e-6: the sweep's eigenvector (Newton at the crossing) and numpy's are of one simple
    # eigenvalue, equal up to scale; the shares are scale-free, so they agree to the
    # eigenvector's conditioning times round-off (measured ~1e-9)
    for k, v in expect.items():
        assert got[k] == pytest.approx(v, abs=1e-6)
    assert set(got) == {"VS2", "TS1", "VS3", "VS1"}
    # the flutter crossing's participation is kept under its own name, and is not this one
    assert max(lim["flutter_participation"], key=lim["flutter_participation"].get) == "VA1"
