"""Differentiable spectral-abscissa constraints for CasADi (METHODS §4).

CasADi has no differentiable nonsymmetric eigendecomposition, so the eigenvalues of a
parameterised real matrix ``A(p)`` are computed in numpy/scipy inside a :class:`casadi.Callback`
whose Jacobian is supplied analytically from left/right eigenvectors::

    d lambda_i / d p_k = w_i^H (dA/dp_k) v_i / (w_i^H v_i)

with ``A v_i = lambda_i v_i`` and ``w_i^H A = lambda_i w_i^H``; ``dA/dp`` comes from the symbolic
``A_fun`` (``casadi.jacobian``). Two constraint functions are offered:

* :class:`TopRealParts` -- the ``m`` largest real parts of ``eig(A(p))``, sorted descending.
  Constraining all of them (``<= -margin``) bounds the spectral abscissa while the individual
  branches stay smooth away from crossings (METHODS §4, m ~ 3-6 per speed).
* :class:`SmoothAbscissa` (:func:`smooth_abscissa`) -- ``tau * log(sum_i exp(Re lambda_i / tau))``,
  a smooth upper bound of the spectral abscissa with
  ``alpha(A) <= result <= alpha(A) + tau * log(n)``.

Both are nonsmooth where eigenvalues coalesce; always verify the final design a posteriori with
:func:`spectral_abscissa` on a finer speed grid (METHODS §4).

CasADi Callback Jacobian signature (checked on CasADi 3.8.2): ``get_jacobian(name, inames,
onames, opts)`` must return a Function with inputs ``[p, out]`` (``inames == ['i0', 'out_o0']``,
the nominal input *and* output) and one output ``jac_o0_i0`` of shape ``(n_out, n_p)``.

Lifetime
--------
A ``casadi.Callback`` is a Python object referenced by CasADi only weakly: the caller must keep
the callback object alive for as long as any expression, ``casadi.Function`` or ``nlpsol``
built from it is used (otherwise CasADi calls into a freed object and crashes). The Jacobian
callback created by ``get_jacobian`` is stored on its parent for the same reason. Store the
callbacks next to the solver, e.g. in the design-problem object.

Units: eigenvalues of a state matrix in physical time are in [1/s]; the softmax temperature
``tau`` has the same unit.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.linalg

__all__ = [
    "PolynomialTopRealParts",
    "SmoothAbscissa",
    "TopRealParts",
    "eig_real_part_sensitivities",
    "smooth_abscissa",
    "spectral_abscissa",
]

#: Default threshold on the normalised eigenvalue conditioning ``|w^H v| / (|w| |v|)``
#: (the reciprocal of the eigenvalue condition number) below which an eigenvalue is treated
#: as nearly defective and its derivative is taken by central finite differences.
DEFECT_TOL = 1e-8


def spectral_abscissa(A: np.ndarray) -> float:
    """Return the spectral abscissa ``max_i Re lambda_i(A)`` [units of A, e.g. 1/s].

    Parameters
    ----------
    A : numpy.ndarray
        Square real (or complex) matrix.

    Returns
    -------
    float
        Largest real part of the eigenvalues (dense LAPACK ``eig``), for a posteriori checks.
    """
    A = np.asarray(A)
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ValueError(f"A must be a square matrix, got shape {A.shape}")
    return float(np.max(scipy.linalg.eigvals(A).real))


def eig_real_part_sensitivities(
    A: np.ndarray, dA: np.ndarray, defect_tol: float = DEFECT_TOL
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eigenvalues of ``A`` and the gradients of their real parts.

    Parameters
    ----------
    A : numpy.ndarray
        (n, n) real matrix.
    dA : numpy.ndarray
        (n, n, n_p) derivatives ``dA/dp_k``.
    defect_tol : float
        Threshold on ``|w^H v| / (|w| |v|)`` [-] below which an eigenvalue is flagged as nearly
        defective (its analytic derivative is unreliable or unbounded).

    Returns
    -------
    lam : numpy.ndarray
        (n,) complex eigenvalues.
    dre : numpy.ndarray
        (n, n_p) ``d Re lambda_i / d p_k`` (rows of flagged eigenvalues are still filled with
        the analytic formula but must not be trusted).
    ill : numpy.ndarray
        (n,) bool, True where the eigenvalue is nearly defective.

    Notes
    -----
    First-order perturbation of a simple eigenvalue:
    ``d lambda / d p_k = w^H (dA/dp_k) v / (w^H v)``.
    """
    lam, vl, vr = scipy.linalg.eig(A, left=True, right=True)
    whv = np.einsum("ai,ai->i", vl.conj(), vr)
    scale = np.linalg.norm(vl, axis=0) * np.linalg.norm(vr, axis=0)
    conditioning = np.abs(whv) / scale
    ill = conditioning < defect_tol
    safe = np.where(ill, 1.0, whv)
    # w_i^H dA_k v_i for all i, k
    num = np.einsum("ai,abk,bi->ik", vl.conj(), dA, vr)
    dlam = num / safe[:, None]
    return lam, dlam.real, ill


