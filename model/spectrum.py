"""Eigenvalue tools shared by model/ and design/: spectral abscissa and eigenvalue derivatives.

First-order perturbation of a simple eigenvalue ``lambda`` of ``A(p)`` with right eigenvector
``v`` (``A v = lambda v``) and left eigenvector ``w`` (``w^H A = lambda w^H``)::

    d lambda / d p_k = w^H (dA/dp_k) v / (w^H v)

(Seyranian & Mailybaev 2003). Near a defective eigenvalue ``w^H v -> 0`` and the derivative is
unbounded: :func:`eigenvalue_derivatives` flags those eigenvalues by the normalised conditioning
``|w^H v| / (|w| |v|)`` (the reciprocal of the eigenvalue condition number). numpy only.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

__all__ = [
    "DEFECT_TOL",
    "eigenvalue_derivative",
    "eigenvalue_derivatives",
    "polynomial_abscissa",
    "spectral_abscissa",
]

#: Default threshold on ``|w^H v| / (|w| |v|)`` below which an eigenvalue is treated as nearly
#: defective (its derivative is then taken by finite differences by the callers).
DEFECT_TOL = 1e-8


def spectral_abscissa(A) -> float:
    """Spectral abscissa ``max_i Re lambda_i(A)`` [units of A, e.g. 1/s] (dense LAPACK eig).

    Raises
    ------
    ValueError
        If ``A`` is not a square matrix.
    """
    A = np.asarray(A)
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ValueError(f"A must be a square matrix, got shape {A.shape}")
    return float(np.max(scipy.linalg.eigvals(A).real))


def polynomial_abscissa(parts, speeds, keep_at_zero=None) -> np.ndarray:
    """Spectral abscissa [1/s] of ``A(U) = sum_j U^j A_j`` at each speed [m/s].

    Parameters
    ----------
    parts : sequence of ndarray
        ``(A0, A1, A2, ...)``.
    speeds : array_like
        [m/s].
    keep_at_zero : array of int, optional
        States kept at ``U = 0`` (the aerodynamic lag states are identically zero there).
    """
    out = []
    for u in np.atleast_1d(np.asarray(speeds, float)):
        A = sum(u ** j * a for j, a in enumerate(parts))
        if u == 0 and keep_at_zero is not None:
            A = A[np.ix_(keep_at_zero, keep_at_zero)]
        out.append(spectral_abscissa(A))
    return np.array(out)


def eigenvalue_derivatives(left, right, dA, defect_tol: float = DEFECT_TOL,
                           real_only: bool = False):
    """Derivatives of selected simple eigenvalues and their nearly-defective flags.

    Parameters
    ----------
    left, right : ndarray (n,) or (n, m)
        Left and right eigenvectors of the selected eigenvalues (columns).
    dA : ndarray (n, n), ndarray (n*n, n_p) or scipy.sparse matrix (n*n, n_p)
        One derivative ``dA/dp`` or the column-major ``d vec(A) / dp``.
    defect_tol : float
        Threshold on ``|w^H v|/(|w||v|)`` [-].
    real_only : bool
        Return only ``d Re lambda / dp`` (real arithmetic throughout).

    Returns
    -------
    J : ndarray (m, n_p)
        ``d lambda_i / d p_k`` (complex, or real parts); rows flagged ``bad`` are not to be
        trusted.
    bad : ndarray (m,) bool

    Notes
    -----
    ``w^H dA v / w^H v = sum_ab conj(u_a) v_b dA_ab`` with ``u = w / conj(w^H v)``: one weight
    matrix per eigenvalue, contracted with ``vec(dA)``.
    """
    wl, vr = np.asarray(left), np.asarray(right)
    if wl.ndim == 1:
        wl, vr = wl[:, None], vr[:, None]
    n = wl.shape[0]
    if not hasattr(dA, "tocsr") and np.ndim(dA) == 2 and dA.shape == (n, n) and n * n != n:
        dA = np.asarray(dA).reshape(n * n, 1, order="F")
    whv = np.einsum("ai,ai->i", wl.conj(), vr)
    cond = np.abs(whv) / (np.linalg.norm(wl, axis=0) * np.linalg.norm(vr, axis=0))
    bad = ~(cond >= defect_tol)
    u = wl / np.where(bad, 1.0, whv).conj()
    # W_i[a, b] = conj(u_ai) v_bi; vec in column-major order: index a + n b
    W = np.einsum("ai,bi->iba", u.conj(), vr).reshape(wl.shape[1], -1)

    def contract(Wpart):
        J = np.asarray(dA.T @ Wpart.T).T if hasattr(dA, "tocsr") else Wpart @ dA
        return np.asarray(J, float)

    if real_only:
        return contract(W.real), bad
    return contract(W.real) + 1j * contract(W.imag), bad


def eigenvalue_derivative(w, v, dA) -> complex:
    """``w^H dA v / (w^H v)`` of one simple eigenvalue (:func:`eigenvalue_derivatives`).

    Parameters
    ----------
    w, v : ndarray (n,)
        Left and right eigenvectors.
    dA : ndarray (n, n)
        Derivative of the matrix.
    """
    J, _ = eigenvalue_derivatives(w, v, dA, defect_tol=0.0)
    return complex(J[0, 0])
