"""Robustness terms of the design: the small-gain norm of the flap loop.

``T = (I - L)^{-1} L``, ``L = K(jw) G(jw)``, is the input complementary sensitivity of the
n_flaps x n_flaps flap loop (positive feedback ``beta = K alpha``); by the small-gain theorem
the loop tolerates a multiplicative input perturbation with ``||Delta||_inf < 1/||T||_inf``.
The NLP bounds the differentiable Frobenius norm (:func:`robust_point_function`,
``sigma_max <= ||T||_F``); the true margin ``1 / max sigma_max(T)`` is checked a posteriori on
a dense grid with polished peaks (:func:`robust_margin`). ``G = Phi_a X`` has rank <= n_modes,
so ``T = K Phi_a (I - K X Phi_a)^{-1} X`` (one n_modes x n_modes complex solve per point).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.linalg

from bridgeflap.design.control.formulation.eigen import _JacobianCallback, _VectorIO
from bridgeflap.design.control.formulation.loop_algebra import LOWRANK_RTOL, _loop_block, k_complex
from bridgeflap.design.control.formulation.plant import plant_factors
from bridgeflap.design.control.results.records import RobustMargin
from bridgeflap.model.aeroelastic.control import Compensator


def robust_point_function(Pa: np.ndarray) -> ca.Function:
    """``(theta, w, omega, Xr, Xi) -> ||T(j omega)||_F^2`` for one speed and frequency.

    ``T = K Phi_a Z``, ``(I - K X diag(w) Phi_a) Z = X diag(w)`` (module docstring), written in
    real arithmetic (a 2 n_modes real solve); differentiable in ``theta`` and ``w``.
    """
    nF, n = Pa.shape
    th = ca.MX.sym("theta", 5)
    w = ca.MX.sym("w", nF)
    om = ca.MX.sym("omega")
    Xr, Xi = ca.MX.sym("Xr", n, nF), ca.MX.sym("Xi", n, nF)
    Kr, Ki = k_complex(th, om)
    Wd = ca.repmat(w.T, n, 1)
    XWr, XWi = Xr * Wd, Xi * Wd
    P = ca.DM(Pa)
    big = _loop_block(Kr, Ki, ca.mtimes(XWr, P), ca.mtimes(XWi, P))
    Z = ca.solve(big, ca.vertcat(XWr, XWi), "lapacklu", {})
    f = (Kr * Kr + Ki * Ki) * (ca.sumsqr(ca.mtimes(P, Z[:n, :]))
                               + ca.sumsqr(ca.mtimes(P, Z[n:, :])))
    return ca.Function("T_fro2", [th, w, om, Xr, Xi], [f], ["theta", "w", "omega", "Xr", "Xi"],
                       ["T_fro2"])


def lowrank_robust_data(Pa, X):
    """``(US, s, E)`` of the low-rank form of ``||T||_F^2`` (:func:`lowrank_point_function`).

    With ``Phi_a = U_r S V_r^T`` (rank ``r``, :data:`LOWRANK_RTOL`) and ``W = diag(w)``, the
    push-through identity gives ``Phi_a (I - K X W Phi_a)^{-1} = U_r S (I_r - K G)^{-1} V_r^T``
    with ``G = E W U_r S`` and ``E = V_r^T X`` (r x n_flaps, independent of theta and w), so
    ``T = K U_r S (I_r - K G)^{-1} E W`` and ``||T||_F^2 = |K|^2 ||S (I_r - K G)^{-1} E W||_F^2``
    (``U_r`` has orthonormal columns): one r x r complex solve per point instead of one
    n_modes x n_modes solve, exact for any ``w`` (the placement design).

    Returns ``US`` (n_flaps, r) = ``U_r S``, ``s`` (r,) and ``E`` (n_points, r, n_flaps)."""
    Pa = np.asarray(Pa, float)
    U, s, Vt = np.linalg.svd(Pa, full_matrices=False)
    r = max(1, int(np.sum(s > LOWRANK_RTOL * s[0]))) if s.size and s[0] > 0 else 1
    E = np.einsum("rn,knf->krf", Vt[:r], np.asarray(X, complex))
    return U[:, :r] * s[:r], s[:r], E


def lowrank_point_function(US, s) -> ca.Function:
    """``(theta, w, omega, Er, Ei) -> ||T(j omega)||_F^2`` for one point in the low-rank form
    of :func:`lowrank_robust_data` (SX, real arithmetic; exact derivatives in theta and w).
    Equals :func:`robust_point_function` to round-off."""
    US = np.asarray(US, float)
    nF, r = US.shape
    th = ca.SX.sym("theta", 5)
    w = ca.SX.sym("w", nF)
    om = ca.SX.sym("omega")
    Er, Ei = ca.SX.sym("Er", r, nF), ca.SX.sym("Ei", r, nF)
    Kr, Ki = k_complex(th, om)
    Wd = ca.repmat(w.T, r, 1)
    EWr, EWi = Er * Wd, Ei * Wd
    big = _loop_block(Kr, Ki, ca.mtimes(EWr, ca.DM(US)), ca.mtimes(EWi, ca.DM(US)))
    Y = ca.solve(big, ca.vertcat(EWr, EWi))
    f = (Kr * Kr + Ki * Ki) * ca.dot(ca.DM(np.asarray(s, float) ** 2),
                                     ca.sum2(Y[:r, :] ** 2 + Y[r:, :] ** 2))
    return ca.Function("T_fro2_lowrank", [th, w, om, Er, Ei], [f],
                       ["theta", "w", "omega", "Er", "Ei"], ["T_fro2"])


class PointsCallback(_VectorIO, ca.Callback):
    """``p -> (f(p, d_k))_k``: a scalar point function ``f`` at every point ``k`` of the data
    ``d_k``, with its Jacobian per point by reverse mode.

    CasADi's Jacobian of a mapped function seeds every input direction through all points
    (forward mode, one sweep of the whole map per parameter): 0.80 s on the placement card's
    robust constraint (816 points, 30 parameters), against 0.029 s here, where each point's
    gradient is one reverse sweep of its own SX graph (``casadi.jacobian`` of the scalar point
    function), mapped and evaluated numerically -- compiled when
    ``bridgeflap.design.control.formulation.buffeting_term.JIT`` (0.009 s; the library is cached by
    its source, so the same point function on other data is not recompiled), value and Jacobian
    together, cached for the last ``p``; the same numbers to 2e-15 relative. ``point``: SX function
    ``(p, *data) -> f`` (scalar); ``data``: per-point DM inputs stacked horizontally (the one-input
    boilerplate: ``bridgeflap.design.control.formulation.eigen._VectorIO``). Keep the object alive
    while expressions built from it are used (bridgeflap.design.control.formulation.eigen).
    """

    def __init__(self, point: ca.Function, data, n_points: int, name: str):
        ca.Callback.__init__(self)
        ins = point.sx_in()
        f = point(*ins)
        both = ca.Function(f"{point.name()}_grad", ins, [f, ca.jacobian(f, ins[0])])
        from bridgeflap.design.control.formulation import buffeting_term as bt

        if bt.JIT:          # compiled like the buffeting term's point functions (else the VM)
            try:
                both, _ = bt._compiled(both, reverse=False)
            except Exception:  # noqa: BLE001 - no compiler: the same expression, VM
                pass
        self._both = both.map(int(n_points), "serial")
        self._data = list(data)
        self._n_p, self._n_out = int(point.size1_in(0)), int(n_points)
        self._last = (None, None, None)
        self._jac_callback = None
        self.construct(name, {})

    def get_sparsity_out(self, i):
        return ca.Sparsity.dense(self._n_out, 1)

    def has_jacobian(self):
        return True

    def get_jacobian(self, name, inames, onames, opts):
        self._jac_callback = _JacobianCallback(self, name, inames, onames, opts)
        return self._jac_callback

    def _evaluate(self, p):
        p = np.asarray(p, float).ravel()
        if self._last[0] is None or not np.array_equal(self._last[0], p):
            v, J = self._both(p, *self._data)
            self._last = (p.copy(), np.asarray(v.full()).ravel(),
                          np.asarray(J.full()).reshape(self._n_out, self._n_p))
        return self._last[1], self._last[2]

    def values(self, p) -> np.ndarray:
        return self._evaluate(p)[0]

    def jacobian(self, p) -> np.ndarray:
        """``(n_points, n_p)``."""
        return self._evaluate(p)[1]

    def eval(self, arg):
        return [ca.DM(self.values(np.asarray(arg[0], float)))]


def lowrank_robust_points(US, s, omega, E) -> PointsCallback:
    """``[theta; w] -> ||T(j omega_k)||_F^2`` at every point of the low-rank form
    (:func:`lowrank_robust_data`, :func:`lowrank_point_function`) as a :class:`PointsCallback`."""
    US = np.asarray(US, float)
    nF, r = US.shape
    pf = lowrank_point_function(US, s)
    q = ca.SX.sym("p", 5 + nF)
    om = ca.SX.sym("omega")
    Er, Ei = ca.SX.sym("Er", r, nF), ca.SX.sym("Ei", r, nF)
    point = ca.Function(f"T_fro2_lowrank_{nF}_{r}", [q, om, Er, Ei],
                        [pf(q[:5], q[5:], om, Er, Ei)])
    E = np.asarray(E, complex)
    data = (ca.DM(np.asarray(omega, float)[None, :]), ca.DM(np.hstack(list(E.real))),
            ca.DM(np.hstack(list(E.imag))))
    return PointsCallback(point, data, len(omega), "T_fro2_lowrank_points")


#: Condition number of the eigenvector matrix of ``N = X diag(w) Phi_a`` above which a point
#: of :func:`analytic_robust_data` is not diagonalised (a nearly defective ``N`` would make
#: ``H`` large with cancelling terms); such points keep the exact solve of
#: :func:`robust_point_function` (none on the Humber design: cond(V) < 1e4 there).
ANALYTIC_COND_MAX = 1e8


def analytic_robust_data(Pa, X, weights):
    """Per point, ``(mu, H)`` with ``||T||_F^2 = |K|^2 d^H H d``, ``d_i = 1 / (1 - K mu_i)``.

    The compensator enters ``T = K Phi_a (I - K N)^{-1} X W`` (``N = X W Phi_a``, ``W =
    diag(w)`` fixed) only through the scalar ``K(j omega)``: with ``N = V diag(mu) V^{-1}``,
    ``T = K C diag(d) D`` (``C = Phi_a V``, ``D = V^{-1} X W``) and ``||T||_F^2 = |K|^2 d^H H
    d`` with ``H = (C^H C) o conj(D D^H)`` (Hadamard product, Hermitian). One eigen-
    decomposition per point, once; the NLP evaluates an ``O(n_modes^2)`` expression of
    ``(Re K, Im K)`` instead of a ``2 n_modes`` real solve.

    Parameters
    ----------
    Pa : ndarray (n_flaps, n)
    X : ndarray (n_points, n, n_flaps)
    weights : array_like (n_flaps,)

    Returns
    -------
    mu : ndarray (n_points, n) complex
    H : ndarray (n_points, n, n) complex
    ok : ndarray (n_points,) bool
        False where ``cond(V) > ANALYTIC_COND_MAX`` (use the exact solve there).
    """
    w = np.asarray(weights, float)
    X = np.asarray(X, complex)
    XW = X * w[None, None, :]
    N = XW @ Pa[None, :, :]
    mu, V = np.linalg.eig(N)
    ok = np.linalg.cond(V) <= ANALYTIC_COND_MAX
    Vs = np.where(ok[:, None, None], V, np.eye(V.shape[1])[None])
    C = Pa[None, :, :] @ Vs
    D = np.linalg.solve(Vs, XW)
    H = (np.conj(np.swapaxes(C, 1, 2)) @ C) * np.conj(D @ np.conj(np.swapaxes(D, 1, 2)))
    return mu, H, ok


def analytic_robust_function(omega, mu, H) -> PointsCallback:
    """``theta -> ||T(j omega_k)||_F^2`` (n_points,) from the data of
    :func:`analytic_robust_data` as a :class:`PointsCallback` (the point function in real
    arithmetic, exact derivatives in theta): ``d^H H d = a^T H_r a + b^T H_r b - 2 a^T H_i b``
    for ``d = a + i b``. (Before: one flat SX graph of every point, data as constants, which
    every ``nlpsol`` differentiated again.)"""
    mu, H = np.asarray(mu), np.asarray(H)
    N, n = mu.shape
    th = ca.SX.sym("theta", 5)
    om = ca.SX.sym("omega")
    mr, mi = ca.SX.sym("mu_r", n), ca.SX.sym("mu_i", n)
    Hr, Hi = ca.SX.sym("H_r", n, n), ca.SX.sym("H_i", n, n)
    Kr, Ki = k_complex(th, om)
    qr = 1.0 - (Kr * mr - Ki * mi)
    qi = -(Kr * mi + Ki * mr)
    q2 = qr * qr + qi * qi
    a, b = qr / q2, -qi / q2
    f = (Kr * Kr + Ki * Ki) * (ca.dot(a, ca.mtimes(Hr, a)) + ca.dot(b, ca.mtimes(Hr, b))
                               - 2.0 * ca.dot(a, ca.mtimes(Hi, b)))
    f1 = ca.Function(f"T_fro2_point_{n}", [th, om, mr, mi, Hr, Hi], [f])
    data = (ca.DM(np.asarray(omega, float)[None, :]), ca.DM(mu.real.T), ca.DM(mu.imag.T),
            ca.DM(np.hstack(list(H.real))), ca.DM(np.hstack(list(H.imag))))
    return PointsCallback(f1, data, N, "T_fro2_analytic")


def true_t_peak(theta, Pa, X, omega, weights) -> np.ndarray:
    """``sigma_max(T(j omega_k))`` per frequency [-] (numpy, for the a posteriori margin)."""
    K = np.atleast_1d(Compensator(*(float(v) for v in theta)).frequency_response(omega))
    XW = np.asarray(X) * np.asarray(weights, float)[None, None, :]     # (N, n, nF)
    Z = np.linalg.solve(np.eye(Pa.shape[1])[None] - K[:, None, None] * (XW @ Pa), XW)
    # batched over the frequencies (one LAPACK call each for the solves and the SVDs)
    return np.linalg.svd(K[:, None, None] * (Pa[None] @ Z), compute_uv=False)[:, 0]


def t_sigma_function(model, U, theta, weights, cache=None):
    """``omega -> sigma_max(T(j omega, U))`` (vectorised over ``omega``) for one speed;
    ``cache``: a dict of plant factors already computed on this model (:func:`cached_plant`),
    used for grids (more than one frequency)."""
    def f(omega):
        omega = np.atleast_1d(np.asarray(omega, float))
        if cache is None or omega.size == 1:
            Pa, X = plant_factors(model, float(U), 1j * omega)
        else:
            Pa, X = cached_plant(model, float(U), omega, cache)
        return true_t_peak(theta, Pa, X, omega, weights)
    return f


#: Frequencies per speed kept by :func:`cached_plant` (each ``n_modes x n_flaps`` complex:
#: 2,000 x 16 x 25 is 13 MB per speed on the default card).
PLANT_CACHE_POINTS = 2000


def cached_plant(model, U, omega, cache) -> tuple[np.ndarray, np.ndarray]:
    """:func:`bridgeflap.design.control.formulation.plant.plant_factors` at ``(U, j omega)`` with
    the frequencies computed before at ``U`` taken from ``cache`` (``{U: (sorted omega, X)}``) and
    the others computed and added (up to :data:`PLANT_CACHE_POINTS` per speed). The plant does not
    depend on ``theta``: the dense robust check of every cutting-plane round reuses the fixed part
    of its grid (400 log points + the structural frequencies per speed). The values are the
    plant's own, point by point (bitwise: each frequency is solved on its own either way)."""
    om_c, X_c, Pa = cache.get(U, (np.empty(0), None, None))
    i = np.clip(np.searchsorted(om_c, omega), 0, max(om_c.size - 1, 0))
    hit = (om_c[i] == omega) if om_c.size else np.zeros(omega.shape, bool)
    miss = ~hit
    Xm = None
    if miss.any():
        Pa, Xm = plant_factors(model, U, 1j * omega[miss])
    X = np.empty((omega.size, *(X_c if X_c is not None else Xm).shape[1:]), complex)
    if hit.any():
        X[hit] = X_c[i[hit]]
    if Xm is not None:
        X[miss] = Xm
        if om_c.size + int(miss.sum()) <= PLANT_CACHE_POINTS:
            om_n = np.concatenate([om_c, omega[miss]])
            X_n = Xm if X_c is None else np.concatenate([X_c, Xm])
            order = np.argsort(om_n, kind="stable")
            cache[U] = (om_n[order], X_n[order], Pa)
    return Pa, X


