"""Derivative loads on a structure: strip projection, Roger state space, exact p-k matrices.

The physics and conventions are those of :mod:`bridgeflap.model.aero.derivatives` (module docstring
there: the Scanlan form, the Roger RFA and the p-k split); this module projects a deck section's
derivative loads onto a :class:`~bridgeflap.model.aero.basis.StructuralBasis` and assembles the
speed-polynomial state space ``x' = (A0 + U A1 + U^2 A2) x`` with lag states
``x_j' = q' - (gamma_j U / B) x_j``, returned as an
:class:`~bridgeflap.model.aeroelastic.statespace.AeroelasticSystem` whose ``frozen()`` gives the p-k
matrices on the interpolated derivatives.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from bridgeflap.model.aero.basis import StructuralBasis
from bridgeflap.model.aero.derivatives import (
    FlutterDerivatives,
    RogerFit,
    _positive,
    fit_roger,
    flat_plate,
)
from bridgeflap.model.aero.strips import StripAero
from bridgeflap.model.aeroelastic.statespace import AeroelasticSystem, StateIndex
from bridgeflap.model.errors import BridgeflapInputError

__all__ = [
    "DerivativeFrozen",
    "DerivativeSystem",
    "derivative_bridge_system",
    "derivative_system",
    "flat_plate_fit",
    "section_generalised",
    "strip_matrix",
]

# --------------------------------------------------------------------------- geometry


def strip_matrix(chord_m: float, n_dof: int = 2) -> tuple[NDArray, NDArray]:
    """``(S_out, S_in)``: ``F_pkg = 1/2 rho U^2 S_out Qn S_in q`` on package coordinates.

    ``q = (h down, alpha nose-up, p downwind)`` (first ``n_dof``), ``F_pkg`` the generalised
    loads on them (lift down, moment nose-up, drag downwind): ``S_out = diag(-B, B^2, B)``,
    ``S_in = diag(-1/B, 1, 1/B)``.
    """
    B = float(chord_m)
    return np.diag([-B, B * B, B])[:n_dof, :n_dof], np.diag([-1 / B, 1.0, 1 / B])[:n_dof, :n_dof]


def section_generalised(basis: StructuralBasis, chord_m: float, phi_p=None) -> tuple:
    """Strip projection ``(L, R, n_dof)``: generalised ``Q(K) = L Qn(K) R`` (n x n).

    ``L = sum_i dl_i Phi_i^T S_out`` and ``R = S_in Phi_i`` stacked so that
    ``Q = sum_i dl_i Phi_i^T S_out Qn S_in Phi_i`` with ``Phi_i = (phi_h[i], phi_a[i],
    phi_p[i])``; one deck section (uniform chord and derivatives) for all strips.
    """
    n_dof = 2 if phi_p is None else 3
    S_out, S_in = strip_matrix(chord_m, n_dof)
    rows = [basis.phi_h, basis.phi_a] + ([] if phi_p is None else [np.asarray(phi_p, float)])
    ns = basis.n_strip
    dl = np.asarray(basis.strip_length, float)
    # Phi: (ns, n_dof, n)
    Phi = np.stack(rows, axis=1)
    left = np.einsum("i,idn,de->ine", dl, Phi, S_out)        # (ns, n, n_dof)
    right = np.einsum("de,ien->idn", S_in, Phi)              # (ns, n_dof, n)
    del ns
    return left, right, n_dof


def _project(left, Qn, right):
    """``sum_i left_i Qn right_i`` for Qn (..., d, d) -> (..., n, n)."""
    return np.einsum("ind,...de,iem->...nm", left, Qn, right)



# --------------------------------------------------------------------------- systems


@dataclass(frozen=True)
class DerivativeFrozen:
    """The p-k matrices on ``(q, q')`` at a frozen reduced frequency (module docstring).

    ``matrix_at_k(U, k)`` takes the half-chord reduced frequency ``k = |Im p| b / U`` of
    :func:`bridgeflap.model.stability.sweeps.pk_sweep` (``K = 2 k``) and returns the real
    first-order matrix with stiffness ``K_s - 1/2 rho U^2 Re Q(K)`` and damping ``C - 1/2 rho U B Im
    Q(K) / K``.
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    left: np.ndarray
    right: np.ndarray
    source: FlutterDerivatives
    n_dof: int
    air_density: float
    chord_m: float

    @property
    def half_chord(self) -> float:
        """``B / 2`` [m] (the ``b`` of the p-k iteration)."""
        return 0.5 * self.chord_m

    def generalised(self, K_red: float) -> np.ndarray:
        """Generalised ``Q(K)`` [complex, n x n]."""
        Kr = max(float(K_red), 1e-9)
        return _project(self.left, self.source.matrix(np.array(Kr), self.n_dof), self.right)

    def matrix_at_k(self, wind_speed: float, k: float) -> np.ndarray:
        """First-order matrix at ``U`` [m/s] and half-chord reduced frequency ``k`` [-]."""
        U = float(wind_speed)
        Kr = max(2.0 * float(k), 1e-9)
        Q = self.generalised(Kr)
        q = 0.5 * self.air_density
        Ks = self.K - q * U * U * Q.real
        Cs = self.C - q * U * self.chord_m * Q.imag / Kr
        n = self.M.shape[0]
        Minv = np.linalg.inv(self.M)
        return np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ Ks, -Minv @ Cs]])

    def dynamic_matrix(self, wind_speed: float, s: complex, K_red: float) -> np.ndarray:
        """``s^2 M + s C + K - 1/2 rho U^2 Q(K)`` (the exact flutter matrix at ``s = i omega``)."""
        U = float(wind_speed)
        return s * s * self.M + s * self.C + self.K - 0.5 * self.air_density * U * U * \
            self.generalised(K_red)