class _VectorIO:
    """CasADi Callback boilerplate shared by the eigenvalue callbacks: one dense input ``p``
    of length ``self._n_p`` and one dense output named ``out`` (sparsity from the subclass)."""

    def get_n_in(self):
        return 1

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return "p"

    def get_name_out(self, i):
        return "out"

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense(self._n_p, 1)


class _EigenCallback(_VectorIO, ca.Callback):
    """Common machinery: evaluate A(p), dA/dp numerically and the eigen-sensitivities.

    Subclasses define ``_outputs(lam) -> values`` and ``_jacobian_from(lam, dre, ill) ->
    (J, bad_rows)``: the analytic Jacobian and the rows that need finite differences.
    """

    def __init__(self, name, A_fun, n_out, defect_tol, fd_step, opts):
        ca.Callback.__init__(self)
        if not isinstance(A_fun, ca.Function):
            raise TypeError("A_fun must be a casadi.Function p -> A")
        if A_fun.n_in() != 1 or A_fun.n_out() != 1:
            raise ValueError("A_fun must have exactly one input p and one output A")
        if A_fun.size2_in(0) != 1:
            raise ValueError("A_fun's input p must be a column vector")
        n = A_fun.size1_out(0)
        if A_fun.size2_out(0) != n:
            raise ValueError("A_fun's output A must be square")
        self._A_fun = A_fun
        self._n = n
        self._n_p = A_fun.size1_in(0)
        self._n_out = n_out
        self.defect_tol = float(defect_tol)
        self.fd_step = float(fd_step)
        #: Number of Jacobian rows taken by finite differences since construction.
        self.fd_fallback_count = 0
        #: Output indices whose Jacobian row used finite differences at the last Jacobian call.
        self.last_fd_rows: tuple[int, ...] = ()
        sym = ca.SX if A_fun.is_a("SXFunction") else ca.MX
        p = sym.sym("p", self._n_p)
        A = A_fun(p)
        self._dA_fun = ca.Function("dA_dp", [p], [ca.jacobian(ca.vec(A), p)])
        self._jac_callback = None  # kept alive here, see module docstring
        self._cache_key = None
        self._cache = None
        self.construct(name, dict(opts or {}))

    # ---- CasADi interface: one dense input p, one dense output (see _VectorIO)
    def get_sparsity_out(self, i):
        return ca.Sparsity.dense(self._n_out, 1)

    def eval(self, arg):
        p = np.asarray(arg[0], dtype=float).ravel()
        return [ca.DM(self._outputs(self._eigvals(p)))]

    def has_jacobian(self):
        return True

    def get_jacobian(self, name, inames, onames, opts):
        self._jac_callback = _JacobianCallback(self, name, inames, onames, opts)
        return self._jac_callback

    # ---- numerics
    def matrix(self, p) -> np.ndarray:
        """Return ``A(p)`` as a dense numpy array."""
        return np.asarray(self._A_fun(ca.DM(np.asarray(p, dtype=float))).full())

    def _eigvals(self, p: np.ndarray) -> np.ndarray:
        A = self.matrix(p)
        if not np.all(np.isfinite(A)):  # solver failure is data: NaN, not an exception
            return np.full(self._n, np.nan, dtype=complex)
        return scipy.linalg.eigvals(A)

    def _matrix_and_derivative(self, p: np.ndarray):
        """``(A(p), dA/dp)`` with ``dA`` shaped (n, n, n_p); ``(None, None)`` if not finite."""
        A = self.matrix(p)
        dA = np.asarray(self._dA_fun(ca.DM(p)).full()).reshape(
            (self._n, self._n, self._n_p), order="F"
        )
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(dA))):
            return None, None
        return A, dA

    def jacobian(self, p) -> np.ndarray:
        """Jacobian of the output w.r.t. ``p`` [(n_out, n_p)], with finite-difference fallback.

        Rows depending on a nearly defective eigenvalue (``|w^H v|/(|w||v|) < defect_tol``)
        are replaced by central differences with step ``fd_step`` (relative to ``max(1,|p_k|)``)
        and reported in :attr:`last_fd_rows` / :attr:`fd_fallback_count`.
        """
        p = np.asarray(p, dtype=float).ravel()
        key = p.tobytes()
        if key == self._cache_key:
            return self._cache.copy()
        A, dA = self._matrix_and_derivative(p)
        if A is None:
            return np.full((self._n_out, self._n_p), np.nan)
        lam, dre, ill = eig_real_part_sensitivities(A, dA, self.defect_tol)
        J, bad = self._jacobian_from(lam, dre, ill)
        bad_rows = tuple(int(i) for i in np.flatnonzero(bad))
        if bad_rows:
            for k in range(self._n_p):
                h = self.fd_step * max(1.0, abs(p[k]))
                e = np.zeros_like(p)
                e[k] = h
                fp = self._outputs(self._eigvals(p + e))
                fm = self._outputs(self._eigvals(p - e))
                rows = list(bad_rows)
                J[rows, k] = (fp[rows] - fm[rows]) / (2.0 * h)
            self.fd_fallback_count += len(bad_rows)
        self.last_fd_rows = bad_rows
        self._cache_key, self._cache = key, J.copy()
        return J


