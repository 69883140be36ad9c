"""Named CasADi functions of the one assembly: open-loop ``A(U, p)``, closed-loop ``A_cl``.

Both are built by :mod:`bridgeflap.model.aeroelastic.assembly` from CasADi symbols (the backend shim
of
:mod:`bridgeflap.model.aeroelastic.backend`), from the same code as the numeric matrices of
:mod:`bridgeflap.model.aeroelastic.statespace` and :mod:`bridgeflap.model.aeroelastic.flaps`. This
is one of the two files of :mod:`bridgeflap.model` allowed to import CasADi.

Open loop, modal lag order: ``A(U, p)``.

``p`` holds the parameters a designer varies, **relative to nominal** (``p = 1`` is the bridge
file's value), in the order of :data:`SYMBOLIC_PARAMETERS`:

========================  ==========================================================
``damping.ratio``         Rayleigh ratio; ``C = zeta/zeta0 (a_M M + a_K K)`` (coefficients
                          fitted at the nominal first vertical and torsional frequencies)
``deck.mass_kg_per_m``    enters the mass and, through the dead load, the cable tension
``deck.mass_inertia_...`` torsional mass
``deck.gj_nm2``           torsional stiffness
``deck.ei_vertical_nm2``  vertical bending stiffness
``cable.main_sag_m``      cable tension, geometric and cable-stretching stiffness
``deck.half_chord_m``     ``b`` in every aerodynamic term and in the lag rates ``beta U/b``
``aero.air_density...``   ``rho`` in every aerodynamic term
========================  ==========================================================

The structural parameters act through a **Ritz projection on the nominal modes**: with ``Phi``
the retained mass-normalised nominal modes, ``M(p) = I + sum_k (p_k - 1) Phi^T dM_k Phi`` and
likewise for ``K``, where ``dM_k = p0_k dM_FE/dp_k`` is the change of the assembled FE matrices
(central difference of the assembly, exact for the parameters that enter linearly: mass,
inertia, GJ, EI; first order for the sag and the dead-load part of the deck mass) of the Ritz
basis of :func:`bridgeflap.model.structure.ritz.ritz_basis`. This is
exact at nominal and first-order accurate away from it within the retained basis; the numeric
path (:func:`bridgeflap.model.aeroelastic.statespace.spec_system` on re-solved modes) re-solves the
modes instead. Half-chord and air density enter exactly. ``U`` enters as ``A0 + U A1 + U^2 A2`` as
in
:mod:`bridgeflap.model.aeroelastic.statespace`.

Closed loop (:func:`closed_loop_functions`): ``A_cl(U, theta, w)`` and ``A_parts(theta, w) ->
(A0, A1, A2)`` with the compensator coefficients ``theta = (b2, b1, b0, a2, a1)`` and the
per-flap weights ``w``, the functions the compensator optimiser differentiates.

Spectral RMS (:func:`casadi_spectral_variance`, :func:`buffeting_rms_function`): the one-sided
output variance ``sigma_j^2 = int_0^omega_max G_yy,jj d omega`` with ``G_yy = H G_ww H^H`` and
``H = C (i omega I - A)^{-1} B`` (the paper's Eqs. (10)-(12), (17)) on a *fixed* grid (trapezoid
weights), the convention of :mod:`bridgeflap.model.spectral`. The complex solve is written in real
arithmetic: ``[[-A, -omega I], [omega I, -A]] [Xr; Xi] = [B; 0]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from bridgeflap.model.aero.basis import StructuralBasis
from bridgeflap.model.aero.rfa import RationalApprox, get_rfa
from bridgeflap.model.aero.strips import strip_aero
from bridgeflap.model.aeroelastic.assembly import open_pieces, rfa_parts
from bridgeflap.model.aeroelastic.control import canonical_realisation
from bridgeflap.model.arguments import checked, describe
from bridgeflap.model.errors import BridgeflapInputError, BridgeflapTypeError
from bridgeflap.model.spectral import trapezoid_weights
from bridgeflap.model.structure.bridge_arg import BridgeArg, takes_bridge
from bridgeflap.model.structure.fe import assemble
from bridgeflap.model.structure.modes import ModalModel, solve
from bridgeflap.model.structure.ritz import chosen_modes, ritz_basis
from bridgeflap.model.structure.spec import BridgeSpec, get_path

__all__ = [
    "SYMBOLIC_PARAMETERS",
    "SymbolicModel",
    "buffeting_rms_function",
    "build_symbolic",
    "casadi_spectral_rms",
    "casadi_spectral_variance",
    "closed_loop_functions",
]

SYMBOLIC_PARAMETERS = (
    "damping.ratio",
    "deck.mass_kg_per_m",
    "deck.mass_inertia_kgm2_per_m",
    "deck.gj_nm2",
    "deck.ei_vertical_nm2",
    "cable.main_sag_m",
    "deck.half_chord_m",
    "aero.air_density_kg_m3",
)
_STRUCTURAL = SYMBOLIC_PARAMETERS[1:6]


@dataclass(frozen=True)
class SymbolicModel:
    """``A_fun(U, p)``, ``B_fun(U, p)`` (gust input) and ``parts_fun(p) -> (A0, A1, A2)``."""

    A_fun: ca.Function
    B_fun: ca.Function
    parts_fun: ca.Function
    parameters: tuple
    nominal_values: np.ndarray
    n_modes: int
    labels: tuple
    n_states: int

    def A(self, wind_speed: float, p=None) -> np.ndarray:
        """Numeric ``A`` at ``wind_speed`` [m/s] and relative parameters ``p`` (default 1).

        Parameters
        ----------
        wind_speed : float
            ``U`` [m/s].
        p : array_like, optional
            Each of ``parameters`` relative to its nominal value [-] (default all 1).

        Returns
        -------
        numpy.ndarray
            The state matrix (``n_states`` square).
        """
        p = np.ones(len(self.parameters)) if p is None else np.asarray(p, dtype=float)
        return np.array(self.A_fun(wind_speed, p))


def _gust_input(M_t, P_gust, n_states: int):
    """``B_gust / U``: strip gust velocities [m/s] to the ``q'`` rows, ``M_t^{-1} P_gust``."""
    n = M_t.shape[0]
    P = P_gust if isinstance(P_gust, ca.SX | ca.MX) else ca.DM(P_gust)
    return ca.vertcat(ca.DM.zeros(n, P_gust.shape[1]), ca.solve(M_t, P),
                      ca.DM.zeros(n_states - 2 * n, P_gust.shape[1]))