@dataclass(frozen=True)
class DerivativeSystem(AeroelasticSystem):
    """:class:`~bridgeflap.model.aeroelastic.statespace.AeroelasticSystem` of derivative loads
    (Roger RFA).

    ``frozen()`` returns the :class:`DerivativeFrozen` p-k matrices on the interpolated
    derivatives instead of the frozen-``C(k)`` form.
    """

    derivative_frozen: DerivativeFrozen | None = field(default=None, compare=False, repr=False)

    def frozen(self):
        """The exact p-k matrices (:class:`DerivativeFrozen`)."""
        return self.derivative_frozen


def derivative_system(basis: StructuralBasis, source: FlutterDerivatives, air_density: float,
                      fit: RogerFit | None = None, phi_p=None, n_lags: int = 2
                      ) -> DerivativeSystem:
    """Aeroelastic state space of a structure with derivative loads (module docstring).

    Parameters
    ----------
    basis : StructuralBasis
        Structure and strip heave/pitch per coordinate (heave down, package convention).
    source : FlutterDerivatives
        Derivatives of the deck section (chord ``source.chord_m``).
    air_density : float
        [kg/m^3].
    fit : RogerFit, optional
        RFA to use (default :func:`fit_roger` with ``n_lags`` poles).
    phi_p : array (n_strip, n), optional
        Strip lateral displacement (downwind) per coordinate; enables ``P_i^*, H5, H6, A5,
        A6``.

    Returns
    -------
    DerivativeSystem
        ``A(U) = A0 + U A1 + U^2 A2`` on ``x = (q, q', x_1..x_n)``; ``.frozen()`` for p-k.
    """
    _positive("air_density_kg_m3", air_density)
    B = source.chord_m
    left, right, d = section_generalised(basis, B, phi_p)
    if fit is None:
        fit = fit_roger(source, n_lags=n_lags, n_dof=d)
    if fit.R.shape[1] != d:
        raise BridgeflapInputError("fit", f"RFA is for {fit.R.shape[1]} DOFs, the section has {d}")
    Rg = [_project(left, Rj, right).real for Rj in fit.R]
    n, nl = basis.n, fit.n_lags
    rho = float(air_density)
    q = 0.5 * rho
    Meff = basis.M - q * B * B * Rg[2]
    Minv = np.linalg.inv(Meff)
    nx = n * (2 + nl)
    A0, A1, A2 = (np.zeros((nx, nx)) for _ in range(3))
    iq, iv = slice(0, n), slice(n, 2 * n)
    A0[iq, iv] = np.eye(n)
    A0[iv, iq] = -Minv @ basis.K
    A0[iv, iv] = -Minv @ basis.C
    A1[iv, iv] = Minv @ (q * B * Rg[1])
    A2[iv, iq] = Minv @ (q * Rg[0])
    for j, g in enumerate(fit.poles):
        lj = slice((2 + j) * n, (3 + j) * n)
        A0[lj, iv] = np.eye(n)
        A1[lj, lj] = -(g / B) * np.eye(n)
        A2[iv, lj] = Minv @ (q * Rg[3 + j])
    ns = basis.n_strip
    C_out = np.zeros((2 * ns, nx))
    C_out[:ns, iq] = basis.phi_h
    C_out[ns:, iq] = basis.phi_a
    names = ([f"q[{lab}]" for lab in basis.labels] + [f"qdot[{lab}]" for lab in basis.labels]
             + [f"lag{j + 1}[{lab}]" for j in range(nl) for lab in basis.labels])
    index = StateIndex(q=iq, q_dot=iv, aero_lag=slice(2 * n, nx), compensator=slice(nx, nx),
                       n=nx, names=tuple(names))
    zero = np.zeros((n, n))
    # static aerodynamic stiffness per U^2 (s = 0: the lag states vanish): P G0 = rho/2 R0
    aero = StripAero(M_nc=-q * B * B * Rg[2], D_nc=-q * B * Rg[1], P=q * Rg[0], G0=np.eye(n),
                     G1=zero, P_gust=np.zeros((n, ns)), half_chord=0.5 * B,
                     air_density=rho)
    frozen = DerivativeFrozen(basis.M, basis.C, basis.K, left, right, source, d, rho, B)
    return DerivativeSystem(A0=A0, A1=A1, A2=A2, Bw1=np.zeros((nx, ns)), C_out=C_out,
                            index=index, basis=basis, aero=aero, rfa=fit, order="modal",
                            extras={"derivatives": source.name}, derivative_frozen=frozen)


