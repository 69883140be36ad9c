"""Eigenvalue tools shared by model/ and design/: spectral abscissa and eigenvalue derivatives.

First-order perturbation of a simple eigenvalue ``lambda`` of ``A(p)`` with right eigenvector
``v`` (``A v = lambda v``) and left eigenvector ``w`` (``w^H A = lambda w^H``)::

    d lambda / d p_k = w^H (dA/dp_k) v / (w^H v)

(Seyranian & Mailybaev 2003). Near a defective eigenvalue ``w^H v -> 0`` and the derivative is
unbounded: :func:`eigenvalue_derivatives` flags those eigenvalues by the normalised conditioning
``|w^H v| / (|w| |v|)`` (the reciprocal of the eigenvalue condition number). numpy only.
"""

from __future__ import annotations

import os
import threading

import numpy as np
import scipy.linalg

__all__ = [
    "DEFECT_TOL",
    "eigen_map",
    "eigenvalue_derivative",
    "eigenvalue_derivatives",
    "polynomial_abscissa",
    "spectral_abscissa",
]

#: Threads of :func:`eigen_map` in the main process (LAPACK's ``geev`` runs without the GIL, so
#: the dense eigen-decompositions of a speed grid use both cores of a 2-core machine while the
#: design's one process would leave one idle). ``BRIDGEFLAP_EIG_THREADS=1`` runs them in turn.
#: Worker processes run them in turn: their pool already holds the cores.
EIG_THREADS = 2
#: Fewer tasks than this run in turn (a thread's start costs ~100 us).
EIG_MAP_MIN_TASKS = 4
_IN_MAP = threading.local()


def _eig_threads() -> int:
    import multiprocessing

    if multiprocessing.parent_process() is not None:
        return 1
    try:
        n = int(os.environ.get("BRIDGEFLAP_EIG_THREADS", EIG_THREADS))
    except ValueError:
        n = EIG_THREADS
    return max(1, min(n, os.cpu_count() or 1))


def eigen_map(fn, items) -> list:
    """``[fn(x) for x in items]``, in up to :data:`EIG_THREADS` threads.

    For per-speed eigen-decompositions (``fn`` spends its time in LAPACK, which releases the
    GIL, and shares no state between calls): each call computes what it computes in turn, so
    the results are bit-identical to the serial loop's, in the same order. Serial in a worker
    process, for fewer than :data:`EIG_MAP_MIN_TASKS` items, and inside a call of its own.
    The threads live for the call only: a process forked later (a worker pool) starts from a
    process with no extra thread."""
    items = list(items)
    n = _eig_threads()
    if n == 1 or len(items) < EIG_MAP_MIN_TASKS or getattr(_IN_MAP, "on", False):
        return [fn(x) for x in items]
    from concurrent.futures import ThreadPoolExecutor

    def run(x):
        _IN_MAP.on = True
        try:
            return fn(x)
        finally:
            _IN_MAP.on = False

    with ThreadPoolExecutor(n, thread_name_prefix="bridgeflap-eig") as ex:
        return list(ex.map(run, items))

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
