"""Lean inner loop of the p-k method: frozen matrices at one speed and a secant k iteration.

The p-k point (:mod:`bridgeflap.model.stability.pk`) solves ``p = eig(A(U, k))`` with ``k = |Im p| b
/ U``. Its reference form rebuilds ``A`` from the frozen system at every iteration
(``FrozenParts.matrix`` with :func:`bridgeflap.model.aero.theodorsen.theodorsen`, or
``DerivativeFrozen.matrix_at_k`` with the derivatives' generic ``matrix``) and iterates ``k`` by
fixed-point substitution. Here the same matrices are formed from constants computed once:

* Theodorsen (:class:`~bridgeflap.model.aeroelastic.assembly.FrozenParts`):
  ``A(U, c) = [A0 + U A1 + U^2 A2] + c [U A1c + U^2 A2c]``, both brackets per speed, ``c`` from
  :func:`bridgeflap.model.aero.theodorsen.theodorsen_scalar`;
* flutter derivatives (:class:`~bridgeflap.model.aeroelastic.derivative_system.DerivativeFrozen`):
  the projection ``M^-1 L Qn R`` of each entry of ``Qn`` once (``Qn`` of the flat plate in closed
  form, tables by one linear interpolation of all columns, other sources through their ``matrix``),
  and the blocks written into a preallocated matrix (no ``np.block``);

and the eigenvalues come from LAPACK ``geev`` without vectors. :meth:`Kernel.point` iterates
``k`` on the consistency ``g(k) = |Im p(k)| b / U - k = 0`` by secant steps (the first one with
the branch's slope ``dg/dk`` from the previous point when the caller keeps it), with fixed-point
steps as the fallback; it stops when the frequency implied by ``k`` equals ``|Im p|`` to
``tol max(1, |p|)`` [rad/s]. Method: docs/methods.md#p-k-check.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import lapack

from bridgeflap.model.aero.theodorsen import theodorsen_scalar

__all__ = ["BranchMemory", "Kernel", "kernel_for"]

#: secant steps without halving ``|g|`` after which a k iteration stops as not converged: near a
#: root the secant gains far more than a factor 2 per step (2 to 5 steps per point on the IABSE
#: cases), so this many without progress means that the branch has no consistent k there (a
#: p-k branch ending where a heavily damped pair turns real); the fixed-point reference
#: iterates to its 100 steps in that case
STAGNATION = 3
#: relative distance between the extrapolated and the predicted starting k above which a k
#: iteration that failed from the first is restarted from the second (nearer starts fail alike)
RESTART = 1e-3
#: nodes of the extrapolated starting k (a cubic: about 1e-9 relative on a 0.4 m/s grid)
NODES = 4


def _eigvals_real(a):
    # overwrite_a=0: LAPACK works on a copy, the caller's buffer keeps its constant blocks
    wr, wi, _, _, info = lapack.dgeev(a, compute_vl=0, compute_vr=0, overwrite_a=0)
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
        they are distinct and near (``U`` within their spread of the last) and it agrees with
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

        ``hint``: the branch's :class:`BranchMemory` (or None): its extrapolated ``k`` and
        slope start the iteration, and when that does not converge from a start more than
        :data:`RESTART` away it is started again from ``k = |Im p_guess| b / U`` without them
        (the start of the reference iteration); failing that, ``k = 0`` is tried for a real root
        (:meth:`_real_root`).
        Returns ``(p, converged, eigenvalues of the last matrix, index of p among them)``, as
        :func:`bridgeflap.model.stability.pk._pk_point`.
        """
        U = float(U)  # Python floats throughout: numpy scalars cost ~20x per operation here
        if U != self.speed:
            self.set_speed(U)
        w = U / self.half_chord  # k -> frequency [rad/s]
        p0 = complex(p_guess)
        k0 = abs(p0.imag) / w
        if hint is None:
            return self._iterate(w, p0, k0, None, tol, maxit)[:4]
        k1, slope = hint.guess(U, k0), hint.slope
        if slope is not None and not slope < 0:
            slope = None  # only a contracting map's slope (dg/dk = T' - 1 < 0) is carried over
        out = self._iterate(w, p0, k1, slope, tol, maxit)
        if not out[1] and abs(k1 - k0) > RESTART * k0 and out[6] < maxit:
            out = self._iterate(w, p0, k0, None, tol, maxit - out[6])
        if not out[1]:
            out = self._real_root(out)
        if out[1]:
            hint.record(U, out[4], out[5])
        return out[:4]

    def _real_root(self, out):
        """A failed k iteration ``out`` tried at ``k = 0``: where a damped pair has turned real
        (the p-k branch ends), the eigenvalue nearest the last iterate is real there and
        consistent (``k = |Im p| b / U = 0``), the root the fixed-point iteration falls onto
        after its tens of steps."""
        lam = self.eigvals(0.0)
        idx = int(np.abs(lam - out[0]).argmin())
        p = complex(lam[idx])
        if p.imag != 0.0:
            return out
        return p, True, lam, idx, 0.0, out[5], out[6] + 1

    def _iterate(self, w, p, k, slope, tol, maxit):
        """The k iteration from ``(p, k)``: ``(p, converged, lam, index, k, slope, steps)``."""
        k_old = g_old = None
        lam, idx = np.array([p]), 0
        best, since = np.inf, 0
        for it in range(maxit):
            lam = self.eigvals(k)
            idx = int(np.abs(lam - p).argmin())
            p = complex(lam[idx])
            g = abs(p.imag) / w - k
            if abs(g) * w <= tol * max(1.0, abs(p)):
                return p, True, lam, idx, k, slope, it + 1
            if abs(g) < 0.5 * best:
                best, since = abs(g), 0
            else:
                since += 1
                if since >= STAGNATION:
                    return p, False, lam, idx, k, slope, it + 1  # no root near
            if k_old is not None:
                dk = k - k_old
                # no slope from a step too small to resolve it
                slope = ((g - g_old) / dk if g != g_old and abs(dk) > 1e-13 * max(k, 1e-300)
                         else None)
            k_old, g_old = k, g
            if slope is not None and math.isfinite(slope) and slope != 0:
                # secant step, at most a step of half of k plus the fixed-point step
                dk = -g / slope
                lim = 0.5 * k + abs(g)
                k = max(k + max(-lim, min(lim, dk)), 0.0)
            else:
                k = max(k + g, 0.0)  # fixed-point substitution, k = |Im p| b / U
        return p, False, lam, idx, k, slope, maxit


