"""Leading- and trailing-edge deck flaps driven by a compensator: closed-loop state space.

Conventions (h down, alpha nose-up, moment about mid-chord, lift in the equations positive
down, ``b`` half-chord) are those of :mod:`model`. Seed paper §6, Eq. (18); METHODS §5;
HUMBER_DATA §4(c).

Flap loads (per unit span, Theodorsen TR-496 with ``a = 0``)
-----------------------------------------------------------
A trailing-edge (TE) flap hinged at ``x = c b`` with angle ``beta`` (TE-down positive, the
rotational sense of nose-up ``alpha``)::

    L_down = rho b^2 (U T4 beta' + b T1 beta'') - 2 pi rho U b C(k) Q_f
    M_mid  = -rho b^2 [(T4 + T10) U^2 beta + (T1 - T8 - c T4 + T11/2) U b beta'
                       - (T7 + c T1) b^2 beta''] + pi rho U b^2 C(k) Q_f
    Q_f    = (T10/pi) U beta + (b T11 / (2 pi)) beta'

A leading-edge (LE) flap hinged at ``x = e b`` (``e < 0``) with angle ``delta`` in the same
rotational sense (LE-up positive) is, exactly in linear thin-aerofoil theory, a rigid pitch
``delta`` of the whole chord about ``x = e b`` (mid-chord heave ``h = -e b delta``, pitch
``delta``, i.e. the deck loads of :mod:`model.aero` with ``Q_r = U delta + b (1/2 - e) delta'``)
plus a TE flap ``beta = -delta`` hinged at ``c = e`` (HUMBER_DATA §4(c)). The circulatory
flap terms enter the same downwash that the deck's lag states filter, so the rational
approximation of C(k) of the deck (:mod:`model.rfa`) filters them too.

Flap geometry: each flap has chord ``flap_chord_m`` measured from its edge *inside* the deck
chord ``2 b`` (hinge ``c = (b - chord)/b`` for the TE flap and ``e = -c`` for the LE flap;
3 m in seed §6). ``Controller.flap_width_m`` is the flap's *spanwise* length; the flap loads
act at the strip centre with the mode shapes interpolated there (strip theory).

Drive ("the same (actually anti-symmetric)", seed §6)
------------------------------------------------------
The controller angle of a TE flap is TE-down positive and that of a LE flap LE-down positive
(each flap's tip down, mirror images of each other). ``beta_TE = +K alpha`` and
``beta_LE = -K alpha`` (the package convention, :mod:`model.control`) then means both flaps
rotate by ``K alpha`` in the rotational sense of ``alpha``: the deck-plus-flaps section is
point-antisymmetric, which is the only choice that behaves the same for wind from either side
(reflecting the section swaps LE and TE and flips the sign of ``alpha``). In steady flow the
LE and TE flaps then give the *same* nose-up mid-chord moment (``-T4(c)/2`` each), doubling a
single flap's moment, while the LE flap adds only ``2(theta_h - sin theta_h)`` of lift.

Closed loop
-----------
Each flap ``f`` has its own compensator state pair ``xc_f' = Ac xc_f + Bc alpha_f`` with
``alpha_f`` the deck pitch at its strip; ``beta_f``, ``beta_f'``, ``beta_f''`` follow from
:meth:`model.control.Compensator.second_derivative_feedthrough`. The ``beta''`` term contains
``Dc alpha_f''``, so the effective mass ``M + M_nc - Dc H2 Phi_a`` is nonsymmetric. ``U`` still
enters polynomially: ``A(U) = A0 + U A1 + U^2 A2`` with state
``x = (q, q', lag states, compensator states)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from model import statespace
from model.aero import StructuralBasis
from model.control import Compensator, Controller
from model.errors import BridgeflapInputError
from model.statespace import AeroelasticSystem, StateIndex
from model.theodorsen import t_functions

__all__ = [
    "DEFAULT_FLAP_CHORD_M",
    "ClosedLoopModel",
    "FlapSectionLoads",
    "FlapSet",
    "closed_loop_flutter",
    "closed_loop_model",
    "closed_loop_state_space",
    "closed_loop_pk_flutter",
    "closed_loop_system",
    "section_model",
    "flap_section_loads",
    "flap_set",
]

#: Chordwise flap size of seed §6 [m] ("the width of the flap is assumed to be 3 m").
DEFAULT_FLAP_CHORD_M = 3.0


# --------------------------------------------------------------------------- section loads


@dataclass(frozen=True)
class FlapSectionLoads:
    """Per-unit-span loads of a flap (or LE+TE pair) for a unit drive angle ``beta``.

    ``[L_down, M_mid] = e2 beta'' + U e1 beta' + U^2 e0 beta + [-2 pi rho b, pi rho b^2] U C Q``
    with ``Q = U g0 beta + b g1 beta'``.

    Attributes
    ----------
    e2 : ndarray (2,)
        [N s^2/m per rad, N s^2 per rad] (lift down, mid-chord moment nose-up).
    e1 : ndarray (2,)
        [N s/m^2 per rad, N s/m per rad] (multiplies ``U beta'``).
    e0 : ndarray (2,)
        [N/m^3 per rad ...] (multiplies ``U^2 beta``).
    g0, g1 : float
        Downwash coefficients [-].
    """

    e2: np.ndarray
    e1: np.ndarray
    e0: np.ndarray
    g0: float
    g1: float

    def __add__(self, other: FlapSectionLoads) -> FlapSectionLoads:
        return FlapSectionLoads(self.e2 + other.e2, self.e1 + other.e1, self.e0 + other.e0,
                                self.g0 + other.g0, self.g1 + other.g1)

    def scaled(self, factor: float) -> FlapSectionLoads:
        """The loads of ``factor * beta``."""
        return FlapSectionLoads(factor * self.e2, factor * self.e1, factor * self.e0,
                                factor * self.g0, factor * self.g1)

    def steady(self, air_density: float, half_chord: float) -> tuple[float, float]:
        """Steady ``(dC_L/dbeta, dC_M,mid/dbeta)`` [1/rad], C_L up on ``q 2b``, C_M on ``q (2b)^2``.

        ``k = 0`` (``C = 1``), ``U = 1``: ``L_down = e0[0] - 2 pi rho b g0``,
        ``M = e0[1] + pi rho b^2 g0``.
        """
        rho, b = air_density, half_chord
        lift_up = -(self.e0[0] - 2 * np.pi * rho * b * self.g0)
        moment = self.e0[1] + np.pi * rho * b * b * self.g0
        return float(lift_up / (rho * b)), float(moment / (2 * rho * b * b))


def _te_loads(c: float, rho: float, b: float) -> FlapSectionLoads:
    """TR-496 TE-flap loads, ``a = 0``, lift down (module docstring)."""
    t = t_functions(c)
    T1, T4, T7, T8, T10, T11 = (float(t[k]) for k in ("T1", "T4", "T7", "T8", "T10", "T11"))
    e2 = np.array([rho * b**3 * T1, rho * b**4 * (T7 + c * T1)])
    e1 = np.array([rho * b**2 * T4, -rho * b**3 * (T1 - T8 - c * T4 + 0.5 * T11)])
    e0 = np.array([0.0, -rho * b**2 * (T4 + T10)])
    return FlapSectionLoads(e2, e1, e0, T10 / np.pi, T11 / (2 * np.pi))


def _rigid_pitch_loads(e: float, rho: float, b: float, kappa: float) -> FlapSectionLoads:
    """Deck loads (seed Eqs. 2-3) of a rigid pitch ``delta`` about ``x = e b`` (h = -e b delta)."""
    e2 = np.array([np.pi * rho * b**3 * e, -kappa * np.pi * rho * b**4 / 8.0])
    e1 = np.array([-np.pi * rho * b**2, -np.pi * rho * b**3 / 2.0])
    e0 = np.zeros(2)
    return FlapSectionLoads(e2, e1, e0, 1.0, 0.5 - e)


def flap_section_loads(half_chord: float, air_density: float, flap_chord_m: float,
                       leading_edge: bool = True, trailing_edge: bool = True,
                       added_inertia: bool = True) -> FlapSectionLoads:
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
        Which flaps are fitted (module docstring for the drive signs).
    added_inertia : bool
        Keep the apparent-inertia moment of the rigid-pitch part of the LE flap (as for the
        deck, :mod:`model`); the TE-flap T-functions always contain their own.

    Returns
    -------
    FlapSectionLoads
    """
    b, rho = float(half_chord), float(air_density)
    chord = float(flap_chord_m)
    if not (np.isfinite(chord) and 0.0 < chord < b):
        raise BridgeflapInputError("flap_chord_m",
                                   f"must lie in (0, b = {b} m) so LE and TE flaps fit in the "
                                   f"deck chord, got {flap_chord_m!r}")
    c = (b - chord) / b
    kappa = 1.0 if added_inertia else 0.0
    total = FlapSectionLoads(np.zeros(2), np.zeros(2), np.zeros(2), 0.0, 0.0)
    if trailing_edge:
        total = total + _te_loads(c, rho, b)
    if leading_edge:
        e = -c
        total = total + _rigid_pitch_loads(e, rho, b, kappa) + _te_loads(e, rho, b).scaled(-1.0)
    return total


# --------------------------------------------------------------------------- flap geometry


@dataclass(frozen=True)
class FlapSet:
    """Flaps on a structural basis: mode shapes at the flap strips.

    Attributes
    ----------
    phi_h, phi_a : ndarray (n_flap, n)
        Heave [m] and pitch [rad] at each flap centre per unit coordinate.
    width_m : ndarray (n_flap,)
        Spanwise length of each flap [m].
    position_m : ndarray (n_flap,)
        Flap centres from the main-span mid-point [m] (0 for a section).
    loads : FlapSectionLoads
        Per-unit-span loads of the LE+TE pair per unit drive angle.
    """

    phi_h: np.ndarray
    phi_a: np.ndarray
    width_m: np.ndarray
    position_m: np.ndarray
    loads: FlapSectionLoads

    @property
    def n_flaps(self) -> int:
        """Number of flap strips."""
        return self.phi_h.shape[0]


def _main_span_frame(spec) -> tuple[float, float]:
    """(global x of the main-span mid-point, main-span length) [m]."""
    lengths = [s.length_m for s in spec.spans]
    start = float(sum(lengths[: spec.main_span_index]))
    length = float(lengths[spec.main_span_index])
    return start + 0.5 * length, length


def flap_set(spec, basis: StructuralBasis, positions_m, width_m, flap_chord_m: float,
             leading_edge: bool = True, trailing_edge: bool = True) -> FlapSet:
    """Flaps at ``positions_m`` (from the main-span mid-point) on a bridge's structural basis.

    Raises
    ------
    BridgeflapInputError
        ``controller.flap_strip_positions_m`` when a flap reaches outside the main span.
    """
    mid, length = _main_span_frame(spec)
    pos = np.asarray(positions_m, dtype=float).ravel()
    width = np.broadcast_to(np.asarray(width_m, dtype=float), pos.shape).copy()
    outside = np.abs(pos) + 0.5 * width > 0.5 * length + 1e-9
    if np.any(outside):
        i = int(np.flatnonzero(outside)[0])
        raise BridgeflapInputError(
            "controller.flap_strip_positions_m",
            f"flap {i} at {pos[i]:g} m (width {width[i]:g} m) reaches outside the main span "
            f"(|x| + width/2 <= {0.5 * length:g} m)")
    x = mid + pos
    order = np.argsort(basis.strip_x)
    sx = basis.strip_x[order]
    phi_h = np.column_stack([np.interp(x, sx, basis.phi_h[order, j]) for j in range(basis.n)])
    phi_a = np.column_stack([np.interp(x, sx, basis.phi_a[order, j]) for j in range(basis.n)])
    a = spec.aero
    loads = flap_section_loads(spec.deck.half_chord_m, a.air_density_kg_m3, flap_chord_m,
                               leading_edge, trailing_edge, a.added_inertia)
    return FlapSet(phi_h=phi_h, phi_a=phi_a, width_m=width, position_m=pos, loads=loads)


# --------------------------------------------------------------------------- assembly


def compensator_matrices(theta):
    """Controllable canonical realisation of K(s) for symbolic ``theta = (b2, b1, b0, a2, a1)``.

    Same realisation as :meth:`model.control.Compensator.state_space` (second order, ``a2 > 0``).
    Returns ``(Ac, Bc, Cc, Dc)`` as CasADi expressions.
    """
    b2, b1, b0, a2, a1 = (theta[i] for i in range(5))
    d1, d0 = a1 / a2, 1.0 / a2
    c2, c1, c0 = b2 / a2, b1 / a2, b0 / a2
    Ac = ca.vertcat(ca.horzcat(0.0, 1.0), ca.horzcat(-d0, -d1))
    Bc = ca.DM([[0.0], [1.0]])
    Cc = ca.horzcat(c0 - c2 * d0, c1 - c2 * d1)
    Dc = c2
    return Ac, Bc, Cc, Dc


def _assemble(system: AeroelasticSystem, flaps: FlapSet, Ac, Bc, Cc, Dc, weights):
    """Closed-loop ``(A0, A1, A2, M_eff)`` as CasADi expressions (module docstring).

    ``Ac, Bc, Cc, Dc`` and ``weights`` (per-flap load factor in [0, 1]) may be numeric (DM)
    or symbolic (SX/MX).
    """
    if system.order != "modal":
        raise BridgeflapInputError("order", "closed-loop flaps are assembled in modal order")
    B, a, rfa = system.basis, system.aero, system.rfa
    n, nl, nF = B.n, rfa.n_lags, flaps.n_flaps
    nc = int(Ac.shape[0])
    b, rho = a.half_chord, a.air_density
    ld = flaps.loads
    nx = 2 * n + nl * n + nc * nF
    iq, iv = slice(0, n), slice(n, 2 * n)
    icomp = slice(2 * n + nl * n, nx)
    Phih, Phia = flaps.phi_h, flaps.phi_a
    symbolic = [x for x in (Ac, Cc, Dc, weights) if isinstance(x, (ca.SX, ca.MX))]
    zeros = type(symbolic[0]).zeros if symbolic else ca.DM.zeros
    scale = ca.DM(flaps.width_m) * weights           # (nF, 1) width x weight
    Dscale = ca.diag(scale)

    def force_map(e):          # generalised force per unit flap drive (n, nF)
        return ca.mtimes(ca.DM(Phih.T * e[0] + Phia.T * e[1]), Dscale)

    H2, H1, H0 = force_map(ld.e2), force_map(ld.e1), force_map(ld.e0)
    PF = ca.mtimes(ca.DM(-2 * np.pi * rho * b * Phih.T + np.pi * rho * b * b * Phia.T), Dscale)

    cb = ca.mtimes(Cc, Bc)
    cab = ca.mtimes(ca.mtimes(Cc, Ac), Bc)
    eye_f = ca.DM.eye(nF)
    PhA = ca.DM(Phia)

    def beta_map(qcoef, vcoef, row):     # (nF, nx) map of a beta derivative
        S = zeros(nF, nx)
        S[:, iq] = qcoef * PhA
        S[:, iv] = vcoef * PhA
        S[:, icomp] = ca.kron(eye_f, row)
        return S

    S0 = beta_map(Dc, 0.0, Cc)
    S1 = beta_map(cb, Dc, ca.mtimes(Cc, Ac))
    S2 = beta_map(cab, cb, ca.mtimes(ca.mtimes(Cc, Ac), Ac))   # without Dc alpha''

    Z0 = zeros(n, nx)
    Z0[:, iv] = ca.DM(a.P @ a.G1)
    Z0 = Z0 + b * ld.g1 * ca.mtimes(PF, S1)
    Z1 = zeros(n, nx)
    Z1[:, iq] = ca.DM(a.P @ a.G0)
    Z1 = Z1 + ld.g0 * ca.mtimes(PF, S0)

    F0 = zeros(n, nx)
    F0[:, iq] = ca.DM(-B.K)
    F0[:, iv] = ca.DM(-B.C)
    F0 = F0 + ca.mtimes(H2, S2)
    F1 = zeros(n, nx)
    F1[:, iv] = ca.DM(-a.D_nc)
    for j in range(nl):
        lj = slice(2 * n + j * n, 2 * n + (j + 1) * n)
        F1[:, lj] = float(rfa.gains[j]) * ca.DM.eye(n)
    F1 = F1 + 0.5 * Z0 + ca.mtimes(H1, S1)
    F2 = 0.5 * Z1 + ca.mtimes(H0, S0)
    M_eff = ca.DM(B.M + a.M_nc) - Dc * ca.mtimes(H2, PhA)

    A0, A1, A2 = zeros(nx, nx), zeros(nx, nx), zeros(nx, nx)
    A0[iq, iv] = ca.DM.eye(n)
    rows = ca.solve(M_eff, ca.horzcat(F0, F1, F2))
    A0[iv, :] = rows[:, :nx]
    A1[iv, :] = rows[:, nx:2 * nx]
    A2[iv, :] = rows[:, 2 * nx:]
    for j in range(nl):
        lj = slice(2 * n + j * n, 2 * n + (j + 1) * n)
        rate = float(rfa.poles[j]) / b
        E = zeros(n, nx)
        E[:, lj] = ca.DM.eye(n)
        A1[lj, :] = rate * (Z0 - E)
        A2[lj, :] = rate * Z1
    A0[icomp, icomp] = ca.kron(eye_f, Ac)
    A0[icomp, iq] = ca.mtimes(ca.kron(eye_f, Bc), PhA)
    return A0, A1, A2, M_eff, S0


@dataclass
class ClosedLoopModel:
    """Open-loop aeroelastic system plus flaps; builds closed-loop matrices for any K(s).

    Attributes
    ----------
    open_loop : AeroelasticSystem
    flaps : FlapSet
    """

    open_loop: AeroelasticSystem
    flaps: FlapSet
    _functions: dict = field(default_factory=dict, repr=False)

    @property
    def n_flaps(self) -> int:
        """Number of flap strips."""
        return self.flaps.n_flaps

    def _names(self, nc: int) -> tuple:
        return tuple(self.open_loop.index.names) + tuple(
            f"xc{i + 1}[flap{f}]" for f in range(self.n_flaps) for i in range(nc))

    def system(self, compensator: Compensator, weights=None) -> AeroelasticSystem:
        """Closed-loop :class:`~model.statespace.AeroelasticSystem` for a numeric K(s).

        Parameters
        ----------
        compensator : Compensator
        weights : array_like, optional
            Per-flap load factor [-] (1 = fitted, 0 = absent); default all ones.
        """
        w = np.ones(self.n_flaps) if weights is None else np.asarray(weights, float).ravel()
        Ac, Bc, Cc, Dc = (ca.DM(m) for m in compensator.state_space())
        A0, A1, A2, M_eff, S0 = _assemble(self.open_loop, self.flaps, Ac, Bc, Cc,
                                          float(Dc[0, 0]), ca.DM(w))
        ol = self.open_loop
        nx = A0.shape[0]
        n = ol.basis.n
        Bw1 = np.zeros((nx, ol.Bw1.shape[1]))
        Bw1[n:2 * n] = np.linalg.solve(np.asarray(M_eff.full() if hasattr(M_eff, "full")
                                                  else M_eff), ol.aero.P_gust)
        nol = ol.n_states
        C_out = np.zeros((ol.C_out.shape[0], nx))
        C_out[:, :nol] = ol.C_out
        index = StateIndex(q=ol.index.q, q_dot=ol.index.q_dot, aero_lag=ol.index.aero_lag,
                           compensator=slice(nol, nx), n=nx,
                           names=self._names(compensator.order))
        extras = {"flap_angle_map": np.asarray(ca.DM(S0).full()), "compensator": compensator,
                  "weights": w, "flaps": self.flaps}
        return AeroelasticSystem(A0=np.asarray(ca.DM(A0).full()), A1=np.asarray(ca.DM(A1).full()),
                                 A2=np.asarray(ca.DM(A2).full()), Bw1=Bw1, C_out=C_out,
                                 index=index, basis=ol.basis, aero=ol.aero, rfa=ol.rfa,
                                 order=ol.order, extras=extras)

    def casadi_functions(self) -> dict:
        """Symbolic closed loop, built once.

        Returns
        -------
        dict
            ``"A_cl"``: ``ca.Function("A_cl", [U, theta, w], [A])`` with ``theta = (b2, b1,
            b0, a2, a1)`` and ``w`` the per-flap weights; ``"A_parts"``: ``(theta, w) ->
            (A0, A1, A2)``.
        """
        if not self._functions:
            theta = ca.SX.sym("theta", 5)
            w = ca.SX.sym("w", self.n_flaps)
            U = ca.SX.sym("U")
            Ac, Bc, Cc, Dc = compensator_matrices(theta)
            A0, A1, A2, _, _ = _assemble(self.open_loop, self.flaps, Ac, Bc, Cc, Dc, w)
            parts = ca.Function("A_parts", [theta, w], [A0, A1, A2], ["theta", "w"],
                                ["A0", "A1", "A2"])
            th2, w2 = ca.SX.sym("theta", 5), ca.SX.sym("w", self.n_flaps)
            P0, P1, P2 = parts(th2, w2)
            A = P0 + U * P1 + U * U * P2
            self._functions["A_parts"] = parts
            self._functions["A_cl"] = ca.Function("A_cl", [U, th2, w2], [A],
                                                  ["U", "theta", "w"], ["A"])
        return self._functions

    # ------------------------------------------------------------------ exact (p-k) check
    def exact_matrix(self, compensator: Compensator, wind_speed: float, c_value: complex,
                     weights=None) -> np.ndarray:
        """First-order matrix with C(k) frozen at ``c_value`` (no lag states), numpy only.

        State ``(q, q', xc)``; an eigenvalue ``p`` of it solves the exact flutter equation with
        ``K(p)`` in the flap loads when ``c_value = C(|Im p| b / U)`` (p-k iteration). This is
        an independent numpy assembly used to check the CasADi one.
        """
        ol, fl = self.open_loop, self.flaps
        B, a = ol.basis, ol.aero
        U, b, rho = float(wind_speed), a.half_chord, a.air_density
        n, nF = B.n, fl.n_flaps
        w = np.ones(nF) if weights is None else np.asarray(weights, float)
        Ac, Bc, Cc, Dc = compensator.state_space()
        nc = Ac.shape[0]
        dc = float(Dc[0, 0])
        ld = fl.loads
        sc = fl.width_m * w
        # beta = Cb x with x = (q, v, xc); beta' = Cb1 x; beta'' = Cb2 x + dc Phia v'
        nx = 2 * n + nc * nF
        Cb0 = np.zeros((nF, nx), complex)
        Cb1 = np.zeros((nF, nx), complex)
        Cb2 = np.zeros((nF, nx), complex)
        cb = float((Cc @ Bc)[0, 0])
        cab = float((Cc @ Ac @ Bc)[0, 0])
        for f in range(nF):
            cols = slice(2 * n + nc * f, 2 * n + nc * (f + 1))
            Cb0[f, :n] = dc * fl.phi_a[f]
            Cb0[f, cols] = Cc[0]
            Cb1[f, :n] = cb * fl.phi_a[f]
            Cb1[f, n:2 * n] = dc * fl.phi_a[f]
            Cb1[f, cols] = (Cc @ Ac)[0]
            Cb2[f, :n] = cab * fl.phi_a[f]
            Cb2[f, n:2 * n] = cb * fl.phi_a[f]
            Cb2[f, cols] = (Cc @ Ac @ Ac)[0]
        lift = -2 * np.pi * rho * b * fl.phi_h.T + np.pi * rho * b * b * fl.phi_a.T
        Hk = [(fl.phi_h.T * e[0] + fl.phi_a.T * e[1]) * sc for e in (ld.e0, ld.e1, ld.e2)]
        PF = lift * sc
        Q = np.zeros((n, nx), complex)                      # generalised circulatory downwash
        Q[:, :n] = U * a.P @ a.G0
        Q[:, n:2 * n] = a.P @ a.G1
        Q += PF @ (U * ld.g0 * Cb0 + b * ld.g1 * Cb1)
        F = np.zeros((n, nx), complex)
        F[:, :n] -= B.K
        F[:, n:2 * n] -= B.C + U * a.D_nc
        F += U * c_value * Q + U * U * Hk[0] @ Cb0 + U * Hk[1] @ Cb1 + Hk[2] @ Cb2
        M_eff = B.M + a.M_nc - dc * Hk[2] @ fl.phi_a
        A = np.zeros((nx, nx), complex)
        A[:n, n:2 * n] = np.eye(n)
        A[n:2 * n] = np.linalg.solve(M_eff, F)
        for f in range(nF):
            cols = slice(2 * n + nc * f, 2 * n + nc * (f + 1))
            A[cols, cols] = Ac
            A[cols, :n] = Bc @ fl.phi_a[f][None, :]
        return A


# --------------------------------------------------------------------------- spec-level API


def controller_flaps(spec, basis: StructuralBasis, controller: Controller,
                     flap_chord_m: float = DEFAULT_FLAP_CHORD_M) -> FlapSet:
    """The :class:`FlapSet` of a :class:`~model.control.Controller` on a bridge basis."""
    return flap_set(spec, basis, controller.flap_strip_positions_m, controller.flap_width_m,
                    flap_chord_m, controller.leading_edge, controller.trailing_edge)


def closed_loop_model(spec, positions_m, width_m, n_modes: int = 16,
                      flap_chord_m: float = DEFAULT_FLAP_CHORD_M, leading_edge: bool = True,
                      trailing_edge: bool = True, modal=None) -> ClosedLoopModel:
    """Open-loop bridge system plus a flap layout (compensator chosen later)."""
    from model.analysis import bridge_system

    _, system = bridge_system(spec, n_modes, modal=modal)
    flaps = flap_set(spec, system.basis, positions_m, width_m, flap_chord_m, leading_edge,
                     trailing_edge)
    return ClosedLoopModel(system, flaps)


def section_model(basis: StructuralBasis, half_chord: float, air_density: float,
                  flap_chord_m: float, flap_width_m: float = 1.0, leading_edge: bool = True,
                  trailing_edge: bool = True, rfa: str = "rfa4",
                  added_inertia: bool = True) -> ClosedLoopModel:
    """A 2-DOF section (:func:`model.section.section_basis`) with one flap strip of unit span."""
    system = statespace.build(basis, half_chord, air_density, rfa=rfa,
                              added_inertia=added_inertia)
    loads = flap_section_loads(half_chord, air_density, flap_chord_m, leading_edge,
                               trailing_edge, added_inertia)
    flaps = FlapSet(phi_h=basis.phi_h[:1].copy(), phi_a=basis.phi_a[:1].copy(),
                    width_m=np.array([float(flap_width_m)]), position_m=np.zeros(1),
                    loads=loads)
    return ClosedLoopModel(system, flaps)


def closed_loop_system(spec, controller: Controller, n_modes: int = 16,
                       flap_chord_m: float = DEFAULT_FLAP_CHORD_M) -> AeroelasticSystem:
    """Closed-loop system with the AeroelasticSystem interface (``A(U)``, ``B_gust(U)``, ...)."""
    model = closed_loop_model(spec, controller.flap_strip_positions_m, controller.flap_width_m,
                              n_modes, flap_chord_m, controller.leading_edge,
                              controller.trailing_edge)
    return model.system(controller.compensator)


def closed_loop_state_space(spec, controller: Controller, speed: float, n_modes: int = 16,
                            flap_chord_m: float = DEFAULT_FLAP_CHORD_M):
    """``(A, B, C, D, state_names, input_names, output_names)`` of the closed loop at ``speed``.

    Inputs: strip gust velocities [m/s] (up, before admittance). Outputs: strip heave [m],
    strip pitch [rad], then each flap's drive angle ``beta = K alpha`` [rad].
    """
    sys_cl = closed_loop_system(spec, controller, n_modes, flap_chord_m)
    U = float(speed)
    A, B = sys_cl.A(U), sys_cl.B_gust(U)
    C = np.vstack([sys_cl.C_out, sys_cl.extras["flap_angle_map"]])
    D = np.zeros((C.shape[0], B.shape[1]))
    ns = sys_cl.basis.n_strip
    inputs = [f"gust_w[strip{i}] (m/s, up, before admittance)" for i in range(ns)]
    outputs = ([f"heave[strip{i}] (m, down)" for i in range(ns)]
               + [f"pitch[strip{i}] (rad, nose-up)" for i in range(ns)]
               + [f"beta[flap{f}] (rad, TE flap TE-down; LE flap = -beta, LE-down)"
                  for f in range(controller.n_flaps)])
    return A, B, C, D, list(sys_cl.index.names), inputs, outputs


@dataclass(frozen=True)
class ClosedLoopFlutterResult:
    """Closed-loop stability sweep plus the open-loop reference."""

    base: object            # model.analysis.FlutterResult of the closed loop
    open_loop: object       # model.analysis.FlutterResult without flaps
    controller: Controller

    def summary(self) -> dict:
        """Same keys as :meth:`model.analysis.FlutterResult.summary`, plus closed-loop info.

        ``divergence_static_speed_m_s`` is the open-loop static check (the closed-loop
        divergence is the eigenvalue crossing ``divergence_speed_m_s``).
        """
        s = self.base.summary()
        ol = self.open_loop.summary()
        k = self.controller.compensator
        s.update({
            "closed_loop": True,
            "flap_count": self.controller.n_flaps,
            "compensator": {"b2": k.b2, "b1": k.b1, "b0": k.b0, "a2": k.a2, "a1": k.a1},
            "max_gain": k.max_gain(),
            "gain_limit": self.controller.gain_limit,
            "open_loop_flutter_speed_m_s": ol["flutter_speed_m_s"],
            "open_loop_flutter_status": ol["flutter_status"],
            "open_loop_divergence_speed_m_s": ol["divergence_speed_m_s"],
            "open_loop_divergence_status": ol["divergence_status"],
        })
        return s

    def plot(self, axes=None):
        """Closed-loop root locus and damping/frequency against speed."""
        return self.base.sweep.plot(axes, title=f"{self.base.spec.name} with "
                                                f"{self.controller.n_flaps} flap pairs:")


def closed_loop_flutter(spec, controller: Controller, speeds, n_modes: int = 16,
                        flap_chord_m: float = DEFAULT_FLAP_CHORD_M) -> ClosedLoopFlutterResult:
    """Closed-loop flutter/divergence sweep (and the open-loop one for reference)."""
    from model.analysis import FlutterResult, bridge_system, parse_range
    from model.stability import check_speeds, sweep

    u = parse_range(speeds, "speeds", 0.0) if isinstance(speeds, str) else check_speeds(speeds)
    modal, system = bridge_system(spec, n_modes)
    flaps = controller_flaps(spec, system.basis, controller, flap_chord_m)
    cl = ClosedLoopModel(system, flaps).system(controller.compensator)
    base = FlutterResult(spec, sweep(cl, u), int(n_modes), "modal", "rfa4", cl.n_states)
    ol = FlutterResult(spec, sweep(system, u), int(n_modes), "modal", "rfa4", system.n_states)
    return ClosedLoopFlutterResult(base, ol, controller)


# --------------------------------------------------------------------------- p-k cross-check


def _pk_point(model: ClosedLoopModel, compensator: Compensator, U: float, p_guess: complex,
              tol: float = 1e-10, maxit: int = 200) -> tuple[complex, bool]:
    """One p-k solution: ``p`` eigenvalue of :meth:`ClosedLoopModel.exact_matrix` with
    ``C = C(|Im p| b / U)`` (exact Theodorsen), continued from ``p_guess``."""
    from model.theodorsen import theodorsen

    b = model.open_loop.aero.half_chord
    p = complex(p_guess)
    for _ in range(maxit):
        k = abs(p.imag) * b / U
        c = complex(theodorsen(k)) if k > 0 else 1.0 + 0j
        lam = np.linalg.eigvals(model.exact_matrix(compensator, U, c))
        p_new = lam[np.argmin(np.abs(lam - p))]
        if abs(p_new - p) < tol * max(1.0, abs(p)):
            return p_new, True
        p = p_new
    return p, False


def closed_loop_pk_flutter(model: ClosedLoopModel, compensator: Compensator, speeds,
                           speed_tol: float = 1e-4):
    """Closed-loop flutter speed by the p-k method with exact Theodorsen and ``K(p)``.

    Each structural branch is continued from its ``U = 0`` eigenvalue; ``K(p)`` is exact
    because the compensator is part of the first-order matrix. Returns
    ``(speed [m/s], frequency [Hz], status, branches)``.
    """
    from scipy.optimize import brentq

    from model.stability import BRACKET_FAILED, CONVERGED, NO_CROSSING

    speeds = np.asarray(speeds, float)
    speeds = speeds[speeds > 0]
    lam0 = model.open_loop.structural_eigenvalues()
    branches = np.zeros((len(lam0), len(speeds)), complex)
    for j, p in enumerate(lam0):
        for i, U in enumerate(speeds):
            p, _ = _pk_point(model, compensator, U, p)
            branches[j, i] = p
    best = None
    for j in range(len(lam0)):
        re = branches[j].real
        idx = np.flatnonzero((re[:-1] < 0) & (re[1:] >= 0) & (np.abs(branches[j, 1:].imag) > 0))
        if idx.size and (best is None or idx[0] < best[1]):
            best = (j, int(idx[0]))
    if best is None:
        return float("nan"), float("nan"), NO_CROSSING, branches
    j, i = best

    def f(U):
        return _pk_point(model, compensator, U, branches[j, i])[0].real

    try:
        u = float(brentq(f, speeds[i], speeds[i + 1], xtol=speed_tol))
    except ValueError:
        return float("nan"), float("nan"), BRACKET_FAILED, branches
    p = _pk_point(model, compensator, u, branches[j, i])[0]
    return u, abs(p.imag) / (2 * np.pi), CONVERGED, branches
