"""Strip loads of the deck and of the flaps (the paper's Eqs. 2-3, Theodorsen TR-496), written once.

Per unit span, with the elastic axis at mid-chord (``a = 0``; conventions in
:mod:`bridgeflap.model`), every load of this package has the form of :class:`SectionLoads`: for a
unit input ``x`` (deck heave ``h``, deck pitch ``alpha``, or a flap drive angle ``beta``)::

    [L_down, M_mid] = e2 x'' + U e1 x' + U^2 e0 x + [-2 pi rho b, pi rho b^2] U C(k) Q
    Q = U g0 x + b g1 x'                                   (3/4-chord downwash)

The deck (the paper's Eqs. 2-3, ``Q = U alpha + h' + b alpha'/2``)::

    L = -pi rho b^2 (U alpha' + h'') - 2 pi rho U b C(k) Q
    M = -pi rho b^2 (b U alpha'/2 + kappa b^2 alpha''/8) + pi rho U b^2 C(k) Q

``kappa = 1`` keeps the apparent-inertia moment (default), ``kappa = 0`` drops it (Scanlan).
A trailing-edge (TE) flap hinged at ``x = c b`` (TE-down positive)::

    L_down = rho b^2 (U T4 beta' + b T1 beta'') - 2 pi rho U b C(k) Q_f
    M_mid  = -rho b^2 [(T4 + T10) U^2 beta + (T1 - T8 - c T4 + T11/2) U b beta'
                       - (T7 + c T1) b^2 beta''] + pi rho U b^2 C(k) Q_f
    Q_f    = (T10/pi) U beta + (b T11 / (2 pi)) beta'

A leading-edge (LE) flap hinged at ``x = e b`` (``e < 0``, LE-up positive) is a rigid pitch of
the whole chord about ``x = e b`` (the deck loads with ``h = -e b delta``, ``alpha = delta``)
plus a TE flap ``beta = -delta`` hinged at ``c = e``
(docs/humber_data.md#flap-loads-and-t-functions); the drive signs of the LE+TE pair are
described in :mod:`bridgeflap.model.aeroelastic.flaps`.

Projection (:func:`project` for the deck strips, :func:`load_map` for the flap strips): strips
of length ``dl_i`` with heave ``phi_h[i] q`` and pitch ``phi_a[i] q`` give the generalised
force ``-M_nc q'' - U D_nc q' + U P [C(k) (G1 q' + U G0 q)] + U P_g w`` with
``P[:, i] = dl_i (-2 pi rho b phi_h[i] + pi rho b^2 phi_a[i])^T``, ``G1 = phi_h + b/2 phi_a``,
``G0 = phi_a`` and the buffeting map ``P_g[:, i] = dl_i (-rho b C_L' phi_h[i] + 2 rho b^2 C_M'
phi_a[i])^T`` for the vertical gust ``w`` (up positive) from the paper's Eqs. (7)-(8) with
``C_L = C_M = C_D = 0``.

The coefficients are plain arithmetic, so ``b`` and ``rho`` may be CasADi symbols
(:mod:`bridgeflap.model.aeroelastic.symbolic`); the strip geometry is always numeric.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bridgeflap.model.aero.basis import StructuralBasis
from bridgeflap.model.aero.theodorsen import t_functions
from bridgeflap.model.errors import BridgeflapInputError

__all__ = [
    "SectionLoads",
    "StripAero",
    "circulatory_lift",
    "deck_section_loads",
    "flap_section_loads",
    "load_map",
    "project",
    "strip_aero",
]


@dataclass(frozen=True)
class SectionLoads:
    """Per-unit-span loads of one unit input (module docstring for the form).

    Attributes
    ----------
    e2 : tuple (2,)
        Lift down [N/m per input unit s^-2] and mid-chord moment nose-up per ``x''``.
    e1 : tuple (2,)
        The same per ``U x'``.
    e0 : tuple (2,)
        The same per ``U^2 x``.
    g0, g1 : float
        Downwash coefficients [-] (``Q = U g0 x + b g1 x'``).
    """

    e2: tuple
    e1: tuple
    e0: tuple
    g0: object
    g1: object

    def __add__(self, other: SectionLoads) -> SectionLoads:
        def add(a, b):
            return (a[0] + b[0], a[1] + b[1])

        return SectionLoads(add(self.e2, other.e2), add(self.e1, other.e1),
                            add(self.e0, other.e0), self.g0 + other.g0, self.g1 + other.g1)

    def scaled(self, factor) -> SectionLoads:
        """The loads of the input ``factor * x``."""
        def mul(a):
            return (factor * a[0], factor * a[1])

        return SectionLoads(mul(self.e2), mul(self.e1), mul(self.e0), factor * self.g0,
                            factor * self.g1)

    def steady(self, air_density: float, half_chord: float) -> tuple[float, float]:
        """Steady ``(dC_L/dx, dC_M,mid/dx)`` [1/rad], C_L up on ``q 2b``, C_M on ``q (2b)^2``.

        ``k = 0`` (``C = 1``), ``U = 1``: ``L_down = e0[0] - 2 pi rho b g0``,
        ``M = e0[1] + pi rho b^2 g0``.
        """
        rho, b = air_density, half_chord
        lift_up = -(self.e0[0] - 2 * np.pi * rho * b * self.g0)
        moment = self.e0[1] + np.pi * rho * b * b * self.g0
        return float(lift_up / (rho * b)), float(moment / (2 * rho * b * b))


def circulatory_lift(half_chord, air_density) -> tuple:
    """``(-2 pi rho b, pi rho b^2)``: lift down and moment of a unit ``U C(k) Q`` (Eqs. 2-3)."""
    b, rho = half_chord, air_density
    return (-2 * np.pi * rho * b, np.pi * rho * b ** 2)


def deck_section_loads(half_chord, air_density, kappa=1.0) -> tuple[SectionLoads, SectionLoads]:
    """Deck loads of unit heave ``h`` and unit pitch ``alpha`` (the paper's Eqs. 2-3).

    Returns
    -------
    (SectionLoads, SectionLoads)
        Heave (``e2 = (-pi rho b^2, 0)``, ``Q = h'``) and pitch (``e2 = (0, -kappa pi rho
        b^4/8)``, ``e1 = (-pi rho b^2, -pi rho b^3/2)``, ``Q = U alpha + b alpha'/2``).
    """
    b, rho = half_chord, air_density
    heave = SectionLoads((-np.pi * rho * b ** 2, 0.0), (0.0, 0.0), (0.0, 0.0), 0.0, 1.0 / b)
    pitch = SectionLoads((0.0, -kappa * np.pi * rho * b ** 4 / 8.0),
                         (-np.pi * rho * b ** 2, -np.pi * rho * b ** 3 / 2.0), (0.0, 0.0),
                         1.0, 0.5)
    return heave, pitch


def _te_loads(c: float, rho: float, b: float) -> SectionLoads:
    """TR-496 TE-flap loads, ``a = 0``, lift down (module docstring)."""
    t = t_functions(c)
    T1, T4, T7, T8, T10, T11 = (float(t[k]) for k in ("T1", "T4", "T7", "T8", "T10", "T11"))
    return SectionLoads((rho * b**3 * T1, rho * b**4 * (T7 + c * T1)),
                        (rho * b**2 * T4, -rho * b**3 * (T1 - T8 - c * T4 + 0.5 * T11)),
                        (0.0, -rho * b**2 * (T4 + T10)), T10 / np.pi, T11 / (2 * np.pi))


def _rigid_pitch_loads(e: float, rho: float, b: float, kappa: float) -> SectionLoads:
    """Deck loads of a rigid pitch ``delta`` about ``x = e b`` (``h = -e b delta``)."""
    heave, pitch = deck_section_loads(b, rho, kappa)
    return heave.scaled(-e * b) + pitch


def flap_section_loads(half_chord: float, air_density: float, flap_chord_m: float,
                       leading_edge: bool = True, trailing_edge: bool = True,
                       added_inertia: bool = True) -> SectionLoads:
    """Per-unit-span loads of the flap pair for the drive angle ``beta = K alpha``.

    Parameters
    ----------
    half_chord : float
        Deck half-chord ``b`` [m].
    air_density : float
        [kg/m^3].
    flap_chord_m : float
        Chordwise size of each flap inside the deck chord [m], ``0 < chord < b``.
    leading_edge, trailing_edge : bool
        Which flaps are fitted (:mod:`bridgeflap.model.aeroelastic.flaps` for the drive signs).
    added_inertia : bool
        Keep the apparent-inertia moment of the rigid-pitch part of the LE flap (as for the
        deck, :mod:`bridgeflap.model`); the TE-flap T-functions always contain their own.
    """
    b, rho = float(half_chord), float(air_density)
    chord = float(flap_chord_m)
    if not (np.isfinite(chord) and 0.0 < chord < b):
        raise BridgeflapInputError("flap_chord_m",
                                   f"must lie in (0, b = {b} m) so LE and TE flaps fit in the "
                                   f"deck chord, got {flap_chord_m!r}")
    c = (b - chord) / b
    kappa = 1.0 if added_inertia else 0.0
    total = SectionLoads((0.0, 0.0), (0.0, 0.0), (0.0, 0.0), 0.0, 0.0)
    if trailing_edge:
        total = total + _te_loads(c, rho, b)
    if leading_edge:
        e = -c
        total = total + _rigid_pitch_loads(e, rho, b, kappa) + _te_loads(e, rho, b).scaled(-1.0)
    return total


def project(inputs, phi_h, phi_a, length):
    """Generalised loads of inputs on a set of strips: ``(H2, H1, H0)``.

    Parameters
    ----------
    inputs : sequence of (SectionLoads, array (m, k))
        The loads of each unit input and the input at each strip per unit of ``k`` variables.
    phi_h, phi_a : array (m, n)
        Strip heave [m] and pitch [rad] per unit coordinate (the virtual displacements).
    length : array (m,)
        Strip lengths [m].

    Returns
    -------
    tuple
        ``H_j = sum_inputs e_j[0] phi_h^T diag(dl) X + e_j[1] phi_a^T diag(dl) X`` for
        ``j = 2, 1, 0``: the generalised force per ``x''``, ``U x'`` and ``U^2 x``.
    """
    dl = np.asarray(length)[:, None]
    grams = [(ld, phi_h.T @ (dl * X), phi_a.T @ (dl * X)) for ld, X in inputs]
    out = []
    for name in ("e2", "e1", "e0"):
        total = 0.0
        for ld, Gh, Ga in grams:
            e = getattr(ld, name)
            total = total + (e[0] * Gh + e[1] * Ga)
        out.append(total)
    return tuple(out)


def load_map(loads: SectionLoads, phi_h, phi_a) -> tuple:
    """``(E2, E1, E0)``: generalised force per unit load input at each of ``m`` strips.

    ``E_j[:, i] = e_j[0] phi_h[i] + e_j[1] phi_a[i]`` (n, m), per unit strip length.
    """
    return tuple(phi_h.T * e[0] + phi_a.T * e[1] for e in (loads.e2, loads.e1, loads.e0))


@dataclass(frozen=True)
class StripAero:
    """Aerodynamic matrices of a :class:`~bridgeflap.model.aero.basis.StructuralBasis` (module
    docstring)."""

    M_nc: np.ndarray
    D_nc: np.ndarray
    P: np.ndarray
    G0: np.ndarray
    G1: np.ndarray
    P_gust: np.ndarray
    half_chord: float
    air_density: float


def _check_positive(name, value):
    if isinstance(value, int | float | np.floating) and not (np.isfinite(value) and value > 0):
        raise BridgeflapInputError(name, f"must be positive, got {value}")


def strip_aero(basis: StructuralBasis, half_chord, air_density, added_inertia: bool = True,
               lift_slope_buffeting: float = 2 * np.pi,
               moment_slope_buffeting: float = np.pi / 2) -> StripAero:
    """Deck strip matrices of a basis (the deck loads of :func:`deck_section_loads` projected).

    Parameters
    ----------
    half_chord : float or casadi.SX
        ``b`` [m].
    air_density : float or casadi.SX
        ``rho`` [kg/m^3].
    added_inertia : bool
        Keep the apparent-inertia moment ``pi rho b^4 alpha''/8`` (the paper's Eq. 3).
    lift_slope_buffeting, moment_slope_buffeting : float
        ``C_L'`` and ``C_M'`` [1/rad] of the buffeting loads (the paper's Eqs. 7-8).
    """
    _check_positive("half_chord_m", half_chord)
    _check_positive("air_density_kg_m3", air_density)
    numeric = isinstance(half_chord, int | float | np.floating) and isinstance(
        air_density, int | float | np.floating)
    b, rho = (float(half_chord), float(air_density)) if numeric else (half_chord, air_density)
    heave, pitch = deck_section_loads(b, rho, 1.0 if added_inertia else 0.0)
    dl = basis.strip_length[:, None]
    ph, pa = basis.phi_h, basis.phi_a
    H2, H1, _ = project(((heave, ph), (pitch, pa)), ph, pa, basis.strip_length)
    circ = circulatory_lift(b, rho)
    P_gust = (dl * (-rho * b * lift_slope_buffeting * ph
                    + 2 * rho * b ** 2 * moment_slope_buffeting * pa)).T
    return StripAero(M_nc=-H2, D_nc=-H1, P=(dl * (circ[0] * ph + circ[1] * pa)).T,
                     G0=heave.g0 * ph + pitch.g0 * pa,
                     G1=(b * heave.g1) * ph + (b * pitch.g1) * pa,
                     P_gust=P_gust, half_chord=b, air_density=rho)