class _JacobianCallback(ca.Callback):
    """Jacobian of an :class:`_EigenCallback`; inputs ``[p, out]`` (CasADi >= 3.6)."""

    def __init__(self, parent, name, inames, onames, opts):
        ca.Callback.__init__(self)
        self._parent = parent
        self._inames = list(inames)
        self._onames = list(onames)
        self.construct(name, dict(opts or {}))

    def get_n_in(self):
        return 2

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return self._inames[i]

    def get_name_out(self, i):
        return self._onames[i]

    def get_sparsity_in(self, i):
        if i == 0:
            return ca.Sparsity.dense(self._parent._n_p, 1)
        return ca.Sparsity.dense(self._parent._n_out, 1)

    def get_sparsity_out(self, i):
        return ca.Sparsity.dense(self._parent._n_out, self._parent._n_p)

    def eval(self, arg):
        return [ca.DM(self._parent.jacobian(np.asarray(arg[0], dtype=float).ravel()))]


class TopRealParts(_EigenCallback):
    """The ``m`` largest real parts of ``eig(A(p))``, sorted descending, as a CasADi function.

    Parameters
    ----------
    A_fun : casadi.Function
        ``p -> A`` with ``p`` a dense (n_p, 1) column and ``A`` real (n, n).
    m : int
        Number of real parts returned, ``1 <= m <= n``.
    name : str
        CasADi function name.
    defect_tol : float
        Nearly-defective threshold on ``|w^H v|/(|w||v|)`` [-], see
        :func:`eig_real_part_sensitivities`.
    fd_step : float
        Relative central-difference step of the fallback [-].
    opts : dict, optional
        CasADi Function options.

    Notes
    -----
    Call it on a symbol (``TopRealParts(A_fun, 4)(p)``) inside an NLP; use Ipopt with
    ``hessian_approximation = "limited-memory"`` (no second derivatives are provided).
    Complex-conjugate pairs appear twice with equal real parts; their gradients are equal.
    Keep the object alive while it is used (module docstring).
    """

    def __init__(
        self,
        A_fun: ca.Function,
        m: int,
        name: str = "top_real_parts",
        defect_tol: float = DEFECT_TOL,
        fd_step: float = 1e-6,
        opts: dict | None = None,
    ):
        n = A_fun.size1_out(0)
        if not (isinstance(m, (int, np.integer)) and 1 <= m <= n):
            raise ValueError(f"m must be an integer in 1..{n}, got {m!r}")
        self.m = int(m)
        super().__init__(name, A_fun, int(m), defect_tol, fd_step, opts)

    def _order(self, lam):
        # stable sort: ties (conjugate pairs) keep LAPACK order, same in value and Jacobian
        return np.argsort(-lam.real, kind="stable")[: self.m]

    def _outputs(self, lam):
        return lam.real[self._order(lam)]

    def _jacobian_from(self, lam, dre, ill):
        idx = self._order(lam)
        return dre[idx].copy(), ill[idx]

    def jacobian(self, p) -> np.ndarray:
        """Jacobian [(m, n_p)] contracting only the ``m`` selected eigenpairs.

        Same formula as :func:`eig_real_part_sensitivities` (``Re w^H dA_k v / w^H v``) but
        ``O(m n^2 n_p)`` instead of ``O(n^3 n_p)``: at 146 states and 5 parameters about
        10x faster than contracting every eigenvalue. Rows of nearly defective eigenvalues
        (``|w^H v|/(|w||v|) < defect_tol``) are taken by central differences (reported in
        :attr:`last_fd_rows` / :attr:`fd_fallback_count`).
        """
        p = np.asarray(p, dtype=float).ravel()
        key = p.tobytes()
        if key == self._cache_key:
            return self._cache.copy()
        A, dA = self._matrix_and_derivative(p)
        if A is None:
            return np.full((self._n_out, self._n_p), np.nan)
        lam, vl, vr = scipy.linalg.eig(A, left=True, right=True)
        idx = self._order(lam)
        J, bad = _selected_sensitivities(vl[:, idx], vr[:, idx],
                                         dA.reshape(self._n * self._n, self._n_p, order="F"),
                                         self.defect_tol)
        bad_rows = tuple(int(i) for i in np.flatnonzero(bad))
        if bad_rows:
            rows = list(bad_rows)
            for k in range(self._n_p):
                h = self.fd_step * max(1.0, abs(p[k]))
                e = np.zeros_like(p)
                e[k] = h
                fp = self._outputs(self._eigvals(p + e))
                fm = self._outputs(self._eigvals(p - e))
                J[rows, k] = (fp[rows] - fm[rows]) / (2.0 * h)
            self.fd_fallback_count += len(bad_rows)
        self.last_fd_rows = bad_rows
        self._cache_key, self._cache = key, J.copy()
        return J


