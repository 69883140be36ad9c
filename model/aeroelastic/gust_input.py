"""Quasi-steady gust inputs of an aeroelastic system: ``Bw1`` from the bridge's
``[static_coefficients]``.

:func:`quasi_steady_inputs` replaces the thin-aerofoil gust-input matrix ``Bw1`` of an
:class:`~bridgeflap.model.aeroelastic.statespace.AeroelasticSystem` (Theodorsen or Roger state
space) by the quasi-steady ``w`` loads of :func:`bridgeflap.model.aero.quasi_steady.gust_inputs` and
puts the ``u`` loads in ``system.extras["Bw1_u"]``. Used by the buffeting inputs
(:func:`bridgeflap.model.response.buffeting_inputs.resolve_system`) and by the state space of a
bridge with flutter-derivative loads
(:func:`bridgeflap.model.aeroelastic.derivative_system.derivative_bridge_system`). Conventions:
:mod:`bridgeflap.model`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["quasi_steady_inputs"]


def quasi_steady_inputs(system, spec):
    """``system`` with the quasi-steady gust inputs (``Bw1`` = w, ``extras["Bw1_u"]`` = u)."""
    import dataclasses

    from bridgeflap.model.aero.quasi_steady import gust_inputs

    basis = system.basis
    P_w, P_u = gust_inputs(basis, 2.0 * spec.deck.half_chord_m, spec.aero.air_density_kg_m3,
                           spec.static_coefficients, system.extras.get("phi_p"))
    M_t = basis.M + system.aero.M_nc  # the mass of the q'' rows (model.aeroelastic.assembly)
    iv = system.index.q_dot
    Bw, Bu = np.zeros_like(system.Bw1), np.zeros_like(system.Bw1)
    Bw[iv] = np.linalg.solve(M_t, P_w)
    Bu[iv] = np.linalg.solve(M_t, P_u)
    extras = dict(system.extras, Bw1_u=Bu if np.any(Bu) else None)
    return dataclasses.replace(system, Bw1=Bw, extras=extras)
