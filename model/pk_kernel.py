"""Lean inner loop of the p-k method: frozen matrices at one speed and a secant k iteration.

The p-k point (:mod:`model.pk`) solves ``p = eig(A(U, k))`` with ``k = |Im p| b / U``. Its
reference form rebuilds ``A`` from the frozen system at every iteration
(``FrozenParts.matrix`` with :func:`model.theodorsen.theodorsen`, or
``DerivativeFrozen.matrix_at_k`` with the derivatives' generic ``matrix``) and iterates ``k`` by
fixed-point substitution. Here the same matrices are formed from constants computed once:

* Theodorsen (:class:`~model.assembly.FrozenParts`):
  ``A(U, c) = [A0 + U A1 + U^2 A2] + c [U A1c + U^2 A2c]``, both brackets per speed, ``c`` from
  :func:`model.theodorsen.theodorsen_scalar`;
* flutter derivatives (:class:`~model.derivative_system.DerivativeFrozen`): the projection
  ``M^-1 L Qn R`` of each entry of ``Qn`` once (``Qn`` of the flat plate in closed form, tables
  by one linear interpolation of all columns, other sources through their ``matrix``), and the
  blocks written into a preallocated matrix (no ``np.block``);

and the eigenvalues come from LAPACK ``geev`` without vectors. :meth:`Kernel.point` iterates
``k`` on the consistency ``g(k) = |Im p(k)| b / U - k = 0`` by secant steps (the first one with
the branch's slope ``dg/dk`` from the previous point when the caller keeps it), with fixed-point
steps as the fallback; it stops when the frequency implied by ``k`` equals ``|Im p|`` to
``tol max(1, |p|)`` [rad/s]. Method: docs/methods.md#p-k-check.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

from model.theodorsen import theodorsen_scalar

__all__ = ["BranchMemory", "Kernel", "kernel_for"]

#: secant steps without halving ``|g|`` after which a k iteration stops as not converged: near a
#: root the secant gains far more than a factor 2 per step (2 to 5 steps per point on the IABSE
#: cases), so this many without progress means that the branch has no consistent k there (a
#: p-k branch ending where a heavily damped pair turns real); the fixed-point reference
#: iterates to its 100 steps in that case
STAGNATION = 3
#: nodes of the extrapolated starting k (a cubic: about 1e-9 relative on a 0.4 m/s grid)
NODES = 4


def _eigvals_real(a):
    wr, wi, _, _, info = lapack.dgeev(a, compute_vl=0, compute_vr=0, overwrite_a=1)
    if info != 0:
        raise np.linalg.LinAlgError("eigenvalues did not converge (dgeev)")
    return wr + 1j * wi


def _eigvals_complex(a):
    w, _, _, info = lapack.zgeev(a, compute_vl=0, compute_vr=0, overwrite_a=1)
    if info != 0:
        raise np.linalg.LinAlgError("eigenvalues did not converge (zgeev)")
    return w


class BranchMemory:
    """What the k iteration of one branch carries from point to point: the last secant slope
    ``dg/dk`` and the last :data:`NODES` converged ``(U, k U)`` (a polynomial extrapolation of
    the frequency ``k U / b``, which varies slowly with ``U`` where ``k`` goes like ``1/U``)."""

    __slots__ = ("slope", "us", "ks")

    def __init__(self):
        self.slope, self.us, self.ks = None, [], []

    def record(self, U: float, k: float, slope) -> None:
        self.slope = slope
        self.us = [*self.us[1 - NODES:], float(U)]
        self.ks = [*self.ks[1 - NODES:], float(k) * float(U)]

    def guess(self, U: float, k_pred: float) -> float:
        """Starting ``k`` at ``U``: the polynomial through the last :data:`NODES` points when
        they are distinct and near (``U`` within 2 of their spreads), and it agrees with
        ``k_pred`` (from the branch's predicted eigenvalue) to 1 %; else ``k_pred``."""
        us, ks = self.us, self.ks
        if len(us) < NODES:
            return k_pred
        spread = max(us) - min(us)
        if not (spread > 0 and len(set(us)) == NODES and abs(U - us[-1]) <= spread):
            return k_pred
        total = 0.0
        for i in range(NODES):
            w = ks[i]
            for j in range(NODES):
                if j != i:
                    w *= (U - us[j]) / (us[i] - us[j])
            total += w
        kq = total / U
        return kq if abs(kq - k_pred) <= 1e-2 * k_pred else k_pred


class Kernel:
    """Frozen p-k matrices at one speed (:meth:`set_speed`) and the k iteration (:meth:`point`).

    Subclasses provide :meth:`set_speed` and :meth:`eigvals` ``(kr)``; ``half_chord`` [m] is the
    ``b`` of ``k = |Im p| b / U``.
    """

    half_chord: float
    speed: float = float("nan")

    def set_speed(self, U: float) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def eigvals(self, kr: float) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def point(self, U: float, p_guess: complex, hint=None, tol: float = 1e-10, maxit: int = 50):
        """One p-k point near ``p_guess`` at ``U`` [m/s] (secant on the k consistency).

        ``hint``: the branch's :class:`BranchMemory` (or None), read for the first step and
        updated. Returns ``(p, converged, eigenvalues of the last matrix, index
        of p among them)``, as :func:`model.pk._pk_point`.
        """
        if U != self.speed:
            self.set_speed(U)
        w = U / self.half_chord  # k -> frequency [rad/s]
        p = complex(p_guess)
        k = abs(p.imag) / w
        slope = None
        if hint is not None:
            k, slope = hint.guess(U, k), hint.slope
        k_old = g_old = None
        if slope is not None and not slope < 0:
            slope = None  # only a contracting map's slope (dg/dk = T' - 1 < 0) is carried over
        lam, idx = np.array([p]), 0
        best, since = np.inf, 0
        for _ in range(maxit):
            lam = self.eigvals(k)
            idx = int(np.argmin(np.abs(lam - p)))
            p = complex(lam[idx])
            g = abs(p.imag) / w - k
            if abs(g) * w <= tol * max(1.0, abs(p)):
                if hint is not None:
                    hint.record(U, k, slope)
                return p, True, lam, idx
            if abs(g) < 0.5 * best:
                best, since = abs(g), 0
            else:
                since += 1
                if since >= STAGNATION:
                    break  # no root near: |g| has not halved in STAGNATION steps
            if k_old is not None:
                dk = k - k_old
                # no slope from a step too small to resolve it
                slope = ((g - g_old) / dk if g != g_old and abs(dk) > 1e-13 * max(k, 1e-300)
                         else None)
            k_old, g_old = k, g
            if slope is not None and np.isfinite(slope) and slope != 0:
                # secant step, at most a step of half of k plus the fixed-point step
                dk = -g / slope
                lim = 0.5 * k + abs(g)
                k = max(k + max(-lim, min(lim, dk)), 0.0)
            else:
                k = max(k + g, 0.0)  # fixed-point substitution, k = |Im p| b / U
        return p, False, lam, idx


class TheodorsenKernel(Kernel):
    """Kernel of :class:`~model.assembly.FrozenParts` (exact Theodorsen ``C(k)``)."""

    def __init__(self, frozen):
        self.frozen = frozen
        self.half_chord = float(frozen.half_chord)
        n = frozen.A0.shape[0]
        self._buf = np.empty((n, n), complex)

    def set_speed(self, U: float) -> None:
        f = self.frozen
        U = float(U)
        self.speed = U
        self._B0 = f.A0 + U * f.A1 + (U * U) * f.A2
        self._Bc = U * f.A1c + (U * U) * f.A2c

    def matrix(self, kr: float) -> np.ndarray:
        """``A(U, C(kr))`` at the speed set (complex)."""
        return self._fill(kr).copy()

    def _fill(self, kr: float) -> np.ndarray:
        c = theodorsen_scalar(kr) if kr > 0 else 1.0 + 0j
        buf = self._buf
        np.multiply(self._Bc, c, out=buf)
        buf += self._B0
        return buf

    def eigvals(self, kr: float) -> np.ndarray:
        # the transpose view is Fortran-ordered: LAPACK works on it in place (same eigenvalues)
        return _eigvals_complex(self._fill(kr).T)


class DerivativeKernel(Kernel):
    """Kernel of :class:`~model.derivative_system.DerivativeFrozen` (flutter derivatives).

    The lower block row of ``A`` (flattened) is ``-[M^-1 K, M^-1 C] + r @ H`` with ``r`` the
    real and imaginary parts of ``Qn``, scaled by ``rho U^2 / 2`` and ``rho U B / (2 K)``, and
    ``H`` their projections ``M^-1 L Qn R`` placed in the stiffness and damping halves.
    """

    def __init__(self, frozen):
        self.frozen = frozen
        self.half_chord = float(frozen.half_chord)
        M = np.asarray(frozen.M, float)
        n, d = M.shape[0], frozen.n_dof
        Minv = np.linalg.inv(M)
        # M^-1 Q = sum_(r,c) Qn[r, c] G[r, c] with G[r, c] = M^-1 sum_i left_i[:, r] right_i[c, :]
        P = np.einsum("inr,icm->rcnm", frozen.left, frozen.right)
        G = np.einsum("ab,rcbm->rcam", Minv, P).reshape(d * d, n, n)
        H = np.zeros((2, d * d, n, 2 * n))
        H[0, :, :, :n] = G  # Re Qn -> stiffness half
        H[1, :, :, n:] = G  # Im Qn -> damping half
        self._H = H.reshape(2 * d * d, 2 * n * n)
        self._base = -np.hstack([Minv @ frozen.K, Minv @ frozen.C]).ravel()
        self._n, self._dd = n, d * d
        self._qd = 0.5 * float(frozen.air_density)
        self._B = float(frozen.chord_m)
        self._buf = np.zeros((2 * n, 2 * n))
        self._buf[:n, n:] = np.eye(n)
        self._low = self._buf[n:].reshape(-1)  # a view: the lower block row, flattened
        self._qn = _qn_function(frozen.source, d)

    def set_speed(self, U: float) -> None:
        self.speed = float(U)

    def matrix(self, kr: float) -> np.ndarray:
        """``A(U, k)`` at the speed set (real), as ``DerivativeFrozen.matrix_at_k``."""
        return self._fill(kr).copy()

    def _fill(self, kr: float) -> np.ndarray:
        U, dd = self.speed, self._dd
        Kr = max(2.0 * float(kr), 1e-9)
        r = self._qn(Kr)
        r[:dd] *= self._qd * U * U
        r[dd:] *= self._qd * U * self._B / Kr
        np.dot(r, self._H, out=self._low)
        self._low += self._base
        return self._buf

    def eigvals(self, kr: float) -> np.ndarray:
        # dgeev overwrites its input: the transpose (Fortran order, same eigenvalues) is copied
        # so that the constant blocks of the buffer survive
        return _eigvals_real(self._fill(kr).T.copy(order="F"))


def _qn_function(source, d: int):
    """``K -> (Re Qn(K), Im Qn(K))`` flattened into one new real array of ``2 d^2`` values, for
    one reduced frequency ``K > 0`` (:meth:`~model.derivatives.FlutterDerivatives.matrix`)."""
    from model.derivatives import FlatPlateDerivatives, TabulatedDerivatives

    dd = d * d
    if isinstance(source, FlatPlateDerivatives) and source.c_function is None:
        kap = 1.0 if source.added_inertia else 0.0
        pi = np.pi
        pad = [0.0] * (dd - 4)

        def flat(K):
            C = theodorsen_scalar(0.5 * K)
            F, G = C.real, C.imag
            K2 = K * K
            # FlatPlateDerivatives.values in closed form, times K^2: (H4, H3, A4, A3) + i (H1,
            # H2, A1, A2); the lateral entries of a 3-DOF section are zero
            re = [pi / 2 * (1 + 4 * G / K), 2 * pi / K * (F / K - G / 4), pi * G / (2 * K),
                  pi / (2 * K) * (F / K - G / 4) + kap * pi / 64]
            im = [-2 * pi * F / K, pi / (2 * K) * (1 + F + 4 * G / K), -pi * F / (2 * K),
                  -pi / (8 * K) * (1 - F - 4 * G / K)]
            if d == 3:
                re = [re[0], re[1], 0.0, re[2], re[3], 0.0, 0.0, 0.0, 0.0]
                im = [im[0], im[1], 0.0, im[2], im[3], 0.0, 0.0, 0.0, 0.0]
                return K2 * np.array(re + im)
            return K2 * np.array(re + pad + im + pad)

        return flat
    if isinstance(source, TabulatedDerivatives) and source.extrapolation == "hold":
        from model.derivatives import _ENTRIES

        kt = np.asarray(source.K, float)
        vt = 1.0 / kt
        order = np.argsort(vt)
        xs = vt[order]
        cols = []
        for part in (0, 1):
            for r in range(d):
                for c in range(d):
                    name = _ENTRIES[(r, c)][part]
                    cols.append(np.asarray(source.data[name], float)[order]
                                if name in source.data else np.zeros_like(xs))
        tab = np.column_stack(cols)  # (m, 2 d^2): Re then Im parts of Qn / K^2
        slope = np.diff(tab, axis=0) / np.diff(xs)[:, None]

        def table(K):
            v = 1.0 / K
            if v <= xs[0]:
                row = tab[0]
            elif v >= xs[-1]:
                row = tab[-1]
            else:
                i = int(np.searchsorted(xs, v, side="right")) - 1
                row = slope[i] * (v - xs[i]) + tab[i]
            return (K * K) * row

        return table

    def generic(K):
        q = source.matrix(np.array(K), d).ravel()
        return np.concatenate([q.real, q.imag])

    return generic


def kernel_for(frozen) -> Kernel:
    """The lean kernel of a frozen p-k system (``system.frozen()``)."""
    if hasattr(frozen, "matrix_at_k"):
        return DerivativeKernel(frozen)
    return TheodorsenKernel(frozen)