def _selected_sensitivities(wl, vr, dA_flat, defect_tol):
    """``d Re lambda_i / dp`` of selected eigenpairs and their nearly-defective flags.

    Parameters
    ----------
    wl, vr : numpy.ndarray
        (n, m) left and right eigenvectors of the selected eigenvalues.
    dA_flat : numpy.ndarray or scipy.sparse matrix
        (n*n, n_p) ``d vec(A) / dp`` in column-major (Fortran) ``vec`` order.
    defect_tol : float
        Threshold on ``|w^H v|/(|w||v|)`` [-].

    Returns
    -------
    J : numpy.ndarray
        (m, n_p) real-part sensitivities (rows flagged ``bad`` are not to be trusted).
    bad : numpy.ndarray
        (m,) bool.

    Notes
    -----
    ``Re(w^H dA v / w^H v) = sum_ab Re(conj(u_a) v_b) dA_ab`` with ``u = w / conj(w^H v)``:
    one real weight matrix per eigenvalue, contracted with ``vec(dA)``.
    """
    whv = np.einsum("ai,ai->i", wl.conj(), vr)
    cond = np.abs(whv) / (np.linalg.norm(wl, axis=0) * np.linalg.norm(vr, axis=0))
    bad = ~(cond >= defect_tol)
    u = wl / np.where(bad, 1.0, whv).conj()
    # W_i[a, b] = Re(conj(u_ai) v_bi); vec in column-major order: index a + n b
    W = np.einsum("ai,bi->iba", u.conj(), vr).real.reshape(wl.shape[1], -1)
    J = np.asarray(dA_flat.T @ W.T).T if hasattr(dA_flat, "tocsr") else W @ dA_flat
    return np.asarray(J, float), bad


