"""Aeroelastic state space ``x' = A(U) x + B_w(U) w``, ``A(U) = A0 + U A1 + U^2 A2``.

State ``x = (q, q', lag states)`` (named partitions in :class:`StateIndex`). The lift-deficiency
function is replaced by its lag-form rational approximation (:mod:`bridgeflap.model.aero.rfa`)::

    C(s_bar) Q = Q/2 + sum_j A_j y_j,     y_j' = (beta_j U / b) (Q - y_j)

(``sum_j A_j = 1/2``). Two assemblies that must agree (docs/methods.md#state-space):

* ``order="full"``: lag states on every strip's downwash ``Q_i`` (``4 n_strip`` states);
* ``order="modal"``: lag states on the generalised circulatory downwash ``P Q`` (``4 n``
  states). Exact when all strips share ``b`` and the lag poles, because the lag filter then
  commutes with the projection ``P``.

No acceleration feed-through arises (the non-circulatory inertia joins the mass matrix), and
``U`` enters polynomially, so a sweep is a matrix sum and one ``eig`` per speed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bridgeflap.model.aero.basis import StructuralBasis
from bridgeflap.model.aero.rfa import RationalApprox, get_rfa
from bridgeflap.model.aero.strips import StripAero, strip_aero
from bridgeflap.model.aeroelastic import backend as bk
from bridgeflap.model.aeroelastic.assembly import (
    ORDERS,
    FrozenParts,
    OpenPieces,
    dynamic_matrices,
    frozen_parts,
    open_pieces,
    rfa_parts,
)
from bridgeflap.model.errors import BridgeflapInputError


@dataclass(frozen=True)
class StateIndex:
    """Named partitions of the state vector."""

    q: slice
    q_dot: slice
    aero_lag: slice
    compensator: slice
    n: int
    names: tuple

    def find(self, name: str) -> int:
        """Index of a state by name."""
        return self.names.index(name)


@dataclass(frozen=True)
class AeroelasticSystem:
    """Linear aeroelastic model of one bridge state (speed-polynomial form).

    ``A(U) = A0 + U A1 + U^2 A2``; ``B_w(U) = U Bw1`` maps strip gust velocities [m/s] (up
    positive, before admittance) to ``x'``; ``C_out`` maps ``x`` to strip heave [m] then strip
    pitch [rad].
    """

    A0: np.ndarray
    A1: np.ndarray
    A2: np.ndarray
    Bw1: np.ndarray
    C_out: np.ndarray
    index: StateIndex
    basis: StructuralBasis
    aero: StripAero
    rfa: RationalApprox
    order: str
    extras: dict = field(default_factory=dict, compare=False)
    pieces: OpenPieces | None = field(default=None, compare=False, repr=False)
    compensator: tuple | None = field(default=None, compare=False, repr=False)

    def A(self, wind_speed: float) -> np.ndarray:
        """State matrix at ``wind_speed`` [m/s]."""
        U = float(wind_speed)
        return self.A0 + U * self.A1 + (U * U) * self.A2

    def B_gust(self, wind_speed: float) -> np.ndarray:
        """Gust input matrix at ``wind_speed`` [m/s]."""
        return float(wind_speed) * self.Bw1

    @property
    def n_states(self) -> int:
        """Number of states."""
        return self.A0.shape[0]

    def frozen(self) -> FrozenParts:
        """First-order matrices with C(k) frozen
        (:func:`bridgeflap.model.aeroelastic.assembly.frozen_parts`), p-k."""
        if self.pieces is None or self.pieces.order != "modal":
            raise BridgeflapInputError("order", "the frozen-C (p-k) form is built in modal order")
        return frozen_parts(self.pieces, self.compensator)

    def structural_matrix(self) -> np.ndarray:
        """First-order matrix of the structure alone on ``(q, q')`` (no air, ``U = 0``)."""
        B = self.basis
        n = B.n
        Minv = np.linalg.inv(B.M)
        return np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ B.K, -Minv @ B.C]])

    def structural_eigenvalues(self) -> np.ndarray:
        """Eigenvalues of the structure alone (upper half plane), ``U = 0``, no air."""
        lam = np.linalg.eigvals(self.structural_matrix())
        return np.sort_complex(lam[lam.imag > 0])