class TheodorsenKernel(Kernel):
    """Kernel of :class:`~bridgeflap.model.aeroelastic.assembly.FrozenParts` (exact Theodorsen
    ``C(k)``)."""

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
    """Kernel of :class:`~bridgeflap.model.aeroelastic.derivative_system.DerivativeFrozen` (flutter
    derivatives).

    The lower block row of ``A`` (flattened) is ``-[M^-1 K, M^-1 C] + r @ H`` with ``r`` the
    real and imaginary parts of ``Qn``, scaled by ``rho U^2 / 2`` and ``rho U B / (2 K)``, and
    ``H`` their projections ``M^-1 L Qn R`` placed in the stiffness and damping halves (one
    product: ``r`` ends with a 1 and ``H`` with the constant row).
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
        base = -np.hstack([Minv @ frozen.K, Minv @ frozen.C]).ravel()
        self._H = np.vstack([H.reshape(2 * d * d, 2 * n * n), base])
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
        U = self.speed
        Kr = max(2.0 * float(kr), 1e-9)
        r = self._qn(Kr, self._qd * U * U, self._qd * U * self._B / Kr)
        np.dot(r, self._H, out=self._low)  # the last entry of r is 1: the constant row
        return self._buf

    def eigvals(self, kr: float) -> np.ndarray:
        # the transpose (Fortran order, the same eigenvalues) goes to LAPACK without a reorder
        return _eigvals_real(self._fill(kr).T)


def _qn_function(source, d: int):
    """``(K, a, b) -> (a Re Qn(K), b Im Qn(K), 1)`` flattened into one new real array of
    ``2 d^2 + 1`` values, for one reduced frequency ``K > 0``
    (:meth:`~bridgeflap.model.aero.derivatives.FlutterDerivatives.matrix`)."""
    from bridgeflap.model.aero.derivatives import (
        FlatPlateDerivatives,
        PolimiDerivatives,
        TabulatedDerivatives,
    )

    dd = d * d
    if isinstance(source, FlatPlateDerivatives) and source.c_function is None:
        kap = 1.0 if source.added_inertia else 0.0
        pi = np.pi
        pad = [0.0] * (dd - 4) if d == 2 else []

        def flat(K, a, b):
            C = theodorsen_scalar(0.5 * K)
            F, G = C.real, C.imag
            a, b = a * K * K, b * K * K
            # FlatPlateDerivatives.values in closed form, times K^2: (H4, H3, A4, A3) + i (H1,
            # H2, A1, A2); the lateral entries of a 3-DOF section are zero
            re = [pi / 2 * (1 + 4 * G / K), 2 * pi / K * (F / K - G / 4), pi * G / (2 * K),
                  pi / (2 * K) * (F / K - G / 4) + kap * pi / 64]
            im = [-2 * pi * F / K, pi / (2 * K) * (1 + F + 4 * G / K), -pi * F / (2 * K),
                  -pi / (8 * K) * (1 - F - 4 * G / K)]
            re, im = [a * x for x in re], [b * x for x in im]
            if d == 3:
                return np.array([re[0], re[1], 0.0, re[2], re[3], 0.0, 0.0, 0.0, 0.0,
                                 im[0], im[1], 0.0, im[2], im[3], 0.0, 0.0, 0.0, 0.0, 1.0])
            return np.array(re + pad + im + pad + [1.0])

        return flat
    if isinstance(source, TabulatedDerivatives) and source.extrapolation == "hold":
        from bridgeflap.model.aero.derivatives import _ENTRIES

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

        return _scaled(table, dd)

    if isinstance(source, PolimiDerivatives):
        return _scaled(_polimi_function(source, d), dd)

    def generic(K):
        q = source.matrix(np.array(K), d).ravel()
        return np.concatenate([q.real, q.imag])

    return _scaled(generic, dd)


def _scaled(fn, dd: int):
    """``(K, a, b) -> (a Re Qn, b Im Qn, 1)`` from ``fn: K -> (Re Qn, Im Qn)``."""

    def scaled(K, a, b):
        r = fn(K)
        out = np.empty(2 * dd + 1)
        np.multiply(r[:dd], a, out=out[:dd])
        np.multiply(r[dd:], b, out=out[dd:2 * dd])
        out[-1] = 1.0
        return out

    scaled.__name__ = fn.__name__
    return scaled


class _Hold:
    """Linear interpolation of table columns on one abscissa, end values held (``np.interp``)."""

    def __init__(self, x, cols):
        order = np.argsort(x)
        self.x = np.asarray(x, float)[order]
        self.tab = np.column_stack(cols)[order]
        self.slope = np.diff(self.tab, axis=0) / np.diff(self.x)[:, None]

    def __call__(self, v):
        xs = self.x
        if v <= xs[0]:
            return self.tab[0]
        if v >= xs[-1]:
            return self.tab[-1]
        i = int(np.searchsorted(xs, v, side="right")) - 1
        return self.slope[i] * (v - xs[i]) + self.tab[i]


def _polimi_function(source, d: int):
    """:func:`_qn_function` of :class:`~bridgeflap.model.aero.derivatives.PolimiDerivatives`: its 18
    columns interpolated as its ``values`` does, then converted by a matrix ``T0 + v T1 + v^2 T2``.

    :func:`~bridgeflap.model.aero.derivatives.polimi_to_scanlan` is linear in the coefficients with
    factors of degree at most 2 in ``v`` (its docstring), so ``T0, T1, T2`` are read off it at three
    reduced velocities with unit coefficient tables, and checked at a fourth (the direct call
    per point, 100 us, is the fallback if that check fails).
    """
    from bridgeflap.model.aero.derivatives import _ENTRIES, polimi_to_scanlan

    vt = np.asarray(source.v, float)
    ax = [np.asarray(c, float) for c in source.column_v] or [vt] * 6
    tabs = {f: np.asarray(source.polimi[f], float) for f in "hap"}
    inputs = [(f, i) for f in "hap" for i in range(6)]
    groups = {}  # the columns by abscissa
    for n_in, (f, i) in enumerate(inputs):
        x = vt if f == "p" else ax[i]
        groups.setdefault(x.tobytes(), (x, []))[1].append(n_in)
    interp = [(_Hold(x, [tabs[inputs[j][0]][:, inputs[j][1]] for j in cols]), np.array(cols))
              for x, cols in groups.values()]
    names = [_ENTRIES[(r, c)][part] for part in (0, 1) for r in range(d) for c in range(d)]

    def convert(v, coef):
        """``(len(v), 2 d^2)`` Scanlan entries of ``coef`` (``len(v), 18``) at ``v``."""
        out = polimi_to_scanlan(v, coef[:, :6], coef[:, 6:12], coef[:, 12:])
        return np.column_stack([out[name] for name in names])

    probe = np.array([0.5, 1.0, 2.0, 3.7])
    unit = np.eye(18)
    T = np.stack([convert(np.full(18, v), unit).T for v in probe])  # (4, 2 d^2, 18)
    V = np.vander(probe[:3], 3, increasing=True)  # T(v) = T0 + v T1 + v^2 T2 at three v
    T0, T1, T2 = np.einsum("pq,qij->pij", np.linalg.inv(V), T[:3])
    fits = np.allclose(T0 + probe[3] * T1 + probe[3] ** 2 * T2, T[3], rtol=1e-13, atol=1e-13)

    def polimi(K):
        v = 1.0 / K
        c = np.empty(18)
        for fn, cols in interp:
            c[cols] = fn(v)
        if not fits:
            return (K * K) * convert(np.array([v]), c[None, :])[0]
        return (K * K) * (T0 @ c + v * (T1 @ c) + (v * v) * (T2 @ c))

    return polimi


def kernel_for(frozen) -> Kernel:
    """The lean kernel of a frozen p-k system (``system.frozen()``)."""
    if hasattr(frozen, "matrix_at_k"):
        return DerivativeKernel(frozen)
    return TheodorsenKernel(frozen)