class PolynomialTopRealParts(_VectorIO, ca.Callback):
    """Top-``m`` real parts of ``A(U, p) = sum_j U^j A_j(p)`` at a list of speeds, stacked.

    One callback for a whole speed grid: ``dA_j/dp`` is evaluated once per ``p`` (sparse),
    each speed needs one ``eig`` with left and right eigenvectors, shared between the value
    and the Jacobian (cached by ``p``). This is the multi-speed form of :class:`TopRealParts`
    used by the compensator design (``A_j`` the closed-loop parts of :mod:`model.flaps`).

    Parameters
    ----------
    parts_fun : casadi.Function
        ``p -> (A_0, A_1, ..., A_d)``, one input (dense column) and ``d + 1`` square outputs.
    speeds : array_like
        Speeds ``U`` [m/s] (any scalar parameter of the polynomial).
    m : int
        Real parts returned per speed (sorted descending).
    subsets : dict, optional
        ``{speed: indices}``: use only ``A[idx][:, idx]`` at that speed (e.g. drop states
        whose eigenvalues are identically zero at ``U = 0``).
    defect_tol, fd_step : float
        As for :class:`TopRealParts`.
    name : str
        CasADi function name.

    Notes
    -----
    Output layout: ``m`` values for ``speeds[0]``, then ``speeds[1]``, ... Keep the object
    alive while it is used (module docstring).
    """

    def __init__(self, parts_fun: ca.Function, speeds, m: int, subsets=None,
                 defect_tol: float = DEFECT_TOL, fd_step: float = 1e-6,
                 name: str = "top_real_parts_grid", opts: dict | None = None):
        ca.Callback.__init__(self)
        if not isinstance(parts_fun, ca.Function) or parts_fun.n_in() != 1:
            raise TypeError("parts_fun must be a casadi.Function p -> (A_0, ..., A_d)")
        self._parts = parts_fun
        self._n_p = parts_fun.size1_in(0)
        self._n = parts_fun.size1_out(0)
        self.speeds = np.asarray(speeds, float).ravel()
        if self.speeds.size == 0:
            raise ValueError("need at least one speed")
        subsets = dict(subsets or {})
        self._idx = [np.asarray(subsets[u], int) if u in subsets else None
                     for u in self.speeds]
        sizes = [self._n if ix is None else ix.size for ix in self._idx]
        if not (isinstance(m, (int, np.integer)) and 1 <= m <= min(sizes)):
            raise ValueError(f"m must be an integer in 1..{min(sizes)}, got {m!r}")
        self.m = int(m)
        self.defect_tol = float(defect_tol)
        self.fd_step = float(fd_step)
        self.fd_fallback_count = 0
        self.evaluations = 0
        self.eval_time_s = 0.0
        sym = ca.SX if parts_fun.is_a("SXFunction") else ca.MX
        p = sym.sym("p", self._n_p)
        outs = parts_fun(p)
        outs = outs if isinstance(outs, (list, tuple)) else [outs]
        self._dparts = ca.Function("dparts", [p], [ca.jacobian(ca.vec(a), p) for a in outs])
        self._key = None
        self._store = None
        self._jac_callback = None
        self.construct(name, dict(opts or {}))

    # ---- CasADi interface: one dense input p, one dense output (see _VectorIO)
    def get_sparsity_out(self, i):
        return ca.Sparsity.dense(self.m * self.speeds.size, 1)

    def has_jacobian(self):
        return True

    def get_jacobian(self, name, inames, onames, opts):
        self._jac_callback = _GridJacobianCallback(self, name, inames, onames, opts)
        return self._jac_callback

    def eval(self, arg):
        return [ca.DM(self.values(np.asarray(arg[0], float).ravel()))]

    # ---- numerics
    def matrices(self, p) -> list[np.ndarray]:
        """``A(U, p)`` at every speed (subset applied) as dense arrays."""
        parts = self._parts(ca.DM(np.asarray(p, float)))
        parts = parts if isinstance(parts, (list, tuple)) else [parts]
        parts = [np.asarray(a.full()) for a in parts]
        out = []
        for u, ix in zip(self.speeds, self._idx, strict=True):
            A = sum(u**j * a for j, a in enumerate(parts))
            out.append(A if ix is None else A[np.ix_(ix, ix)])
        return out

    def _decompose(self, p):
        key = p.tobytes()
        if key != self._key:
            import time

            t0 = time.perf_counter()
            rows = []
            for A in self.matrices(p):
                if not np.all(np.isfinite(A)):
                    rows.append(None)
                    continue
                lam, vl, vr = scipy.linalg.eig(A, left=True, right=True)
                idx = np.argsort(-lam.real, kind="stable")[: self.m]
                rows.append((lam[idx], vl[:, idx], vr[:, idx]))
            self._key, self._store = key, rows
            self.evaluations += 1
            self.eval_time_s += time.perf_counter() - t0
        return self._store

    def values(self, p) -> np.ndarray:
        """The stacked top-``m`` real parts [(m * n_speeds,)]; NaN where ``A`` is not finite."""
        p = np.asarray(p, float).ravel()
        out = [np.full(self.m, np.nan) if r is None else r[0].real
               for r in self._decompose(p)]
        return np.concatenate(out)

    def jacobian(self, p) -> np.ndarray:
        """Analytic Jacobian [(m * n_speeds, n_p)], central differences for defective rows."""
        p = np.asarray(p, float).ravel()
        rows = self._decompose(p)
        dparts = [ca.DM(d).sparse() if hasattr(ca.DM(d), "sparse") else d.full()
                  for d in self._dparts(ca.DM(p))]
        dparts = dparts if isinstance(dparts, list) else [dparts]
        J = np.full((self.m * self.speeds.size, self._n_p), np.nan)
        n = self._n
        bad_rows = []
        for s, (u, ix, r) in enumerate(zip(self.speeds, self._idx, rows, strict=True)):
            if r is None:
                continue
            dA = sum(u**j * d for j, d in enumerate(dparts))
            if ix is not None:   # rows of vec(A[ix, ix]) in column-major order
                flat = (ix[:, None] + n * ix[None, :]).ravel(order="F")
                dA = dA[flat]
            Js, bad = _selected_sensitivities(r[1], r[2], dA, self.defect_tol)
            J[s * self.m:(s + 1) * self.m] = Js
            bad_rows.extend(s * self.m + int(i) for i in np.flatnonzero(bad))
        if bad_rows:
            for k in range(self._n_p):
                h = self.fd_step * max(1.0, abs(p[k]))
                e = np.zeros_like(p)
                e[k] = h
                fp, fm = self._plain_values(p + e), self._plain_values(p - e)
                J[bad_rows, k] = (fp[bad_rows] - fm[bad_rows]) / (2.0 * h)
            self.fd_fallback_count += len(bad_rows)
        return J

    def _plain_values(self, p):
        return np.concatenate([np.sort(scipy.linalg.eigvals(A).real)[::-1][: self.m]
                               for A in self.matrices(p)])


