"""The one assembly of the aeroelastic equations: deck, optional flaps, optional compensator.

Mechanism (STYLE.md, "One physics path, two numerics"): a **backend shim**. Every function here
is written once with plain arithmetic and the few functions of
:mod:`bridgeflap.model.aeroelastic.backend` (``zeros``, ``solve``, ``hcat``, ``vcat``, ``kron``,
``diag``), which dispatch on the argument types: numpy inputs give the numeric matrices (sweeps,
p-k, plant), CasADi ``SX`` inputs (compensator coefficients ``theta``, flap weights ``w``, relative
bridge parameters ``p``) give the expressions of the named ``ca.Function`` objects of
:mod:`bridgeflap.model.aeroelastic.symbolic`. This module does not import CasADi.

Equations (conventions: :mod:`bridgeflap.model`; loads: :mod:`bridgeflap.model.aero.strips`). With
generalised coordinates ``q``, flap drive angles ``beta`` and the lift-deficiency function ``C``::

    M_t q'' = F(U) z + U R C [W_v + U W_q] z,         z = (q, q', compensator states)
    F(U) = F0 + U F1 + U^2 F2                         (structure, non-circulatory air, flaps)

:class:`OpenPieces` holds these matrices on ``(q, q')`` and the flap-drive input columns;
:func:`close` feeds the compensator ``beta = K(s) alpha_f`` back (``beta, beta', beta''`` are
linear in the state,
:meth:`bridgeflap.model.aeroelastic.control.Compensator.second_derivative_feedthrough`; the ``Dc
alpha''`` part of ``beta''`` joins the mass: ``M_eff = M_t - Dc H2 Phi_a``). Two closures of ``C``
turn the pieces into a first-order ``x' = (A0 + U A1 + U^2 A2) x``:

* :func:`rfa_parts` -- the lag-form rational approximation (:mod:`bridgeflap.model.aero.rfa`),
  ``C Q = Q/2 + sum_j A_j y_j``, ``y_j' = (beta_j U/b)(Q - y_j)``, lag states between ``q'`` and
  the compensator states (``order="modal"``: on ``W z`` with ``R = I``; ``"full"``: on every
  strip's downwash with ``R = P``);
* :func:`frozen_parts` -- ``C`` a given complex number (the p-k method): ``A(U, c) = A0 + U (A1 +
  c A1c) + U^2 (A2 + c A2c)`` without lag states.

:func:`dynamic_matrices` is the frozen-``C`` second-order form ``D(s) q = F_beta(s) beta`` used
by the flap-loop plant and the exact flutter determinant.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bridgeflap.model.aero.basis import StructuralBasis
from bridgeflap.model.aero.strips import StripAero, circulatory_lift, load_map
from bridgeflap.model.aeroelastic import backend as bk
from bridgeflap.model.errors import BridgeflapInputError

__all__ = [
    "ClosedPieces",
    "FrozenParts",
    "OpenPieces",
    "close",
    "dynamic_matrices",
    "flap_inputs",
    "frozen_combination",
    "frozen_parts",
    "open_pieces",
    "rfa_parts",
]

ORDERS = ("modal", "full")


@dataclass(frozen=True)
class OpenPieces:
    """Open-loop equations on ``(q, q')`` with the flap drives as inputs (module docstring).

    Attributes
    ----------
    M : (n, n)
        ``M + M_nc`` [kg per unit coordinate^2].
    F : tuple of 3 (n, 2n)
        ``F0, F1, F2``: structural and non-circulatory forces per ``U^0, U^1, U^2``.
    W : tuple of 2 (m, 2n)
        ``W_v, W_q``: downwash per ``U^0, U^1`` (``m = n`` modal, strips in full order).
    R : (n, m) or None
        Force of a unit circulatory downwash times ``U C`` (``None``: identity, modal order).
    H : tuple of 3 (n, nF) or None
        Flap forces per ``beta''``, ``U beta'``, ``U^2 beta`` (``H2, H1, H0``).
    W_beta : tuple (PF, (b g1, g0)) or None
        Flap circulatory force map (n, nF) and downwash coefficients per ``beta'`` and
        ``U beta``.
    phi_a_flaps : (nF, n) or None
        Deck pitch at the flaps per unit coordinate [rad].
    half_chord : float
        ``b`` [m] (lag rates ``beta_j U / b``).
    order : str
    """

    M: object
    F: tuple
    W: tuple
    R: object
    H: tuple | None
    W_beta: tuple | None
    phi_a_flaps: object
    half_chord: object
    order: str

    @property
    def n(self) -> int:
        """Number of generalised coordinates."""
        return int(self.M.shape[0])

    @property
    def n_flaps(self) -> int:
        """Number of flap strips (0 without flaps)."""
        return 0 if self.H is None else int(self.H[0].shape[1])


def flap_inputs(flaps, weights, half_chord, air_density) -> tuple:
    """``(H, PF, q)`` of a flap set: the flap strip loads of :mod:`bridgeflap.model.aero.strips`
    projected.

    Parameters
    ----------
    flaps : bridgeflap.model.aeroelastic.flaps.FlapSet
        Mode shapes at the flap strips, spanwise widths [m] and per-unit-span loads.
    weights : array (nF,) or casadi.SX
        Per-flap load factor [-] (1 fitted, 0 absent).

    Returns
    -------
    H : tuple of 3 (n, nF)
        Force per ``beta''``, ``U beta'``, ``U^2 beta``.
    PF : (n, nF)
        Force per unit ``U C Q_f``.
    q : tuple of 2
        ``(b g1, g0)``: flap downwash per ``beta'`` and per ``U beta``.
    """
    width = np.asarray(flaps.width_m, float)
    scale = bk.diag(width[:, None] * weights if bk.is_symbolic(weights) else width * weights)
    ld = flaps.loads
    H = tuple(bk.mtimes(E, scale) for E in load_map(ld, flaps.phi_h, flaps.phi_a))
    circ = circulatory_lift(half_chord, air_density)
    PF = bk.mtimes(circ[0] * flaps.phi_h.T + circ[1] * flaps.phi_a.T, scale)
    return H, PF, (half_chord * ld.g1, ld.g0)


def open_pieces(basis: StructuralBasis, aero: StripAero, order: str = "modal", flaps=None,
                weights=None) -> OpenPieces:
    """Open-loop pieces of a structural basis with its deck strips and optional flaps.

    ``basis.M, C, K`` and the aerodynamic matrices may be CasADi expressions (relative bridge
    parameters); ``weights`` may be symbolic (flap placement).
    """
    if order not in ORDERS:
        raise BridgeflapInputError("order", f"must be one of {ORDERS}, got {order!r}")
    if flaps is not None and order != "modal":
        raise BridgeflapInputError("order", "closed-loop flaps are assembled in modal order")
    n = basis.n
    like = (basis.M, basis.K, basis.C, aero.P, aero.M_nc)

    def on_qv(q_block, v_block, rows):
        out = bk.zeros(rows, 2 * n, like)
        if q_block is not None:
            out[:, :n] = q_block
        if v_block is not None:
            out[:, n:] = v_block
        return out

    F = (on_qv(-basis.K, -basis.C, n), on_qv(None, -aero.D_nc, n), bk.zeros(n, 2 * n, like))
    if order == "modal":
        W = (on_qv(None, aero.P @ aero.G1, n), on_qv(aero.P @ aero.G0, None, n))
        R = None
    else:
        ns = basis.n_strip
        W = (on_qv(None, aero.G1, ns), on_qv(aero.G0, None, ns))
        R = aero.P
    H = W_beta = phi_a = None
    if flaps is not None:
        w = np.ones(flaps.n_flaps) if weights is None else weights
        H, PF, q = flap_inputs(flaps, w, aero.half_chord, aero.air_density)
        W_beta = (PF, q)
        phi_a = flaps.phi_a
    return OpenPieces(M=basis.M + aero.M_nc, F=F, W=W, R=R, H=H, W_beta=W_beta,
                      phi_a_flaps=phi_a, half_chord=aero.half_chord, order=order)


@dataclass(frozen=True)
class ClosedPieces:
    """The pieces with the compensator fed back, on ``x = (q, q', lag columns, xc)``.

    ``F`` (3 x (n, nx)) the structural and deck non-circulatory forces, ``HS`` (3 x (n, nx))
    the flap non-circulatory forces, ``W`` (2 x (m, nx)) the downwash (deck and flaps), ``M``
    = ``M_eff``; ``comp_rows`` (nc nF, nx) the compensator dynamics; ``beta_map`` (nF, nx) the
    flap angles ``beta = S0 x`` [rad]; ``n_lag`` the number of (zero) lag columns after ``q'``.
    """

    M: object
    F: tuple
    HS: tuple
    W: tuple
    R: object
    comp_rows: object
    beta_map: object
    n: int
    n_lag: int
    half_chord: object

    def RW(self, k: int):
        """``R W_k``: generalised circulatory force per unit ``U C`` (k = 0: ``W_v``, 1)."""
        return self.W[k] if self.R is None else bk.mtimes(self.R, self.W[k])


def close(op: OpenPieces, compensator=None, n_lag: int = 0) -> ClosedPieces:
    """Feed ``beta_f = K(s) alpha_f`` back (``compensator = (Ac, Bc, Cc, Dc)``, numeric or not).

    Without a compensator (or without flaps) the flap inputs are dropped: the open loop.
    """
    n, nF = op.n, op.n_flaps
    closed = compensator is not None and nF > 0
    Ac, Bc, Cc, Dc = compensator if closed else (np.zeros((0, 0)), None, None, 0.0)
    nc = int(Ac.shape[0])
    nx = 2 * n + n_lag + nc * nF
    like = (op.M, *op.F, *op.W, *(op.H or ()), *(op.W_beta or (None,))[:1], Ac, Cc, Dc)
    iq, iv, icomp = slice(0, n), slice(n, 2 * n), slice(2 * n + n_lag, nx)

    def embed(block):                 # (rows, 2n) on (q, q') -> (rows, nx)
        out = bk.zeros(block.shape[0], nx, like)
        out[:, :2 * n] = block
        return out

    F, W = [embed(f) for f in op.F], [embed(w) for w in op.W]
    HS = [bk.zeros(n, nx, like)] * 3
    M = op.M
    comp_rows = bk.zeros(nc * nF, nx, like)
    S0 = bk.zeros(nF if closed else 0, nx, like)
    if closed:
        PhA = op.phi_a_flaps
        eye_f = np.eye(nF)
        CA = bk.mtimes(Cc, Ac)
        cb, cab = bk.mtimes(Cc, Bc), bk.mtimes(CA, Bc)

        def beta_map(qcoef, vcoef, row):       # (nF, nx) map of a beta derivative
            S = bk.zeros(nF, nx, like)
            S[:, iq] = qcoef * PhA
            S[:, iv] = vcoef * PhA
            S[:, icomp] = bk.kron(eye_f, row)
            return S

        S0 = beta_map(Dc, 0.0, Cc)
        S1 = beta_map(cb, Dc, CA)
        S2 = beta_map(cab, cb, bk.mtimes(CA, Ac))      # without Dc alpha''
        H2, H1, H0 = op.H
        HS = [bk.mtimes(H2, S2), bk.mtimes(H1, S1), bk.mtimes(H0, S0)]
        PF, (q1, q0) = op.W_beta
        W = [W[0] + q1 * bk.mtimes(PF, S1), W[1] + q0 * bk.mtimes(PF, S0)]
        M = M - Dc * bk.mtimes(H2, PhA)
        comp_rows[:, icomp] = bk.kron(eye_f, Ac)
        comp_rows[:, iq] = bk.mtimes(bk.kron(eye_f, Bc), PhA)
    return ClosedPieces(M=M, F=tuple(F), HS=tuple(HS), W=tuple(W), R=op.R,
                        comp_rows=comp_rows, beta_map=S0, n=n, n_lag=n_lag,
                        half_chord=op.half_chord)


def _first_order(cp: ClosedPieces, rows_v, lag_rows=None) -> tuple:
    """Stack ``(A0, A1, A2)``: ``q' = v``, the solved ``v'`` rows, lag rows, compensator rows.

    ``rows_v`` and ``lag_rows`` are three blocks each (per ``U^0, U^1, U^2``); ``lag_rows``
    ``None`` means no lag states.
    """
    n, nx = cp.n, cp.F[0].shape[1]
    like = (*rows_v, cp.comp_rows, *(lag_rows or ()))
    top = bk.zeros(n, nx, like)
    top[:, n:2 * n] = np.eye(n)
    ncomp = cp.comp_rows.shape[0]
    if lag_rows is None:
        lag_rows = [bk.zeros(cp.n_lag, nx, like)] * 3
    firsts = [top, bk.zeros(n, nx, like), bk.zeros(n, nx, like)]
    lasts = [cp.comp_rows, bk.zeros(ncomp, nx, like), bk.zeros(ncomp, nx, like)]
    return tuple(bk.vcat([firsts[k], rows_v[k], lag_rows[k], lasts[k]]) for k in range(3))


def rfa_parts(op: OpenPieces, rfa, compensator=None) -> tuple:
    """``(A0, A1, A2, M_eff, beta_map)`` with the lag-form RFA of ``C`` (module docstring)."""
    nl = rfa.n_lags
    m = op.n if op.R is None else op.R.shape[1]
    cp = close(op, compensator, n_lag=nl * m)
    n, nx = cp.n, cp.F[0].shape[1]
    like = (cp.M, *cp.F, *cp.HS, *cp.W)
    F1 = cp.F[1] + bk.zeros(n, nx, like)
    lag_rows1, lag_rows2 = [], []
    for j in range(nl):
        lj = slice(2 * n + j * m, 2 * n + (j + 1) * m)
        F1[:, lj] = float(rfa.gains[j]) * (np.eye(n) if cp.R is None else cp.R)
        rate = float(rfa.poles[j]) / cp.half_chord
        E = np.zeros((m, nx))
        E[:, lj] = np.eye(m)
        lag_rows1.append(rate * (cp.W[0] - E))
        lag_rows2.append(rate * cp.W[1])
    rhs = bk.hcat([cp.F[0] + cp.HS[0], F1 + 0.5 * cp.RW(0) + cp.HS[1],
                   cp.F[2] + 0.5 * cp.RW(1) + cp.HS[2]])
    rows = bk.solve(cp.M, rhs)
    rows_v = [rows[:, :nx], rows[:, nx:2 * nx], rows[:, 2 * nx:]]
    lags = None
    if nl:
        lags = [bk.zeros(cp.n_lag, nx, like), bk.vcat(lag_rows1), bk.vcat(lag_rows2)]
    A0, A1, A2 = _first_order(cp, rows_v, lags)
    return A0, A1, A2, cp.M, cp.beta_map


def frozen_combination(parts, wind_speed: float, c_value: complex):
    """``P0 + U P1 + U^2 P2 + U c (P3 + U P4)``: the equations with ``C`` frozen at ``c``.

    The one place where ``C(k)`` is frozen: ``parts`` are the non-circulatory terms per
    ``U^0, U^1, U^2`` and the circulatory ones per ``U C`` and ``U^2 C`` (forces, solved rows
    of a first-order matrix, or flap-input terms). Used by :class:`FrozenParts` (p-k) and
    :func:`dynamic_matrices` (flap-loop plant, exact flutter determinant).
    """
    U, c = float(wind_speed), complex(c_value)
    P0, P1, P2, P3, P4 = parts
    return P0 + U * P1 + (U * U) * P2 + (U * c) * (P3 + U * P4)


@dataclass(frozen=True)
class FrozenParts:
    """``A(U, c) = A0 + U (A1 + c A1c) + U^2 (A2 + c A2c)`` on ``(q, q', xc)`` (numpy).

    The first-order form of the equations with ``C`` frozen at a complex value ``c``: its
    eigenvalues ``p`` with ``c = C(|Im p| b / U)`` solve the exact flutter equation (p-k).
    """

    A0: np.ndarray
    A1: np.ndarray
    A2: np.ndarray
    A1c: np.ndarray
    A2c: np.ndarray
    half_chord: float

    def matrix(self, wind_speed: float, c_value: complex) -> np.ndarray:
        """First-order matrix at ``wind_speed`` [m/s] with ``C = c_value``."""
        return frozen_combination((self.A0, self.A1, self.A2, self.A1c, self.A2c),
                                  wind_speed, c_value)


def frozen_parts(op: OpenPieces, compensator=None) -> FrozenParts:
    """:class:`FrozenParts` of the pieces (numeric), open or closed loop."""
    cp = close(op, compensator)
    nx = cp.F[0].shape[1]
    F = [f + hs for f, hs in zip(cp.F, cp.HS, strict=True)]
    rows = np.linalg.solve(cp.M, np.hstack([*F, cp.RW(0), cp.RW(1)]))
    blocks = [rows[:, k * nx:(k + 1) * nx] for k in range(5)]
    A0, A1, A2 = _first_order(cp, blocks[:3])
    zero = np.zeros_like(blocks[0])
    _, A1c, A2c = _first_order(cp, [zero, blocks[3], blocks[4]])
    return FrozenParts(A0, A1, A2, A1c, A2c, float(cp.half_chord))


def dynamic_matrices(op: OpenPieces, wind_speed: float, s: complex, c_value: complex):
    """Frozen-``C`` second-order matrices ``D(s) q = F_beta(s) beta`` (numpy, complex).

    ``D(s) = s^2 M_t + s (C + U D_nc) + K - U c P (s G1 + U G0)`` and ``F_beta(s) = s^2 H2 + U
    s H1 + U^2 H0 + U c PF (U g0 + b g1 s)`` (``None`` without flaps). ``det D = 0`` with
    ``c = C(k)`` is the exact Theodorsen flutter equation; with ``c`` the RFA at ``s b/U``,
    ``D^{-1} F_beta`` is the exact transfer function of the RFA state space.
    """
    n = op.n
    RW = [w if op.R is None else op.R @ w for w in op.W]
    F = frozen_combination((*op.F, *RW), wind_speed, c_value)
    D = s * s * op.M - s * F[:, n:] - F[:, :n]
    if op.H is None:
        return D, None
    H2, H1, H0 = op.H
    PF, (q1, q0) = op.W_beta
    return D, frozen_combination((s * s * H2, s * H1, H0, (q1 * s) * PF, q0 * PF),
                                 wind_speed, c_value)
