"""Generalised structural coordinates that carry the aerodynamic strips.

A :class:`StructuralBasis` is what the aeroelastic assembly
(:mod:`bridgeflap.model.aeroelastic.assembly`) needs of a structure: generalised mass, damping and
stiffness and the strip heave/pitch per coordinate. It is produced by
:meth:`bridgeflap.model.structure.modes.ModalModel.structural_basis` (mass-normalised modes), by
:func:`bridgeflap.model.structure.ritz.ritz_basis` (a perturbed structure on the nominal modes) and
by
:func:`bridgeflap.model.cases.section.section_basis` (a rigid two-DOF section). Conventions:
:mod:`bridgeflap.model`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["StructuralBasis"]


@dataclass(frozen=True)
class StructuralBasis:
    """Generalised structural coordinates carrying the aerodynamic strips.

    Attributes
    ----------
    M, C, K : ndarray (n, n)
        Structural mass, damping, stiffness in the generalised coordinates.
    phi_h, phi_a : ndarray (n_strip, n)
        Strip heave [m] and pitch [rad] per unit coordinate.
    strip_length : ndarray (n_strip,)
        [m].
    strip_x : ndarray (n_strip,)
        Strip position [m] (for coherence and plots).
    labels : tuple of str
        Names of the coordinates (mode labels such as ``TS1``).
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    phi_h: np.ndarray
    phi_a: np.ndarray
    strip_length: np.ndarray
    strip_x: np.ndarray
    labels: tuple

    @property
    def n(self) -> int:
        """Number of generalised coordinates."""
        return self.M.shape[0]

    @property
    def n_strip(self) -> int:
        """Number of aerodynamic strips."""
        return self.phi_h.shape[0]