def build(basis: StructuralBasis, half_chord: float, air_density: float,
          rfa: RationalApprox | str = "rfa4", order: str = "modal", added_inertia: bool = True,
          lift_slope_buffeting: float = 2 * np.pi,
          moment_slope_buffeting: float = np.pi / 2) -> AeroelasticSystem:
    """Assemble the aeroelastic state space of a structural basis
    (:mod:`bridgeflap.model.aeroelastic.assembly`).

    Parameters
    ----------
    basis : StructuralBasis
    half_chord : float
        ``b`` [m].
    air_density : float
        [kg/m^3].
    rfa : RationalApprox or str
        Rational approximation of C(k) (``"rfa4"`` default, ``"jones"``).
    order : {"modal", "full"}
        Lag states on generalised or on strip downwash.
    added_inertia : bool
        Keep the apparent-inertia moment (the paper's Eq. 3).
    """
    if order not in ORDERS:
        raise BridgeflapInputError("order", f"must be one of {ORDERS}, got {order!r}")
    rfa = get_rfa(rfa) if isinstance(rfa, str) else rfa
    aero = strip_aero(basis, half_chord, air_density, added_inertia, lift_slope_buffeting,
                      moment_slope_buffeting)
    pieces = open_pieces(basis, aero, order)
    A0, A1, A2, M_t, _ = rfa_parts(pieces, rfa)
    n, ns = basis.n, basis.n_strip
    nx = A0.shape[0]
    iq, iv = slice(0, n), slice(n, 2 * n)
    Bw1 = np.zeros((nx, ns))
    Bw1[iv, :] = bk.solve(M_t, aero.P_gust)
    C_out = np.zeros((2 * ns, nx))
    C_out[:ns, iq] = basis.phi_h
    C_out[ns:, iq] = basis.phi_a
    names = ([f"q[{lab}]" for lab in basis.labels] + [f"qdot[{lab}]" for lab in basis.labels]
             + [f"lag{j + 1}[{k}]" for j in range(rfa.n_lags)
                for k in (basis.labels if order == "modal" else range(ns))])
    index = StateIndex(q=iq, q_dot=iv, aero_lag=slice(2 * n, nx), compensator=slice(nx, nx),
                       n=nx, names=tuple(str(s) for s in names))
    return AeroelasticSystem(A0=A0, A1=A1, A2=A2, Bw1=Bw1, C_out=C_out, index=index,
                             basis=basis, aero=aero, rfa=rfa, order=order, pieces=pieces)


def spec_system(spec, basis: StructuralBasis, order: str = "modal",
                rfa: RationalApprox | str = "rfa4") -> AeroelasticSystem:
    """:func:`build` with the deck half-chord and the aerodynamic inputs of a bridge spec.

    A bridge whose self-excited loads come from flutter-derivative tables (``[derivatives]``
    of a modal bridge) is refused here: its state space is built by
    :func:`bridgeflap.model.aeroelastic.derivative_system.derivative_bridge_system` for flutter
    only, and an analysis that builds Theodorsen deck loads (buffeting, flaps and design,
    sensitivities, state-space export, mode shapes) must not silently use the flat plate instead.
    """
    if getattr(spec, "derivatives", None) is not None:
        raise BridgeflapInputError(
            "derivatives", "this bridge's loads are flutter-derivative tables, which "
            "`flutter`, `buffeting` (quasi-steady gust loads) and modal-data `sensitivity` use; "
            "this analysis needs thin-aerofoil loads: use the flat-plate bridge")
    a = spec.aero
    return build(basis, spec.deck.half_chord_m, a.air_density_kg_m3, rfa=rfa, order=order,
                 added_inertia=a.added_inertia, lift_slope_buffeting=a.lift_slope_buffeting,
                 moment_slope_buffeting=a.moment_slope_buffeting)


def exact_dynamic_matrix(system: AeroelasticSystem, p: complex, wind_speed: float,
                         c_value: complex) -> np.ndarray:
    """``D(p) = p^2 M_t + p (C + U D_nc) + K - U C(k) P (p G1 + U G0)`` for a given ``C(k)``.

    ``det D(p) = 0`` is the exact Theodorsen flutter equation used by the p-k method
    (:func:`bridgeflap.model.aeroelastic.assembly.dynamic_matrices` of the open-loop pieces).
    """
    return dynamic_matrices(system.pieces, wind_speed, p, c_value)[0]


