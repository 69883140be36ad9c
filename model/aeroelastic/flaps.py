"""Leading- and trailing-edge deck flaps driven by a compensator: closed-loop state space.

Conventions (h down, alpha nose-up, moment about mid-chord, lift in the equations positive
down, ``b`` half-chord) are those of :mod:`bridgeflap.model`. The paper, §6, Eq. (18);
docs/methods.md#flap-loads; docs/humber_data.md#flap-loads-and-t-functions.

Flap loads: the TR-496 strip loads of :mod:`bridgeflap.model.aero.strips`
(:func:`bridgeflap.model.aero.strips.flap_section_loads`); the circulatory flap terms enter the same
downwash that the deck's lag states filter, so the rational approximation of C(k) of the deck
(:mod:`bridgeflap.model.aero.rfa`) filters them too. The assembly with the compensator fed back is
the one of
:mod:`bridgeflap.model.aeroelastic.assembly`.

Flap geometry: each flap has chord ``flap_chord_m`` measured from its edge *inside* the deck
chord ``2 b`` (hinge ``c = (b - chord)/b`` for the TE flap and ``e = -c`` for the LE flap;
3 m in the paper, §6). ``Controller.flap_width_m`` is the flap's *spanwise* length; the flap loads
act at the strip centre with the mode shapes interpolated there (strip theory).

Drive ("the same (actually anti-symmetric)", the paper, §6)
------------------------------------------------------
The controller angle of a TE flap is TE-down positive and that of a LE flap LE-down positive
(each flap's tip down, mirror images of each other). ``beta_TE = +K alpha`` and
``beta_LE = -K alpha`` (the package convention, :mod:`bridgeflap.model.aeroelastic.control`) then
means both flaps rotate by ``K alpha`` in the rotational sense of ``alpha``: the deck-plus-flaps
section is point-antisymmetric, which is the only choice that behaves the same for wind from either
side (reflecting the section swaps LE and TE and flips the sign of ``alpha``). In steady flow the
LE and TE flaps then give the *same* nose-up mid-chord moment (``-T4(c)/2`` each), doubling a
single flap's moment, while the LE flap adds only ``2(theta_h - sin theta_h)`` of lift.

Closed loop
-----------
Each flap ``f`` has its own compensator state pair ``xc_f' = Ac xc_f + Bc alpha_f`` with
``alpha_f`` the deck pitch at its strip; ``beta_f``, ``beta_f'``, ``beta_f''`` follow from
:meth:`bridgeflap.model.aeroelastic.control.Compensator.second_derivative_feedthrough`. The
``beta''`` term contains ``Dc alpha_f''``, so the effective mass ``M + M_nc - Dc H2 Phi_a`` is
nonsymmetric. ``U`` still enters polynomially: ``A(U) = A0 + U A1 + U^2 A2`` with state
``x = (q, q', lag states, compensator states)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bridgeflap.model.aero.basis import StructuralBasis
from bridgeflap.model.aero.strips import SectionLoads, flap_section_loads
from bridgeflap.model.aeroelastic import statespace
from bridgeflap.model.aeroelastic.assembly import (
    OpenPieces,
    dynamic_matrices,
    open_pieces,
    rfa_parts,
)
from bridgeflap.model.aeroelastic.backend import is_symbolic
from bridgeflap.model.aeroelastic.control import DEFAULT_FLAP_CHORD_M, Compensator, Controller
from bridgeflap.model.aeroelastic.controller_file import as_controller
from bridgeflap.model.aeroelastic.statespace import AeroelasticSystem, StateIndex
from bridgeflap.model.arguments import flag, number, numbers
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.spectrum import polynomial_abscissa
from bridgeflap.model.structure.bridge_arg import takes_bridge
from bridgeflap.model.structure.fe import assemble
from bridgeflap.model.structure.modes import solve
from bridgeflap.model.vocabulary import DEFAULT_MODES

__all__ = [
    "DEFAULT_FLAP_CHORD_M",
    "ClosedLoopModel",
    "FlapSet",
    "closed_loop_model",
    "closed_loop_state_space",
    "closed_loop_system",
    "section_model",
    "flap_set",
]


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
    loads : bridgeflap.model.aero.strips.SectionLoads
        Per-unit-span loads of the LE+TE pair per unit drive angle.
    """

    phi_h: np.ndarray
    phi_a: np.ndarray
    width_m: np.ndarray
    position_m: np.ndarray
    loads: SectionLoads

    @property
    def n_flaps(self) -> int:
        """Number of flap strips."""
        return int(np.size(self.width_m))


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