def refine_peaks(fun, omega, values, count) -> list[tuple[float, float]]:
    """The ``count`` largest local maxima of ``fun`` sampled as ``values`` on ``omega``.

    Each discrete local maximum ``i`` is polished by a bounded scalar search on
    ``[omega[i-1], omega[i+1]]`` (``xatol`` 1e-9 relative: the peaks of a lightly damped mode
    have a relative half-width ~ its damping ratio >= 1e-4, so the located peak value is exact
    to ~(1e-9 / 1e-4)^2, far below any tolerance used on it). Returns ``(omega, value)`` pairs,
    largest first; the polished value is never below the sampled one.
    """
    from scipy.optimize import minimize_scalar

    v = np.asarray(values, float)
    n = v.size
    if n == 0:
        return []
    left = np.r_[-np.inf, v[:-1]]
    right = np.r_[v[1:], -np.inf]
    idx = np.flatnonzero((v >= left) & (v >= right))
    idx = idx[np.argsort(-v[idx])][:count]
    out = []
    for i in idx:
        lo, hi = omega[max(i - 1, 0)], omega[min(i + 1, n - 1)]
        best = (float(omega[i]), float(v[i]))
        if hi > lo:
            r = minimize_scalar(lambda x: -float(fun(x)[0]), bounds=(lo, hi), method="bounded",
                                options={"xatol": 1e-9 * hi})
            if -r.fun > best[1]:
                best = (float(r.x), float(-r.fun))
        out.append(best)
    return sorted(out, key=lambda t: -t[1])