@functools.lru_cache(maxsize=8)
def _cached_flat_fit(chord_m: float, added_inertia: bool, n_lags: int) -> RogerFit:
    return fit_roger(flat_plate(chord_m, added_inertia), n_lags=n_lags)


def flat_plate_fit(chord_m: float, added_inertia: bool = False, n_lags: int = 4) -> RogerFit:
    """Cached :func:`fit_roger` of the exact flat plate (``K`` in [0.01, 6])."""
    return _cached_flat_fit(float(chord_m), bool(added_inertia), int(n_lags))


def derivative_bridge_system(spec, modal, n_modes: int):
    """Aeroelastic state space of a modal bridge with ``[derivatives]`` loads.

    The hook of :func:`bridgeflap.model.analysis.bridge_system`:
    :meth:`ImportedModalModel.derivative_basis` (lateral modes and shapes when ``lateral``), the
    table of the file with ``B = 2 b`` of the deck, its Roger fit and :func:`derivative_system`
    (whose ``frozen()`` is the exact p-k on the interpolated tables,
    :func:`bridgeflap.model.stability.sweeps.pk_sweep`). ``extras["rfa"]`` names the fit
    (``roger<n>:<table>``) for the flutter summary. A bridge with ``[static_coefficients]`` gets the
    quasi-steady gust inputs (:func:`bridgeflap.model.aeroelastic.gust_input.quasi_steady_inputs`).
    """
    loads = spec.derivatives
    if hasattr(modal, "derivative_basis"):
        basis, phi_p = modal.derivative_basis(int(n_modes), loads.lateral)
    else:  # the built-in FE model: vertical and torsional modes, no lateral DOF
        basis, phi_p = modal.structural_basis(int(n_modes)), None
    chord = 2.0 * spec.deck.half_chord_m
    source = loads.table(chord)
    if not source.lateral:
        phi_p = None
    fit = loads.fit(chord, 2 if phi_p is None else 3)
    system = derivative_system(basis, source, spec.aero.air_density_kg_m3, fit=fit, phi_p=phi_p)
    system.extras.update(rfa=f"{fit.name}:{source.name}", lateral_dof=phi_p is not None,
                         phi_p=phi_p)
    if getattr(spec, "static_coefficients", None) is not None:  # B_gust: quasi-steady w loads
        from bridgeflap.model.aeroelastic.gust_input import quasi_steady_inputs

        system = quasi_steady_inputs(system, spec)
    return system