# --------------------------------------------------------------------------- closed loop


@dataclass
class ClosedLoopModel:
    """Open-loop aeroelastic system plus flaps; builds closed-loop matrices for any K(s).

    A thin front of :mod:`bridgeflap.model.aeroelastic.assembly`: numeric matrices from
    :meth:`system`, the named CasADi functions from :meth:`casadi_functions`
    (:func:`bridgeflap.model.aeroelastic.symbolic.closed_loop_functions`).

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

    def _weights(self, weights) -> np.ndarray:
        return np.ones(self.n_flaps) if weights is None else np.asarray(weights, float).ravel()

    def pieces(self, weights=None) -> OpenPieces:
        """Open-loop pieces with the flap inputs
        (:func:`bridgeflap.model.aeroelastic.assembly.open_pieces`).

        ``weights`` (per-flap load factor [-]) may be numeric or a CasADi symbol.

        Parameters
        ----------
        weights : array_like or CasADi symbol, optional
            Per-flap load factor [-] (1 = fitted, 0 = absent); default all ones.

        Returns
        -------
        OpenPieces
            The open-loop polynomial pieces with the flap load columns.
        """
        ol = self.open_loop
        w = self._weights(weights) if not is_symbolic(weights) else weights
        return open_pieces(ol.basis, ol.aero, ol.order, self.flaps, w)

    def _names(self, nc: int) -> tuple:
        return tuple(self.open_loop.index.names) + tuple(
            f"xc{i + 1}[flap{f}]" for f in range(self.n_flaps) for i in range(nc))

    def system(self, compensator: Compensator, weights=None) -> AeroelasticSystem:
        """Closed-loop :class:`~bridgeflap.model.aeroelastic.statespace.AeroelasticSystem` for a
        numeric K(s).

        Parameters
        ----------
        compensator : Compensator
            The numeric ``K(s)`` on every flap.
        weights : array_like, optional
            Per-flap load factor [-] (1 = fitted, 0 = absent); default all ones.

        Returns
        -------
        AeroelasticSystem
            The open-loop states and the compensator states of every flap.
        """
        w = self._weights(weights)
        Ac, Bc, Cc, Dc = compensator.state_space()
        comp = (Ac, Bc, Cc, float(Dc[0, 0]))
        op = self.pieces(w)
        ol = self.open_loop
        A0, A1, A2, M_eff, S0 = rfa_parts(op, ol.rfa, comp)
        nx = A0.shape[0]
        n = ol.basis.n
        Bw1 = np.zeros((nx, ol.Bw1.shape[1]))
        Bw1[n:2 * n] = np.linalg.solve(M_eff, ol.aero.P_gust)
        nol = ol.n_states
        C_out = np.zeros((ol.C_out.shape[0], nx))
        C_out[:, :nol] = ol.C_out
        index = StateIndex(q=ol.index.q, q_dot=ol.index.q_dot, aero_lag=ol.index.aero_lag,
                           compensator=slice(nol, nx), n=nx,
                           names=self._names(compensator.order))
        extras = {"flap_angle_map": S0, "compensator": compensator, "weights": w,
                  "flaps": self.flaps}
        return AeroelasticSystem(A0=A0, A1=A1, A2=A2, Bw1=Bw1, C_out=C_out, index=index,
                                 basis=ol.basis, aero=ol.aero, rfa=ol.rfa, order=ol.order,
                                 extras=extras, pieces=op, compensator=comp)

    def casadi_functions(self) -> dict:
        """Symbolic closed loop, built once
        (:func:`bridgeflap.model.aeroelastic.symbolic.closed_loop_functions`).

        Returns
        -------
        dict
            ``"A_cl"``: ``ca.Function("A_cl", [U, theta, w], [A])`` with ``theta = (b2, b1,
            b0, a2, a1)`` and ``w`` the per-flap weights; ``"A_parts"``: ``(theta, w) ->
            (A0, A1, A2)``.
        """
        if not self._functions:
            from bridgeflap.model.aeroelastic.symbolic import closed_loop_functions

            self._functions.update(closed_loop_functions(self))
        return self._functions

    def plant(self, wind_speed: float, s, weights=None) -> tuple[np.ndarray, np.ndarray]:
        """Flap-loop plant factors ``(Pa, X)`` with ``G(s) = Pa X(s) diag(w)`` (RFA aero).

        ``G`` maps the flap drive angles [rad] to the deck pitch at the flaps [rad]: ``X =
        D(s)^{-1} F_beta(s)`` from :func:`bridgeflap.model.aeroelastic.assembly.dynamic_matrices`
        with ``C`` the RFA of the state space at ``s b / U`` (``C = 1`` at ``U = 0``), so ``G`` is
        the exact transfer function of the RFA state space. ``weights`` scale the flap loads inside
        ``X`` (default ones: then ``X`` is the unit-weight factor of the design code).

        Parameters
        ----------
        wind_speed : float
            ``U`` [m/s].
        s : array_like
            Complex frequencies [1/s] (``1j * omega`` for a frequency response).

        Returns
        -------
        Pa : ndarray (n_flaps, n_modes)
            Pitch at the flap strips per unit modal coordinate [rad].
        X : ndarray (len(s), n_modes, n_flaps) complex
        """
        Pa, X, _ = self._responses(wind_speed, s, weights, gust=False)
        return Pa, X

    def gust_plant(self, wind_speed: float, s, weights=None):
        """``(Pa, X, X_gust)``: :meth:`plant` and the open-loop gust transfer ``X_gust = D(s)^{-1}
        U P_gust`` (len(s), n_modes, n_strips) [modal coordinate per m/s of strip gust
        velocity after the admittance], from the same ``D(s)``. With the loop ``beta = K
        alpha``, ``q = (I - K X diag(w) Pa)^{-1} X_gust w_tilde`` (the closed-loop gust
        response of the RFA state space ``AeroelasticSystem.B_gust``).

        Parameters
        ----------
        wind_speed : float
            ``U`` [m/s].
        s : array_like of complex
            Laplace variables [1/s].
        weights : array_like, optional
            Per-flap load factor [-] (1 = fitted, 0 = absent); default all ones.

        Returns
        -------
        tuple of numpy.ndarray
            ``Pa`` (flaps x modes), ``X`` (len(s), modes, flaps) and ``X_gust`` (len(s),
            modes, strips).
        """
        return self._responses(wind_speed, s, weights, gust=True)

    def _responses(self, wind_speed, s, weights, gust):
        op = self.pieces(weights)
        ol = self.open_loop
        U, b = float(wind_speed), ol.aero.half_chord
        s = np.atleast_1d(np.asarray(s, complex))
        X = np.zeros((len(s), op.n, self.n_flaps), complex)
        P = U * np.asarray(ol.aero.P_gust, float) if gust else None
        Xg = np.zeros((len(s), op.n, P.shape[1]), complex) if gust else None
        for i, p in enumerate(s):
            c = complex(ol.rfa.evaluate_s(p * b / U)) if U > 0 else 1.0
            D, F = dynamic_matrices(op, U, p, c)
            if gust:
                Y = np.linalg.solve(D, np.hstack([F, P]))
                X[i], Xg[i] = Y[:, :self.n_flaps], Y[:, self.n_flaps:]
            else:
                X[i] = np.linalg.solve(D, F)
        return np.asarray(self.flaps.phi_a, float), X, Xg

    def abscissa(self, compensator: Compensator, speeds, weights=None) -> np.ndarray:
        """Closed-loop spectral abscissa [1/s] per speed (lag states dropped at ``U = 0``).

        Parameters
        ----------
        compensator : Compensator
            The numeric ``K(s)`` on every flap.
        speeds : array_like
            Wind speeds [m/s].
        weights : array_like, optional
            Per-flap load factor [-] (1 = fitted, 0 = absent); default all ones.

        Returns
        -------
        numpy.ndarray
            The largest real part of the closed-loop eigenvalues [1/s] at each speed.
        """
        sys_cl = self.system(compensator, weights)
        keep = np.ones(sys_cl.n_states, bool)
        keep[sys_cl.index.aero_lag] = False
        return polynomial_abscissa((sys_cl.A0, sys_cl.A1, sys_cl.A2), speeds,
                                   np.flatnonzero(keep))


# --------------------------------------------------------------------------- spec-level API


def controller_flaps(spec, basis: StructuralBasis, controller: Controller,
                     flap_chord_m: float | None = None) -> FlapSet:
    """The :class:`FlapSet` of a :class:`~bridgeflap.model.aeroelastic.control.Controller` on a
    bridge basis (``flap_chord_m`` default: the controller's own,
    :attr:`~bridgeflap.model.aeroelastic.control.Controller.chord_m`)."""
    chord = controller.chord_m if flap_chord_m is None else flap_chord_m
    return flap_set(spec, basis, controller.flap_strip_positions_m, controller.flap_width_m,
                    chord, controller.leading_edge, controller.trailing_edge)


@takes_bridge(positions_m=numbers, width_m=number(0.0, 1.0e4, strict=True),
              leading_edge=flag, trailing_edge=flag)
def closed_loop_model(bridge, positions_m, width_m, n_modes: int = DEFAULT_MODES,
                      flap_chord_m: float = DEFAULT_FLAP_CHORD_M, leading_edge: bool = True,
                      trailing_edge: bool = True, modal=None) -> ClosedLoopModel:
    """Open-loop bridge system plus a flap layout (compensator chosen later).

    Parameters
    ----------
    bridge : str, path-like or BridgeSpec
        A built-in name, a bridge TOML file or a spec.
    positions_m : sequence of float
        Flap strip centres along the main span from its mid-point [m].
    width_m : float
        Spanwise width of each flap strip [m].
    n_modes : int, default 30
        Retained vertical + torsional modes.
    flap_chord_m : float, default 3.0
        Chordwise flap size from each deck edge [m].
    leading_edge, trailing_edge : bool, default True
        Which flaps are fitted (the leading-edge ones driven by -K, the trailing-edge ones by +K).
    modal : ModalModel, optional
        Modes already solved for ``bridge``.

    Returns
    -------
    ClosedLoopModel
        The open-loop system and the flap loads; ``system(controller)`` closes it.

    Raises
    ------
    BridgeflapInputError
        A bad bridge or a flap outside the main span.
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
    modal = solve(assemble(spec)) if modal is None else modal
    system = statespace.spec_system(spec, modal.structural_basis(int(n_modes)))
    flaps = flap_set(spec, system.basis, positions_m, width_m, flap_chord_m, leading_edge,
                     trailing_edge)
    return ClosedLoopModel(system, flaps)


