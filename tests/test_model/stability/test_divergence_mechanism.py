"""Divergence named by its mechanism.

The static aerodynamic work of a divergence eigenvector ``q`` (``K q = U_D^2 Q q``,
:func:`bridgeflap.model.aeroelastic.statespace.static_aero_stiffness`) splits over the coordinates
whose deflection generates the load. With strip loads only twist makes static lift and moment, so
every divergence of a strip-theory deck is torsional, whatever share of its strain energy the heave
modes carry (VS1 carries 80 % on the built-in Humber: the twist's lift bends the deck).
"""

from __future__ import annotations

import numpy as np
import pytest

from bridgeflap.model import analysis
from bridgeflap.model.aeroelastic import statespace
from bridgeflap.model.cases.section import typical_section
from bridgeflap.model.stability import sweeps as stability
from bridgeflap.model.structure.loader import load_bridge


@pytest.fixture(scope="module")
def humber():
    spec = load_bridge("humber")
    _, system = analysis.bridge_system(spec, 30)
    sw = stability.sweep(system, np.arange(0.0, 85.0 + 1e-9, 0.5))
    return system, sw


def test_humber_divergence_is_torsional_ts1(humber):
    system, sw = humber
    d = sw.divergence
    assert d.status == stability.CONVERGED
    assert d.mechanism == "torsional" and d.label == "TS1", (d.mechanism, d.label)
    s = sw.summary()
    assert s["divergence_mechanism"] == "torsional" and s["divergence_branch_label"] == "TS1"


def test_static_work_identity_and_families(humber):
    """At the static divergence speed ``q^T K q = U_D^2 q^T Q q`` for the static mode."""
    system, sw = humber
    K, Q = system.basis.K, np.real(statespace.static_aero_stiffness(system))
    u = statespace.divergence_speed_static(system)
    mu, V = np.linalg.eig(np.linalg.solve(K, Q))
    q = np.real(V[:, np.argmax(np.where(np.abs(mu.imag) < 1e-12, mu.real, -np.inf))])
    # an eigen-identity of a 30 x 30 solve: roundoff only (1e-9 leaves room for conditioning)
    assert q @ K @ q == pytest.approx(u ** 2 * (q @ Q @ q), rel=1e-9)
    # twist alone generates static load in strip theory: heave/lateral columns of Q vanish
    fam = statespace.coordinate_families(system)
    cols = np.abs(Q).max(0)
    assert all(cols[j] <= 1e-12 * cols.max() for j, f in enumerate(fam) if f != "torsional")
    # family from the shapes agrees with the FE mode labels (T* torsion, V* vertical)
    for lab, f in zip(system.basis.labels, fam, strict=True):
        assert {"T": "torsional", "V": "vertical", "L": "lateral"}[lab[0]] == f, lab
    mech, src = statespace.divergence_mechanism(system, _state(system, q))
    assert (mech, src) == ("torsional", "TS1")


def _state(system, q):
    x = np.zeros(system.n_states)
    x[system.index.q] = q
    return x


def test_typical_section_divergence_is_torsional():
    """Hodges & Pierce HP-1 (tests/test_aeroelastic.py): divergence at r sqrt(mu/(1+2a))."""
    basis = typical_section(20.0, 6 / 25, 2 / 5, -1 / 5, 1 / 10)
    system = statespace.build(basis, 1.0, 1.0, rfa="rfa4")
    sw = stability.sweep(system, np.arange(0.0, 6.0 + 1e-9, 0.01))
    assert sw.divergence.status == stability.CONVERGED
    assert sw.divergence.mechanism == "torsional"
    assert sw.divergence.label == basis.labels[1]  # the pitch coordinate
