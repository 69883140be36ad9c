"""Strip-theory aerodynamic matrices from Theodorsen's thin-aerofoil loads (seed Eqs. 2-3).

Per unit span, with the elastic axis at mid-chord (``a = 0``; conventions in :mod:`model`)::

    L = -pi rho b^2 (U alpha' + h'') - 2 pi rho U b C(k) Q            (down, seed Eq. 2)
    M = -pi rho b^2 (b U alpha'/2 + kappa b^2 alpha''/8) + pi rho U b^2 C(k) Q   (Eq. 3)
    Q = U alpha + h' + b alpha'/2                                      (3/4-chord downwash)

``kappa = 1`` keeps the apparent-inertia moment (default), ``kappa = 0`` drops it (Scanlan
convention). Projected on generalised coordinates ``q`` with strip heave ``h_i = phi_h[i] q`` and
pitch ``alpha_i = phi_a[i] q``, over strips of length ``dl_i``::

    generalised force = -M_nc q'' - U D_nc q' + U P [C(k) (G1 q' + U G0 q)] + U P_g w

with ``P[:, i] = dl_i (-2 pi rho b phi_h[i] + pi rho b^2 phi_a[i])^T``, ``G1 = phi_h + b/2 phi_a``,
``G0 = phi_a`` and the buffeting map ``P_g[:, i] = dl_i (-rho b C_L' phi_h[i] +
2 rho b^2 C_M' phi_a[i])^T`` for the vertical gust ``w`` (up positive) from seed Eqs. (7)-(8)
with ``C_L = C_M = C_D = 0``; the admittance multiplies ``w`` in the frequency domain.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from model.errors import BridgeflapInputError


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


@dataclass(frozen=True)
class StripAero:
    """Aerodynamic matrices of a :class:`StructuralBasis` (see module docstring)."""

    M_nc: np.ndarray
    D_nc: np.ndarray
    P: np.ndarray
    G0: np.ndarray
    G1: np.ndarray
    P_gust: np.ndarray
    half_chord: float
    air_density: float


def strip_aero(basis: StructuralBasis, half_chord: float, air_density: float,
               added_inertia: bool = True, lift_slope_buffeting: float = 2 * np.pi,
               moment_slope_buffeting: float = np.pi / 2) -> StripAero:
    """Build the strip-theory matrices.

    Parameters
    ----------
    half_chord : float
        ``b`` [m].
    air_density : float
        ``rho`` [kg/m^3].
    added_inertia : bool
        Keep the apparent-inertia moment ``pi rho b^4 alpha''/8`` (seed Eq. 3).
    lift_slope_buffeting, moment_slope_buffeting : float
        ``C_L'`` and ``C_M'`` [1/rad] of the buffeting loads (seed Eqs. 7-8).
    """
    if not (np.isfinite(half_chord) and half_chord > 0):
        raise BridgeflapInputError("half_chord_m", f"must be positive, got {half_chord}")
    if not (np.isfinite(air_density) and air_density > 0):
        raise BridgeflapInputError("air_density_kg_m3", f"must be positive, got {air_density}")
    b, rho = float(half_chord), float(air_density)
    kappa = 1.0 if added_inertia else 0.0
    dl = basis.strip_length[:, None]
    ph, pa = basis.phi_h, basis.phi_a
    M_nc = np.pi * rho * b ** 2 * (ph.T @ (dl * ph)) \
        + kappa * np.pi * rho * b ** 4 / 8.0 * (pa.T @ (dl * pa))
    D_nc = (np.pi * rho * b ** 2 * (ph.T @ (dl * pa))
            + np.pi * rho * b ** 3 / 2.0 * (pa.T @ (dl * pa)))
    P = (dl * (-2 * np.pi * rho * b * ph + np.pi * rho * b ** 2 * pa)).T
    P_gust = (dl * (-rho * b * lift_slope_buffeting * ph
                    + 2 * rho * b ** 2 * moment_slope_buffeting * pa)).T
    return StripAero(M_nc=M_nc, D_nc=D_nc, P=P, G0=pa.copy(), G1=ph + 0.5 * b * pa,
                     P_gust=P_gust, half_chord=b, air_density=rho)
