"""Spectral output RMS as a CasADi expression (differentiable in the state matrix).

Symbolic counterpart of :func:`model.spectral.spectral_rms` on a *fixed* frequency grid, for the
optimiser (buffeting objectives and constraints). Same one-sided PSD convention as
:mod:`model.spectral` (see its docstring): ``sigma_j^2 = int_0^omega_max G_yy,jj d omega`` with
``G_yy = H G_ww H^H`` and ``H = C (i omega I - A)^{-1} B`` (seed paper Eqs. (10)-(12), (17)),
evaluated as ``sum_k weight_k diag(C X_k G_k X_k^H C^T)`` with trapezoid weights.

The complex solve is written in real arithmetic: with ``X = Xr + i Xi``,
``(i omega I - A) X = B`` is the real system::

    [[-A, -omega I], [omega I, -A]] [Xr; Xi] = [B; 0].
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from model.errors import BridgeflapInputError
from model.spectral import trapezoid_weights

__all__ = ["casadi_spectral_variance", "casadi_spectral_rms"]


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
        by :func:`model.spectral.rms_from_psd`).
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