def _projected_derivatives(spec: BridgeSpec, modal: ModalModel, n_modes: int,
                           rel_step: float = 1e-3) -> dict:
    """``(dM_k, dK_k)`` per unit relative change of each structural parameter (Ritz basis)."""
    out = {}
    for path in _STRUCTURAL:
        p0 = get_path(spec, path)
        plus, minus = (ritz_basis(spec.replace(**{path: p0 * (1 + sgn * rel_step)}), modal,
                                  n_modes) for sgn in (+1, -1))
        out[path] = ((plus.M - minus.M) / (2 * rel_step), (plus.K - minus.K) / (2 * rel_step))
    return out


@takes_bridge
def build_symbolic(bridge: BridgeArg, n_modes: int, rfa: RationalApprox | str = "rfa4",
                   modal: ModalModel | None = None) -> SymbolicModel:
    """Build ``A(U, p)`` (modal lag order) for ``spec`` with relative parameters ``p``.

    Parameters
    ----------
    bridge : str, os.PathLike or BridgeSpec
    n_modes : int
        Retained vertical and torsional modes.
    rfa : RationalApprox or str
        Rational approximation of C(k).
    modal : ModalModel, optional
        Nominal modes (solved from ``spec`` when omitted).

    Returns
    -------
    SymbolicModel
        The named CasADi function ``A(U, p)`` and its parameter names: ``p`` holds relative
        changes of the bridge inputs (0 is the nominal bridge).
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
    modal = solve(assemble(spec)) if modal is None else modal
    rfa = get_rfa(rfa) if isinstance(rfa, str) else rfa
    nominal = modal.structural_basis(n_modes)
    n = len(chosen_modes(modal, n_modes))
    derivs = _projected_derivatives(spec, modal, n_modes)
    omega = np.sqrt(np.diag(nominal.K))
    a_m, a_k = modal.rayleigh
    zeta0 = spec.damping.ratio

    U = ca.SX.sym("U")
    p = ca.SX.sym("p", len(SYMBOLIC_PARAMETERS))
    M = ca.SX(np.eye(n))
    K = ca.SX(np.diag(omega ** 2))
    for k, path in enumerate(SYMBOLIC_PARAMETERS):
        if path in derivs:
            dM, dK = derivs[path]
            M = M + (p[k] - 1) * ca.DM(dM)
            K = K + (p[k] - 1) * ca.DM(dK)
    C = p[0] * (a_m * M + a_k * K) if zeta0 > 0 else ca.SX.zeros(n, n)
    b = spec.deck.half_chord_m * p[SYMBOLIC_PARAMETERS.index("deck.half_chord_m")]
    rho = spec.aero.air_density_kg_m3 * p[SYMBOLIC_PARAMETERS.index("aero.air_density_kg_m3")]
    basis = StructuralBasis(M=M, C=C, K=K, phi_h=nominal.phi_h, phi_a=nominal.phi_a,
                            strip_length=nominal.strip_length, strip_x=nominal.strip_x,
                            labels=nominal.labels)
    a = spec.aero
    aero = strip_aero(basis, b, rho, a.added_inertia, a.lift_slope_buffeting,
                      a.moment_slope_buffeting)
    A0, A1, A2, M_t, _ = rfa_parts(open_pieces(basis, aero, "modal"), rfa)
    parts_fun = ca.Function("A_parts", [p], [A0, A1, A2], ["p"], ["A0", "A1", "A2"])
    A_fun = ca.Function("A", [U, p], [A0 + U * A1 + U ** 2 * A2], ["U", "p"], ["A"])
    B_fun = ca.Function("B_gust", [U, p], [U * _gust_input(M_t, aero.P_gust, A0.shape[0])],
                        ["U", "p"], ["B"])
    return SymbolicModel(A_fun=A_fun, B_fun=B_fun, parts_fun=parts_fun,
                         parameters=SYMBOLIC_PARAMETERS,
                         nominal_values=np.array([get_path(spec, q) for q in SYMBOLIC_PARAMETERS]),
                         n_modes=n, labels=nominal.labels, n_states=int(A0.shape[0]))


def _flap_model(value, field: str):
    """A flap model (:class:`~bridgeflap.model.aeroelastic.flaps.ClosedLoopModel`, known by what it
    has: the flaps room imports this one)."""
    if not all(hasattr(value, name) for name in ("pieces", "open_loop", "n_flaps")):
        raise BridgeflapTypeError(field,
                                  "must be a flap model (bridgeflap.model.closed_loop_model), got "
                                         f"{describe(value)}")
    return value


@checked(model=_flap_model)
def closed_loop_functions(model) -> dict:
    """``{"A_parts": (theta, w) -> (A0, A1, A2), "A_cl": (U, theta, w) -> A}`` of a flap model.

    Parameters
    ----------
    model : bridgeflap.model.aeroelastic.flaps.ClosedLoopModel
        Open-loop system (modal order) and flap set.

    Returns
    -------
    dict
        ``"A_parts"``: a CasADi function ``(theta, w) -> (A0, A1, A2)`` of the compensator
        coefficients ``theta`` and flap weights ``w``; ``"A_cl"``: ``(U, theta, w) -> A`` at a wind
        speed ``U`` [m/s].
    """
    theta = ca.SX.sym("theta", 5)
    w = ca.SX.sym("w", model.n_flaps)
    A0, A1, A2, M_eff, _ = rfa_parts(model.pieces(w), model.open_loop.rfa,
                                     canonical_realisation(theta))
    B = _gust_input(M_eff, model.open_loop.aero.P_gust, A0.shape[0])
    parts = ca.Function("A_parts", [theta, w], [A0, A1, A2], ["theta", "w"],
                        ["A0", "A1", "A2"])
    U = ca.SX.sym("U")
    th2, w2 = ca.SX.sym("theta", 5), ca.SX.sym("w", model.n_flaps)
    P0, P1, P2 = parts(th2, w2)
    A_cl = ca.Function("A_cl", [U, th2, w2], [P0 + U * P1 + U * U * P2], ["U", "theta", "w"],
                       ["A"])
    B_cl = ca.Function("B_gust", [U, theta, w], [U * B], ["U", "theta", "w"], ["B"])
    return {"A_parts": parts, "A_cl": A_cl, "B_gust": B_cl}


# --------------------------------------------------------------------------- spectral RMS


def _as_casadi(value, like):
    """Return ``value`` as a CasADi matrix of the same family (MX/SX) as ``like``."""
    if isinstance(value, (ca.MX, ca.SX)):
        return value
    dense = np.asarray(value, dtype=float)
    if dense.ndim == 1:
        dense = dense[:, None]
    return type(like)(ca.DM(dense)) if isinstance(like, (ca.MX, ca.SX)) else ca.DM(dense)


def casadi_spectral_variance(
    A_sym, B_sym, C_sym, omegas, input_csd_values, weights=None, linear_solver=None
):
    """Output variances ``sum_k w_k diag(C X_k G_k X_k^H C^T)`` as a CasADi column.

    Parameters
    ----------
    A_sym : casadi.MX or casadi.SX or array_like, shape (n, n)
        Real state matrix [1/s].
    B_sym : casadi.MX or casadi.SX or array_like, shape (n, m)
        Real input matrix.
    C_sym : casadi.MX or casadi.SX or array_like, shape (p, n)
        Real output matrix.
    omegas : array_like, shape (n_omega,)
        Fixed, strictly increasing quadrature grid [rad/s].
    input_csd_values : array_like, shape (n_omega, m, m)
        Numeric one-sided input CSD matrices (Hermitian) at ``omegas``
        [input unit^2 per rad/s].
    weights : array_like, shape (n_omega,), optional
        Quadrature weights [rad/s]; trapezoid weights of ``omegas`` by default (the rule used
        by :func:`bridgeflap.model.spectral.rms_from_psd`).
    linear_solver : str, optional
        CasADi linear solver plugin for ``ca.solve`` (e.g. ``"lapacklu"``, ``"qr"``); the
        CasADi default when omitted.

    Returns
    -------
    casadi.MX or casadi.SX
        Column (p, 1) of output variances [output unit^2].
    """
    like = next((v for v in (A_sym, B_sym, C_sym) if isinstance(v, (ca.MX, ca.SX))), None)
    if like is None:
        like = ca.MX()
    A = _as_casadi(A_sym, like)
    B = _as_casadi(B_sym, like)
    C = _as_casadi(C_sym, like)
    n = A.size1()
    if A.size2() != n or B.size1() != n or C.size2() != n:
        raise BridgeflapInputError(
            "A_sym", f"inconsistent shapes A {A.shape}, B {B.shape}, C {C.shape}"
        )
    m = B.size2()
    omegas = np.asarray(omegas, dtype=float).ravel()
    w = trapezoid_weights(omegas) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != omegas.shape:
        raise BridgeflapInputError("weights", "must have one weight per frequency")
    S = np.asarray(input_csd_values)
    if S.shape != (omegas.size, m, m):
        raise BridgeflapInputError(
            "input_csd_values", f"must be ({omegas.size}, {m}, {m}), got {S.shape}"
        )
    eye = np.eye(n)
    rhs = ca.vertcat(B, ca.DM.zeros(n, m))
    variance = 0
    for k, omega in enumerate(omegas):
        # real form of (i omega I - A) X = B
        M = ca.vertcat(ca.horzcat(-A, -omega * eye), ca.horzcat(omega * eye, -A))
        X = ca.solve(M, rhs) if linear_solver is None else ca.solve(M, rhs, linear_solver, {})
        Yr = ca.mtimes(C, X[:n, :])
        Yi = ca.mtimes(C, X[n:, :])
        Sr = ca.DM(np.real(S[k]))
        # diag(Y S Y^H) = rowsum(Re(Y S) * Yr + Im(Y S) * Yi), Y = Yr + i Yi, S = Sr + i Si
        Pr = ca.mtimes(Yr, Sr)
        Pi = ca.mtimes(Yi, Sr)
        if np.any(np.imag(S[k]) != 0.0):
            Si = ca.DM(np.imag(S[k]))
            Pr = Pr - ca.mtimes(Yi, Si)
            Pi = Pi + ca.mtimes(Yr, Si)
        variance = variance + w[k] * ca.sum2(Pr * Yr + Pi * Yi)
    return variance


def casadi_spectral_rms(
    A_sym, B_sym, C_sym, omegas, input_csd_values, weights=None, linear_solver=None
):
    """Output RMS ``sqrt`` of :func:`casadi_spectral_variance` (same arguments).

    Parameters
    ----------
    A_sym, B_sym, C_sym : casadi.MX or casadi.SX or array_like
        Real system matrices (n, n), (n, m), (p, n).
    omegas : array_like, shape (n_omega,)
        Fixed quadrature grid [rad/s].
    input_csd_values : array_like, shape (n_omega, m, m)
        One-sided input CSD at ``omegas`` [input unit^2 per rad/s].
    weights : array_like, optional
        Quadrature weights [rad/s]; trapezoid by default.
    linear_solver : str, optional
        CasADi linear solver plugin for ``ca.solve``.

    Returns
    -------
    casadi.MX or casadi.SX
        Column (p, 1) of output RMS values [output unit]. Stability of ``A`` is not checked
        (impose it separately, e.g. a spectral-abscissa constraint); the expression is
        meaningless for unstable ``A``.
    """
    return ca.sqrt(
        casadi_spectral_variance(
            A_sym, B_sym, C_sym, omegas, input_csd_values, weights, linear_solver
        )
    )


def buffeting_rms_function(A_fun: ca.Function, B_fun: ca.Function, nominal, C_out, strip_x,
                           wind_speed: float, gust, outputs, *, omegas=None, n_base: int = 40,
                           peaks_per_mode: int = 15, half_widths: float = 20.0,
                           linear_solver: str = "lapacklu"):
    """Buffeting RMS of selected outputs as a CasADi Function of the model's parameters.

    The spectral integral of :func:`bridgeflap.model.response.buffeting.reduced_response`
    (one-sided, trapezoid rule on a fixed grid, load CSD projected on the row space of the nominal
    ``B_gust``) on the named functions of this module, so it is differentiable in whatever they
    depend on: the relative bridge parameters ``p`` (``SymbolicModel.A_fun``, ``B_fun``) or the
    compensator coefficients and flap weights (``closed_loop_functions(...)["A_cl"]``,
    ``["B_gust"]``).

    Parameters
    ----------
    A_fun, B_fun : casadi.Function
        ``(U, *params) -> A`` and ``(U, *params) -> B_gust`` (same parameters).
    nominal : sequence
        Parameter values where the frequency grid and the load projection are fixed.
    C_out : ndarray (n_out, n_x)
        Output map (strip heave then pitch, ``AeroelasticSystem.C_out``).
    strip_x : ndarray (n_strip,)
        Strip positions [m] (coherence).
    wind_speed : float
        ``U`` [m/s].
    gust : bridgeflap.model.aero.gust.GustField
    outputs : sequence of int
        Rows of ``C_out``.
    omegas : array_like, optional
        Fixed grid [rad/s]; adaptive at the nominal ``A(U)`` when omitted (coarser defaults
        than the numpy path: one dense 2n x 2n solve per frequency).
    linear_solver : str
        CasADi linear solver of the per-frequency solves.

    Returns
    -------
    fun : casadi.Function
        ``"buffeting_rms"``: ``*params -> rms (len(outputs),)`` [output unit].
    omegas : ndarray
        The frozen grid [rad/s].

    Notes
    -----
    The strip row space of ``B_gust`` must not depend on the parameters. It does not for the
    bridge: every coordinate is a vertical or a torsional mode, so each row of ``P_gust`` is
    one mode's strip shape times a scalar that carries ``b`` and ``rho``.
    """
    from bridgeflap.model.aero.gust import coherence_projection
    from bridgeflap.model.spectral import OMEGA_MAX_FACTOR, adaptive_frequency_grid, row_factor

    U = float(wind_speed)
    args = [ca.MX.sym(A_fun.name_in(i), A_fun.sparsity_in(i)) for i in range(1, A_fun.n_in())]
    A, B = A_fun(U, *args), B_fun(U, *args)
    A0 = np.asarray(A_fun(U, *nominal).full())
    _, Vt = row_factor(np.asarray(B_fun(U, *nominal).full()))
    if omegas is None:
        wd = np.abs(np.linalg.eigvals(A0).imag)
        omegas = adaptive_frequency_grid(A0, OMEGA_MAX_FACTOR * wd.max(), n_base,
                                         peaks_per_mode, half_widths)
    omegas = np.asarray(omegas, dtype=float)
    scale = gust.psd(omegas, U) * gust.admittance_sq(omegas, U)
    S = scale[:, None, None] * coherence_projection(strip_x, Vt.T, omegas, U,
                                                    gust.coherence_decay)
    Cr = ca.DM(np.asarray(C_out, dtype=float)[list(outputs)])
    var = casadi_spectral_variance(A, ca.mtimes(B, ca.DM(Vt.T)), Cr, omegas, S,
                                   linear_solver=linear_solver)
    names = [A_fun.name_in(i) for i in range(1, A_fun.n_in())]
    return ca.Function("buffeting_rms", args, [ca.sqrt(var)], names, ["rms"]), omegas