def section_model(basis: StructuralBasis, half_chord: float, air_density: float,
                  flap_chord_m: float, flap_width_m: float = 1.0, leading_edge: bool = True,
                  trailing_edge: bool = True, rfa: str = "rfa4",
                  added_inertia: bool = True) -> ClosedLoopModel:
    """A 2-DOF section (:func:`bridgeflap.model.cases.section.section_basis`) with one flap strip of
    unit span."""
    system = statespace.build(basis, half_chord, air_density, rfa=rfa,
                              added_inertia=added_inertia)
    loads = flap_section_loads(half_chord, air_density, flap_chord_m, leading_edge,
                               trailing_edge, added_inertia)
    flaps = FlapSet(phi_h=basis.phi_h[:1].copy(), phi_a=basis.phi_a[:1].copy(),
                    width_m=np.array([float(flap_width_m)]), position_m=np.zeros(1),
                    loads=loads)
    return ClosedLoopModel(system, flaps)


@takes_bridge(controller=as_controller)
def closed_loop_system(spec, controller: Controller, n_modes: int = DEFAULT_MODES,
                       flap_chord_m: float | None = None) -> AeroelasticSystem:
    """Closed-loop system with the AeroelasticSystem interface (``A(U)``, ``B_gust(U)``,
    ...); ``flap_chord_m`` default: the controller's own
    (:attr:`~bridgeflap.model.aeroelastic.control.Controller.chord_m`)."""
    chord = controller.chord_m if flap_chord_m is None else flap_chord_m
    model = closed_loop_model(spec, controller.flap_strip_positions_m, controller.flap_width_m,
                              n_modes, chord, controller.leading_edge,
                              controller.trailing_edge)
    return model.system(controller.compensator)


@takes_bridge(controller=as_controller)
def closed_loop_state_space(bridge, controller: Controller, speed: float,
                            n_modes: int = DEFAULT_MODES,
                            flap_chord_m: float | None = None):
    """``(A, B, C, D, state_names, input_names, output_names)`` of the closed loop at ``speed``.

    Inputs: strip gust velocities [m/s] (up, before admittance). Outputs: strip heave [m],
    strip pitch [rad], then each flap's drive angle ``beta = K alpha`` [rad].

    Parameters
    ----------
    bridge : str, path-like or BridgeSpec
        A built-in name, a bridge TOML file or a spec.
    controller : Controller
        The compensator and its flap layout.
    speed : float
        Wind speed [m/s], ``>= 0``.
    n_modes : int, default 30
        Retained vertical + torsional modes.
    flap_chord_m : float, optional
        Chordwise flap size [m] (default: the controller's own).

    Returns
    -------
    tuple
        ``(A, B, C, D, state_names, input_names, output_names)``: numpy arrays and lists of str.

    Raises
    ------
    BridgeflapInputError
        A bad bridge, speed or controller.
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
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