class _GridJacobianCallback(_JacobianCallback):
    def get_sparsity_in(self, i):
        if i == 0:
            return ca.Sparsity.dense(self._parent._n_p, 1)
        return ca.Sparsity.dense(self._parent.m * self._parent.speeds.size, 1)

    def get_sparsity_out(self, i):
        return ca.Sparsity.dense(self._parent.m * self._parent.speeds.size, self._parent._n_p)


class SmoothAbscissa(_EigenCallback):
    """Log-sum-exp smooth spectral abscissa ``tau * log(sum_i exp(Re lambda_i(A(p)) / tau))``.

    Parameters
    ----------
    A_fun : casadi.Function
        ``p -> A`` with ``p`` a dense (n_p, 1) column and ``A`` real (n, n).
    temperature : float
        ``tau`` > 0 [units of the eigenvalues, 1/s for a state matrix]. The result lies in
        ``[alpha(A), alpha(A) + tau log n]``; smaller ``tau`` is tighter but less smooth.
    name, defect_tol, fd_step, opts
        As for :class:`TopRealParts`.

    Notes
    -----
    Gradient: ``sum_i softmax_i * grad Re lambda_i`` with ``softmax_i =
    exp((Re lambda_i - alpha)/tau) / sum_j exp((Re lambda_j - alpha)/tau)`` (computed shifted
    by the abscissa, so no overflow). If an eigenvalue with weight > 1e-14 is nearly defective,
    the whole gradient is taken by central differences. Keep the object alive while it is used.
    """

    def __init__(
        self,
        A_fun: ca.Function,
        temperature: float,
        name: str = "smooth_abscissa",
        defect_tol: float = DEFECT_TOL,
        fd_step: float = 1e-6,
        opts: dict | None = None,
    ):
        temperature = float(temperature)
        if not (np.isfinite(temperature) and temperature > 0.0):
            raise ValueError(f"temperature must be finite and > 0, got {temperature!r}")
        self.temperature = temperature
        super().__init__(name, A_fun, 1, defect_tol, fd_step, opts)

    def _weights(self, lam):
        re = lam.real
        shift = np.max(re)
        e = np.exp((re - shift) / self.temperature)
        return shift, e, e / np.sum(e)

    def _outputs(self, lam):
        shift, e, _ = self._weights(lam)
        return np.array([shift + self.temperature * np.log(np.sum(e))])

    def _jacobian_from(self, lam, dre, ill):
        _, _, w = self._weights(lam)
        J = (w @ dre)[None, :]
        bad = np.array([bool(np.any(ill & (w > 1e-14)))])
        return J, bad


def smooth_abscissa(A_fun: ca.Function, temperature: float, **kwargs) -> SmoothAbscissa:
    """Build the log-sum-exp smooth spectral abscissa callback of ``A_fun``.

    Parameters
    ----------
    A_fun : casadi.Function
        ``p -> A`` (real square A).
    temperature : float
        Softmax temperature ``tau`` > 0 [units of the eigenvalues, 1/s].
    **kwargs
        Passed to :class:`SmoothAbscissa` (``name``, ``defect_tol``, ``fd_step``, ``opts``).

    Returns
    -------
    SmoothAbscissa
        A CasADi function ``p -> tau log sum exp(Re lambda / tau)``; keep it alive while used.
    """
    return SmoothAbscissa(A_fun, temperature, **kwargs)
