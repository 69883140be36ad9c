"""Differentiable spectral-abscissa constraints for CasADi (docs/methods.md#eigenvalue-constraints).

CasADi has no differentiable nonsymmetric eigendecomposition, so the eigenvalues of a
parameterised real matrix ``A(U, p) = sum_j U^j A_j(p)`` are computed in numpy/scipy inside a
:class:`casadi.Callback` whose Jacobian is supplied analytically from left/right eigenvectors
(:func:`bridgeflap.model.spectrum.eigenvalue_derivatives`, the package's one eigenvalue
derivative)::

    d lambda_i / d p_k = w_i^H (dA/dp_k) v_i / (w_i^H v_i)

with ``A v_i = lambda_i v_i`` and ``w_i^H A = lambda_i w_i^H``; ``dA_j/dp`` comes from the
symbolic parts (``casadi.jacobian``). :class:`PolynomialTopRealParts` returns the ``m`` largest
real parts of ``eig(A(U, p))`` at each speed of a grid, sorted descending. Constraining all of
them (``<= -margin``) bounds the spectral abscissa while the individual branches stay smooth away
from crossings (docs/methods.md#eigenvalue-constraints, m ~ 3-6 per speed). The constraint is
nonsmooth where eigenvalues coalesce; always verify the final design a posteriori with
:func:`bridgeflap.model.spectrum.spectral_abscissa` on a finer speed grid
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

from bridgeflap.model.spectrum import DEFECT_TOL, eigenvalue_derivatives

__all__ = ["PolynomialStructuralDamping", "PolynomialTopRealParts", "damping_measure",
           "fixed_pole_copies", "inverse_iteration", "structural_selection"]

def parts_jacobian(parts_fun: ca.Function) -> ca.Function:
    """``p -> (d vec(A_0)/dp, ..., d vec(A_d)/dp)`` of ``parts_fun`` (symbolic, sparse). Built
    once per parts function and shared by every grid's callback (``dparts``): ~1 s for the
    104-state closed loop of the default card."""
    sym = ca.SX if parts_fun.is_a("SXFunction") else ca.MX
    p = sym.sym("p", parts_fun.size1_in(0))
    outs = parts_fun(p)
    outs = outs if isinstance(outs, (list, tuple)) else [outs]
    return ca.Function("dparts", [p], [ca.jacobian(ca.vec(a), p) for a in outs])


def _pattern(sp: ca.Sparsity):
    """``(rows, cols, shape, dense)`` of a CasADi sparsity, in the order of its nonzeros."""
    r, c = sp.get_triplet()
    return np.asarray(r, int), np.asarray(c, int), (sp.size1(), sp.size2()), sp.is_dense()


def _dense(dm: ca.DM, pattern) -> np.ndarray:
    """``dm`` as a dense array from its nonzeros and ``pattern`` (:func:`_pattern`):
    ``DM.full()`` goes through a Python list of every entry (22 ms for the three 10816 x 18
    derivative parts of the placement design, 1.8 ms from their ~65k nonzeros)."""
    rows, cols, shape, dense = pattern
    nz = np.array(dm.nonzeros(), float)
    if dense:
        return nz.reshape(shape, order="F")
    out = np.zeros(shape)
    out[rows, cols] = nz
    return out


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
    parts of :func:`bridgeflap.model.aeroelastic.symbolic.closed_loop_functions`); with one part
    ``A_0(p)`` and one speed it is the top-``m`` real parts of a single matrix.

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
        (:func:`bridgeflap.model.spectrum.eigenvalue_derivatives`); such rows are taken by
        differences.
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
                 name: str = "top_real_parts_grid", opts: dict | None = None, dparts=None):
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
        self.fd_speed_evaluations = 0
        self.evaluations = 0
        self.eval_time_s = 0.0
        self._dparts = dparts if dparts is not None else parts_jacobian(parts_fun)
        self._pat_parts = [_pattern(parts_fun.sparsity_out(i)) for i in range(parts_fun.n_out())]
        self._pat_dparts = [_pattern(self._dparts.sparsity_out(i))
                            for i in range(self._dparts.n_out())]
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
    def matrices(self, p, which=None) -> list[np.ndarray]:
        """``A(U, p)`` at every speed (or the speed indices ``which``; subset applied) as
        dense arrays."""
        parts = self._parts(ca.DM(np.asarray(p, float)))
        parts = parts if isinstance(parts, (list, tuple)) else [parts]
        parts = [_dense(a, pat) for a, pat in zip(parts, self._pat_parts, strict=True)]
        out = []
        sel = range(self.speeds.size) if which is None else which
        for u, ix in ((self.speeds[k], self._idx[k]) for k in sel):
            A = sum(u**j * a for j, a in enumerate(parts))
            out.append(A if ix is None else A[np.ix_(ix, ix)])
        return out

    def _decompose(self, p, vectors=False):
        """Per speed ``[lambda, left, right, A]`` of the selected eigenvalues (None where ``A``
        is not finite), cached for the last ``p``. The eigenvectors may be computed lazily
        (``left`` None until asked for with ``vectors``: only the Jacobian needs them, and
        Ipopt evaluates the constraints at more points -- line-search trials -- than their
        Jacobian)."""
        key = p.tobytes()
        if key != self._key:
            t0 = time.perf_counter()
            ctx = self._selection_context(p)
            self._store = [None if not np.all(np.isfinite(A))
                           else list(self._eigenpairs(u, A, ctx)) + [A]
                           for u, A in zip(self.speeds, self.matrices(p), strict=True)]
            self._key = key
            self.evaluations += 1
            self.eval_time_s += time.perf_counter() - t0
        if vectors and any(r is not None and r[1] is None for r in self._store):
            t0 = time.perf_counter()
            for r in self._store:
                if r is not None and r[1] is None:
                    r[1], r[2] = inverse_iteration(r[3], r[0])
            self.eval_time_s += time.perf_counter() - t0
        return self._store

    def _selection_context(self, p):
        return None

    def _eigenpairs(self, u, A, ctx):
        """The ``m`` rightmost eigenvalues with their left and right eigenvectors."""
        lam, vl, vr = scipy.linalg.eig(A, left=True, right=True)
        idx = np.argsort(-lam.real, kind="stable")[: self.m]
        return lam[idx], vl[:, idx], vr[:, idx]

    def values(self, p) -> np.ndarray:
        """The stacked top-``m`` real parts [(m * n_speeds,)]; NaN where ``A`` is not finite."""
        p = np.asarray(p, float).ravel()
        out = [np.full(self.m, np.nan) if r is None else r[0].real
               for r in self._decompose(p)]
        return np.concatenate(out)

    def jacobian(self, p) -> np.ndarray:
        """Analytic Jacobian [(m * n_speeds, n_p)], central differences for defective rows."""
        p = np.asarray(p, float).ravel()
        rows = self._decompose(p, vectors=True)
        outs = self._dparts(ca.DM(p))
        outs = outs if isinstance(outs, (list, tuple)) else [outs]
        # dense (n^2, n_p): n_p is small, so the per-speed sum and the row contraction are
        # cheap dense products (scipy.sparse sums and conversions cost more per speed)
        dparts = [_dense(ca.DM(d), pat) for d, pat in zip(outs, self._pat_dparts, strict=True)]
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
            Js, bad = self._row_block(r, dA)
            J[s * self.m:(s + 1) * self.m] = Js
            bad_rows.extend(s * self.m + int(i) for i in np.flatnonzero(bad))
        if bad_rows:
            self._fd_rows(J, p, bad_rows)
        return J

    def _row_block(self, r, dA):
        """One speed's Jacobian rows from its decomposition ``r`` and ``d vec(A)/dp``, and the
        flags of nearly defective rows: here d(Re lambda)/dp."""
        return eigenvalue_derivatives(r[1], r[2], dA, self.defect_tol, real_only=True)

    def _plain_values(self, p, which=None):
        return np.concatenate([np.sort(scipy.linalg.eigvals(A).real)[::-1][: self.m]
                               for A in self.matrices(p, which)])

    def _fd_rows(self, J, p, bad_rows):
        """Central differences for the rows ``bad_rows`` of ``J`` (nearly defective
        eigenvalues), eigenvalues recomputed only at the speeds those rows belong to."""
        which = sorted({r // self.m for r in bad_rows})
        local = {k: i for i, k in enumerate(which)}
        loc = [local[r // self.m] * self.m + r % self.m for r in bad_rows]
        for k in range(self._n_p):
            h = self.fd_step * max(1.0, abs(p[k]))
            e = np.zeros_like(p)
            e[k] = h
            fp, fm = self._plain_values(p + e, which), self._plain_values(p - e, which)
            J[bad_rows, k] = (fp[loc] - fm[loc]) / (2.0 * h)
        self.fd_fallback_count += len(bad_rows)
        self.fd_speed_evaluations += len(which)


class _GridJacobianCallback(_JacobianCallback):
    def get_sparsity_in(self, i):
        if i == 0:
            return ca.Sparsity.dense(self._parent._n_p, 1)
        return ca.Sparsity.dense(self._parent.m * self._parent.speeds.size, 1)

    def get_sparsity_out(self, i):
        return ca.Sparsity.dense(self._parent.m * self._parent.speeds.size, self._parent._n_p)


#: Relative shift of inverse iteration from an eigenvalue given by ``eigvals`` (keeps
#: ``A - sigma I`` numerically non-singular; one step then converges to ~1e-10 relative for an
#: eigenvalue separated from the others by more than ~1e-4 |lambda|, two steps to round-off).
INVERSE_SHIFT = 1e-10
#: Inverse-iteration steps per eigenvector.
INVERSE_STEPS = 2


def inverse_iteration(A, lam) -> tuple[np.ndarray, np.ndarray]:
    """Left and right eigenvectors ``(vl, vr)`` (n, len(lam)) of ``A`` for the eigenvalues
    ``lam`` (from ``eigvals``) by shifted inverse iteration, one complex LU per eigenvalue
    (``vl[:, i]^H A = lam_i vl[:, i]^H``, as ``scipy.linalg.eig(left=True)``).

    ``eigvals`` plus this for the few eigenpairs the constraints need costs ~0.6 of one
    ``eig`` with both eigenvector sets on the 146-state design model.
    """
    A = np.asarray(A)
    n = A.shape[0]
    lam = np.atleast_1d(np.asarray(lam, complex))
    vl = np.empty((n, lam.size), complex)
    vr = np.empty((n, lam.size), complex)
    rng = np.random.default_rng(0)
    b0 = rng.standard_normal(n) + 1j * rng.standard_normal(n)
    done = {}
    eye = np.eye(n)
    for i, lm in enumerate(lam):
        key = complex(lm)
        if key in done:             # padded repeats of the last selected eigenvalue
            vl[:, i], vr[:, i] = done[key]
            continue
        sig = lm + INVERSE_SHIFT * max(1.0, abs(lm))
        lu = scipy.linalg.lu_factor(A - sig * eye, check_finite=False)
        r, l_ = b0.copy(), b0.copy()
        for _ in range(INVERSE_STEPS):
            r = scipy.linalg.lu_solve(lu, r, check_finite=False)
            r /= np.linalg.norm(r)
            l_ = scipy.linalg.lu_solve(lu, l_, trans=2, check_finite=False)
            l_ /= np.linalg.norm(l_)
        vl[:, i], vr[:, i] = l_, r
        done[key] = (l_, r)
    return vl, vr


#: Relative distance ``|lambda - lambda_copy| / max(|lambda_copy|, COPY_FLOOR)`` below which an
#: eigenvalue is a copy of a fixed pole (an uncoupled aerodynamic lag state ``-p_i U / b`` or a
#: compensator pole of a flap whose loop is uncontrollable). The copies are eigenvalues of
#: decoupled diagonal blocks, exact to round-off (~1e-14 relative); a coupled eigenvalue that
#: the flaps move sits ~ the coupling away. 1e-7 separates the two by orders of magnitude.
COPY_TOL = 1e-7
#: Absolute floor of the copy test [1/s] (the lag copies approach 0 as U -> 0).
COPY_FLOOR = 1e-6


def fixed_pole_copies(lam, lag_rates_1_m, U, theta) -> np.ndarray:
    """Mask of the eigenvalues ``lam`` that are copies of poles no flap can move.

    Parameters
    ----------
    lam : ndarray (complex)
        Closed-loop eigenvalues at speed ``U`` [1/s].
    lag_rates_1_m : array_like
        RFA lag-pole rates ``p_i / b`` [1/m]: the lag copies are ``-p_i U / b``.
    U : float
        Wind speed [m/s].
    theta : array_like
        Compensator coefficients (b2, b1, b0, a2, a1): its poles (roots of ``a2 s^2 + a1 s +
        1``) are the compensator copies.
    """
    lam = np.asarray(lam, complex)
    targets = [-float(r) * U for r in np.atleast_1d(lag_rates_1_m)] if U > 0 else []
    a2, a1 = float(theta[3]), float(theta[4])
    if a2 > 0:
        targets += _quadratic_roots(a2, a1)
    elif a1 > 0:
        targets.append(-1.0 / a1)
    mask = np.zeros(lam.shape, bool)
    for t in targets:
        mask |= np.abs(lam - t) <= COPY_TOL * max(abs(t), COPY_FLOOR)
    return mask


def _quadratic_roots(a2, a1) -> list:
    """Roots of ``a2 s^2 + a1 s + 1`` (``a2 > 0``) in closed form, without cancellation (the
    smaller root from the product ``1 / a2``); ``np.roots`` costs an eigenvalue problem per
    call, and the copy test is called per speed and evaluation."""
    disc = a1 * a1 - 4.0 * a2
    if disc >= 0:
        big = -0.5 * (a1 + np.sqrt(disc)) / a2
        return [big, 1.0 / (a2 * big)]      # big != 0: a2 > 0
    re, im = -0.5 * a1 / a2, 0.5 * np.sqrt(-disc) / a2
    return [complex(re, im), complex(re, -im)]


def damping_measure(lam, zeta_min) -> np.ndarray:
    """``Re lambda + zeta_min |lambda|`` [1/s]: ``<= 0`` iff the damping ratio ``-Re lambda /
    |lambda| >= zeta_min`` (continuous through ``lambda = 0``, where divergence crosses)."""
    lam = np.asarray(lam, complex)
    return lam.real + float(zeta_min) * np.abs(lam)


def structural_selection(lam, lag_rates_1_m, U, theta, zeta_min, m) -> np.ndarray:
    """Indices of the ``m`` movable eigenvalues (not fixed-pole copies, ``Im >= 0``) with the
    largest :func:`damping_measure`, largest first (padded by repeating the last)."""
    lam = np.asarray(lam, complex)
    ok = ~fixed_pole_copies(lam, lag_rates_1_m, U, theta) & (lam.imag >= 0)
    idx = np.flatnonzero(ok)
    g = damping_measure(lam[idx], zeta_min)
    idx = idx[np.argsort(-g, kind="stable")][:m]
    if idx.size == 0:
        raise ValueError(f"no movable eigenvalue at U = {U} m/s")
    return np.concatenate([idx, np.repeat(idx[-1:], m - idx.size)])


class PolynomialStructuralDamping(PolynomialTopRealParts):
    """Damping constraints ``Re lambda + zeta_min |lambda|`` of the movable branches.

    The closed-loop spectrum of the flap design holds many eigenvalues no flap can move: the
    copies of the RFA lag poles ``-p_i U / b`` (the lag states of modes the flaps and the
    other modes do not couple to) and the copies of the compensator poles (per-flap
    compensators beyond the rank of the plant). They are stable and fixed; the spectral
    abscissa of the closed loop is often one of them, so a constraint on it does
    no work. This callback removes them (:func:`fixed_pole_copies`) and returns, per speed,
    the ``m`` largest damping measures :func:`damping_measure` of the remaining eigenvalues
    in the upper half-plane (the structural branches, plus the coupled lag and compensator
    eigenvalues, which are real and stable and therefore satisfy it).

    Jacobian: ``d lambda`` from :func:`bridgeflap.model.spectrum.eigenvalue_derivatives` (complex),
    then ``d g = Re d lambda + zeta_min Re(conj(lambda) d lambda) / |lambda|``. Nearly defective
    rows fall back to central differences as in the parent class.

    Parameters
    ----------
    parts_fun, speeds, m, subsets : see :class:`PolynomialTopRealParts`
    lag_rates_1_m : array_like
        ``p_i / b`` [1/m] of the RFA lag poles.
    zeta_min : float
        Required damping ratio [-].
    theta_of_p : callable, optional
        ``p -> theta`` (default: the first five entries of ``p``).
    """

    def __init__(self, parts_fun, speeds, m, lag_rates_1_m, zeta_min, subsets=None,
                 theta_of_p=None, name="structural_damping_grid", **kw):
        self.lag_rates = np.asarray(lag_rates_1_m, float).ravel()
        self.zeta_min = float(zeta_min)
        self._theta_of_p = theta_of_p or (lambda p: np.asarray(p, float)[:5])
        super().__init__(parts_fun, speeds, m, subsets=subsets, name=name, **kw)

    def _selection_context(self, p):
        return self._theta_of_p(p)

    def _eigenpairs(self, u, A, th):
        """The structural eigenvalues the flaps can move (``eigvals``; their vectors by
        inverse iteration later, when the Jacobian asks: :meth:`_decompose`)."""
        lam = scipy.linalg.eigvals(A, check_finite=False)
        idx = structural_selection(lam, self.lag_rates, u, th, self.zeta_min, self.m)
        return lam[idx], None, None

    def values(self, p) -> np.ndarray:
        """Stacked damping measures [1/s] (m per speed, largest first); NaN if not finite."""
        p = np.asarray(p, float).ravel()
        return np.concatenate([np.full(self.m, np.nan) if r is None
                               else damping_measure(r[0], self.zeta_min)
                               for r in self._decompose(p)])

    def eigenvalues(self, p) -> list:
        """The selected eigenvalues per speed [1/s] (None where ``A`` is not finite)."""
        return [None if r is None else r[0]
                for r in self._decompose(np.asarray(p, float).ravel())]

    def _row_block(self, r, dA):
        """d(Re lambda + zeta_min |lambda|)/dp of the selected eigenvalues."""
        dlam, bad = eigenvalue_derivatives(r[1], r[2], dA, self.defect_tol)
        lam = r[0][:, None]
        mag = np.abs(lam)
        dmag = np.where(mag > 0, (lam.conj() * dlam).real / np.where(mag > 0, mag, 1.0),
                        np.abs(dlam))
        return dlam.real + self.zeta_min * dmag, bad

    def _plain_values(self, p, which=None):
        th = self._theta_of_p(p)
        out = []
        sp = self.speeds if which is None else self.speeds[list(which)]
        for u, A in zip(sp, self.matrices(p, which), strict=True):
            lam = scipy.linalg.eigvals(A)
            idx = structural_selection(lam, self.lag_rates, u, th, self.zeta_min, self.m)
            out.append(damping_measure(lam[idx], self.zeta_min))
        return np.concatenate(out)