def robust_dense_omega(A_parts, U, structural_frequencies) -> np.ndarray:
    """Dense check frequencies [rad/s] at speed ``U`` [m/s]: 400 log-spaced on 0.01..30 rad/s,
    the ``structural_frequencies`` [rad/s] and the damped frequencies ``|Im lambda|`` of the
    closed loop ``A_parts`` in that band (the peaks of ``sigma_max(T)`` sit on its lightly
    damped poles)."""
    A0, A1, A2, _ = A_parts
    lam = scipy.linalg.eigvals(A0 + U * A1 + U * U * A2)
    wd = np.abs(lam.imag)
    wd = wd[(wd > 1e-2) & (wd < 30.0)]
    return np.unique(np.concatenate([np.logspace(-2, np.log10(30.0), 400),
                                     structural_frequencies, wd]))


def robust_margin(model, theta, speeds, weights, omega_at, peaks=1,
                  cache=None) -> RobustMargin:
    """True small-gain margin ``1 / max_U sup_w sigma_max(T(jw))`` on a dense grid.

    ``T = (I - L)^{-1} L``, ``L(jw) = K(jw) G(jw)`` (positive feedback ``beta = K alpha``):
    the transfer from a perturbation ``d`` of the flap inputs (``beta_applied = beta + d``)
    to the controller output; ``sigma_max`` by SVD (not the Frobenius bound of the NLP).
    The largest discrete local maxima (at least 8, and ``peaks``) of each speed's grid are
    polished by a bounded scalar search (:func:`refine_peaks`), so a resonance between grid
    points is not under-read.

    Parameters
    ----------
    model : bridgeflap.model.aeroelastic.flaps.ClosedLoopModel
    theta : array_like
        Compensator coefficients (b2, b1, b0, a2, a1).
    speeds : array_like
        Wind speeds [m/s].
    weights : array_like
        Per-flap weights [-].
    omega_at : callable
        ``U -> frequencies`` [rad/s] of the grid at speed ``U`` [m/s].
    peaks : int
        Local peaks ``(omega, sigma_max)`` per speed kept in ``RobustMargin.peaks``.
    cache : dict, optional
        Plant factors of ``model`` kept between calls (:func:`cached_plant`).
    """
    speeds = np.asarray(speeds, float)
    w = np.asarray(weights, float)
    theta = np.asarray(theta, float)
    out_peaks, t_inf, at = [], [], []
    for U in speeds:
        om = omega_at(float(U))
        fun = t_sigma_function(model, float(U), theta, w, cache)
        pk = refine_peaks(fun, om, fun(om), max(8, int(peaks)))
        out_peaks.append(pk[:max(1, int(peaks))])
        t_inf.append(pk[0][1])
        at.append(pk[0][0])
    t_inf = np.array(t_inf)
    return RobustMargin(speeds_m_s=speeds, t_inf=t_inf, peak_omega_rad_s=np.array(at),
                        peaks=tuple(out_peaks),
                        margin=float(1.0 / t_inf.max()) if t_inf.size else float("nan"))


