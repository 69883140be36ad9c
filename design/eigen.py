"""Differentiable spectral-abscissa constraints for CasADi (docs/methods.md#eigenvalue-constraints).

CasADi has no differentiable nonsymmetric eigendecomposition, so the eigenvalues of a
parameterised real matrix ``A(U, p) = sum_j U^j A_j(p)`` are computed in numpy/scipy inside a
:class:`casadi.Callback` whose Jacobian is supplied analytically from left/right eigenvectors
(:func:`model.spectrum.eigenvalue_derivatives`, the package's one eigenvalue derivative)::

    d lambda_i / d p_k = w_i^H (dA/dp_k) v_i / (w_i^H v_i)

with ``A v_i = lambda_i v_i`` and ``w_i^H A = lambda_i w_i^H``; ``dA_j/dp`` comes from the
symbolic parts (``casadi.jacobian``). :class:`PolynomialTopRealParts` returns the ``m`` largest
real parts of ``eig(A(U, p))`` at each speed of a grid, sorted descending. Constraining all of
them (``<= -margin``) bounds the spectral abscissa while the individual branches stay smooth away
from crossings (docs/methods.md#eigenvalue-constraints, m ~ 3-6 per speed). The constraint is
nonsmooth where eigenvalues coalesce; always verify the final design a posteriori with
:func:`model.spectrum.spectral_abscissa` on a finer speed grid
(docs/methods.md#eigenvalue-constraints).

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

Units: eigenvalues of a state matrix in physical time are in [1/s].
"""

from __future__ import annotations

import time

import casadi as ca
import numpy as np
import scipy.linalg

from model.spectrum import DEFECT_TOL, eigenvalue_derivatives

__all__ = ["PolynomialTopRealParts"]

class _VectorIO:
    """CasADi Callback boilerplate: one dense input ``p`` of length ``self._n_p`` and one dense
    output named ``out`` (sparsity from the subclass)."""

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


class _JacobianCallback(ca.Callback):
    """Jacobian of a :class:`PolynomialTopRealParts`; inputs ``[p, out]`` (CasADi >= 3.6)."""

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


class PolynomialTopRealParts(_VectorIO, ca.Callback):
    """Top-``m`` real parts of ``A(U, p) = sum_j U^j A_j(p)`` at a list of speeds, stacked.

    One callback for a whole speed grid: ``dA_j/dp`` is evaluated once per ``p`` (sparse),
    each speed needs one ``eig`` with left and right eigenvectors, shared between the value
    and the Jacobian (cached by ``p``). Used by the compensator design (``A_j`` the closed-loop
    parts of :func:`model.symbolic.closed_loop_functions`); with one part ``A_0(p)`` and one
    speed it is the top-``m`` real parts of a single matrix.

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
    defect_tol : float
        Nearly-defective threshold on ``|w^H v|/(|w||v|)`` [-]
        (:func:`model.spectrum.eigenvalue_derivatives`); such rows are taken by differences.
    fd_step : float
        Relative central-difference step of that fallback [-].
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
        outs = self._dparts(ca.DM(p))
        outs = outs if isinstance(outs, (list, tuple)) else [outs]
        dparts = [ca.DM(d).sparse() for d in outs]
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
            Js, bad = eigenvalue_derivatives(r[1], r[2], dA, self.defect_tol, real_only=True)
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