def divergence_speed_static(system: AeroelasticSystem) -> float:
    """Static divergence speed [m/s]: smallest ``U`` with ``det(K - U^2 Q) = 0`` (C(0) = 1).

    ``Q = P G0`` for the open loop; with flaps driven by a compensator ``Q = P G0 + (H0 + g0
    PF) K(0) Phi_a`` (the static flap loads of ``beta = K(0) alpha_f``,
    :mod:`bridgeflap.model.aeroelastic.assembly`). Returns NaN when no positive real root exists.
    """
    K = system.basis.K
    mu = np.linalg.eigvals(np.linalg.solve(K, static_aero_stiffness(system)))
    real = mu[(np.abs(mu.imag) <= 1e-9 * np.abs(mu).max()) & (mu.real > 0)].real
    if real.size == 0:
        return float("nan")
    return float(1.0 / np.sqrt(real.max()))


def static_aero_stiffness(system: AeroelasticSystem) -> np.ndarray:
    """Modal static aerodynamic stiffness per ``U^2``, ``Q`` of ``K q = U^2 Q q`` (C(0) = 1).

    Column ``j`` is the static load that coordinate ``j``'s deflection generates: for strip
    loads only twist does (a deck's heave makes no static lift), for derivative tables
    ``H4*``/``A4*`` give heave columns too (:func:`divergence_mechanism`).
    """
    n = system.basis.n
    if system.pieces is None:
        Q = system.aero.P @ system.aero.G0
    else:
        op = system.pieces
        Q = op.W[1][:, :n] if op.R is None else op.R @ op.W[1][:, :n]
        if system.compensator is not None and op.n_flaps:
            Ac, Bc, Cc, Dc = system.compensator
            k0 = float(Dc - (Cc @ np.linalg.solve(Ac, Bc))[0, 0])
            PF, (_, q0) = op.W_beta
            Q = Q + k0 * (op.H[2] + q0 * PF) @ op.phi_a_flaps
    return Q


def coordinate_families(system) -> list[str]:
    """``"torsional"``, ``"vertical"`` or ``"lateral"`` for each structural coordinate: by
    the larger of its twist (``b phi_a``) and heave (``phi_h``) content over the strips."""
    basis = system.basis
    b = float(system.aero.half_chord)
    w = np.asarray(basis.strip_length, dtype=float)[:, None]
    n = basis.n
    tw = (w * (b * np.asarray(basis.phi_a)) ** 2).sum(0) if basis.phi_a is not None \
        else np.zeros(n)
    hv = (w * np.asarray(basis.phi_h) ** 2).sum(0) if basis.phi_h is not None else np.zeros(n)
    return ["lateral" if max(t, h) == 0 else "torsional" if t >= h else "vertical"
            for t, h in zip(tw, hv, strict=True)]


def divergence_mechanism(system, vec) -> tuple[str, str]:
    """Mechanism and source coordinate of a divergence with state eigenvector ``vec``.

    With ``K q = U^2 Q q`` (:func:`bridgeflap.model.aeroelastic.statespace.static_aero_stiffness`),
    the static aerodynamic work ``q^T Q q`` splits over the coordinates whose deflection generates
    the load, ``w_j = (q^T Q)_j q_j``. The mechanism is the family (:func:`coordinate_families`)
    with the largest share, the source its largest coordinate. Returns ``("", "")`` when the
    work is not positive (no divergence-like eigenvector).
    """
    q = np.real(np.asarray(vec)[system.index.q])
    q = q / (np.abs(q).max() or 1.0)
    Q = np.real(static_aero_stiffness(system))
    w = (q @ Q) * q
    if not np.sum(w) > 0:
        return "", ""
    fam = coordinate_families(system)
    share = {f: float(sum(x for x, g in zip(w, fam, strict=True) if g == f)) for f in set(fam)}
    mech = max(share, key=share.get)
    j = max((i for i, g in enumerate(fam) if g == mech), key=lambda i: w[i])
    return mech, system.basis.labels[j]