def robust_epigraph_function(problem, analytic=False):
    """``(theta, w) -> ||T||_F^2`` at every (robust design speed, frequency) and robust cut of
    ``problem`` (a :class:`bridgeflap.design.control.formulation.nlp.DesignProblem`) and the
    ``(speed, omega)`` points, cached on the problem
    (:meth:`bridgeflap.design.control.formulation.nlp.DesignProblem.robust_function`)."""
    key = (tuple(problem.robust_cuts), bool(analytic))
    if problem._robust is None or problem._robust[2] != key:
        s = problem.settings
        if problem._robust_base is None:
            om = problem.robust_omega_grid()
            Xs, oms, pts = [], [], []
            Pa = None
            for U in s.robust_design_speeds_m_s:
                Pa, X = plant_factors(problem.model, float(U), 1j * om)
                Xs += list(X)
                oms += list(om)
                pts += [(float(U), float(w)) for w in om]
            problem._robust_base = (Pa, Xs, oms, pts)
        Pa, Xs, oms, pts = problem._robust_base
        Xs, oms, pts = list(Xs), list(oms), list(pts)
        for U, omc in key[0]:
            Pa, X = plant_factors(problem.model, float(U), [1j * omc])
            Xs.append(X[0])
            oms.append(omc)
            pts.append((float(U), float(omc)))
        th = ca.MX.sym("theta", 5)
        w = ca.MX.sym("w", problem.model.n_flaps)
        oms = np.asarray(oms, float)
        exact = np.ones(len(pts), bool)
        vals, cbs = [], []
        if analytic:
            mu, H, ok = analytic_robust_data(Pa, np.asarray(Xs), problem.weights)
            exact = ~ok
            i = np.flatnonzero(ok)
            if i.size:
                fa = analytic_robust_function(oms[i], mu[i], H[i])
                vals.append(fa(th).T)
                cbs.append(fa)
        j = np.flatnonzero(exact)
        if j.size:      # the exact solve, in its low-rank form (design.control.formulation.robust)
            US, sv, E = lowrank_robust_data(Pa, [Xs[k] for k in j])
            cbs.append(lowrank_robust_points(US, sv, oms[j], E))
            wj = ca.DM(problem.weights) if analytic else w
            vals.append(cbs[-1](ca.vertcat(th, wj)).T)
        order = np.concatenate([np.flatnonzero(~exact), j]).astype(int)
        pts = [pts[k] for k in order]
        fun = ca.Function("T_fro2_grid", [th, w], [ca.horzcat(*vals).T], ["theta", "w"],
                          ["T_fro2"])
        problem._robust = (fun, pts, key, cbs)    # the callbacks kept alive with it
    return problem._robust[:2]
