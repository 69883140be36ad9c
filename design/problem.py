"""Flap compensator design: Ipopt over K(s) (and optionally the flap layout), seed §6.

Problem (METHODS §4-5)::

    minimise     w_rob gamma_T + w_buf J_buf(theta)/J_buf(open loop) + w_reg |theta/scale|^2
                 + w_flaps sum(w)/n_flaps
    over         theta = (b2, b1, b0, a2, a1), gamma_T  [and w in [0, 1]^n_flaps if
                 optimise_placement]
    subject to   top-m Re lambda(A_cl(U_i, theta, w)) <= -sigma_req(U_i)  at every design speed
                 ||T(j omega_k, U_j)||_F^2 <= gamma_T^2    robust speeds U_j x frequency grid
                 |K(j omega_k)|^2 <= gain_limit^2          on a frequency grid (and omega -> inf)
                 a2 >= a2_min > 0,  a1 >= a1_min > 0       (stable, proper K)

Robustness. ``T = (I - L)^{-1} L``, ``L = K(jw) G(jw)`` is the input complementary sensitivity
of the n_flaps x n_flaps flap loop (positive feedback ``beta = K alpha``); by the small-gain
theorem the loop tolerates a multiplicative input perturbation with ``||Delta||_inf <
1/||T||_inf``. The NLP constrains the **Frobenius norm** ``||T||_F >= sigma_max(T)``, a
differentiable upper bound (``sigma_max <= ||T||_F <= sqrt(rank) sigma_max``, rank <= n_modes),
at ``robust_design_speeds_m_s`` and ``n_robust_omega`` log-spaced frequencies plus the
in-vacuo structural frequencies, so ``1/gamma_T`` is a guaranteed lower bound of the margin at
those points. ``G = Phi_a D(s)^{-1} F(s) diag(w)`` has rank <= n_modes, so ``T`` is evaluated
as ``K Phi_a (I - K X Phi_a)^{-1} X`` with ``X = D^{-1} F diag(w)`` (one n_modes x n_modes
complex solve per point). The true margin ``1/max sigma_max(T)`` is reported a posteriori on
a dense grid (:meth:`DesignProblem.robust_margin`).

Decay rate. ``sigma_req(U) = min(sigma_min, sigma_per_speed * U)``: the slowest aerodynamic lag
pole of the RFA moves as ``-beta_1 U / b`` and is (almost) uncontrollable by the flaps, so a
fixed decay rate cannot be demanded at low speed. At ``U = 0`` the lag states are exactly
decoupled (their input is proportional to ``U``), their zero eigenvalues are dropped, and the
structural ones must satisfy ``sigma_min``. The eigenvalue constraints use
:class:`design.eigen.PolynomialTopRealParts` (analytic eigenvalue Jacobians, limited-memory
Hessian).

Buffeting. ``J_buf`` is the mean over ``buffeting_speeds_m_s`` of the squared RMS vertical and
torsional deck response (each normalised by its open-loop value) from
:func:`model.buffeting.buffeting`, evaluated numerically in a :class:`casadi.Callback` with a
forward-difference Jacobian (step 1e-4 relative); used only when ``weight_buffeting > 0``.

Cutting planes (:meth:`DesignProblem.solve_with_cuts`, at most ``cutting_plane_rounds``
warm-started re-solves of at most ``resolve_max_iter`` iterations): violating speeds of the dense
decay-rate check join the design grid; if the true peak ``Compensator.max_gain()`` exceeds the
limit, its frequency joins the gain grid; dense ``sigma_max(T)`` peaks above ``gamma_T`` join the
robust epigraph. A re-solve only sees sample points and may land on a worse design, so the best
round (feasible first, then smallest dense peak) is returned and every round is recorded.
A design whose true peak gain exceeds ``gain_limit`` is never ``converged``.

Verification. Every solution is checked a posteriori on the dense ``check_step_m_s`` grid
(cutting planes: violating speeds join the design grid and the problem is re-solved) and, when
the design model is reduced, on the ``verification_modes`` model that ``bridgeflap flutter``
uses (:data:`model.analysis.DEFAULT_MODES`); the result reports both honestly.

Placement. With ``optimise_placement`` the per-flap weights ``w`` (load factor, 1 = fitted)
are NLP variables with a penalty ``weight_flaps * sum(w)/n_flaps``; the solution is rounded
(``w > 0.5`` fitted), ``theta`` re-solved for the rounded layout and re-verified. The minimum
flap count search over evenly spaced layouts remains as the fallback.
"""

from __future__ import annotations

import math
import os
import sys
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import casadi as ca
import numpy as np
import scipy.linalg

from design.eigen import PolynomialTopRealParts
from model.control import Compensator, Controller
from model.errors import BridgeflapInputError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

THETA_NAMES = ("b2", "b1", "b0", "a2", "a1")
#: Scale of theta in the regularisation term (a2 ~ 0.01..1 s^2).
THETA_SCALE = np.array([1.0, 1.0, 1.0, 0.1, 1.0])
#: Eigenvalue constraints are ~ 0.01 1/s: multiplied by this [s] to be O(1) for Ipopt.
EIG_SCALE = 100.0
#: Feasibility tolerance of the dense verification [1/s] (Ipopt's constr_viol_tol 1e-6 on the
#: scaled constraint is 1e-8 1/s; 1e-6 1/s leaves room for the eig round-off of ~1e-10 1/s).
VIOLATION_TOL = 1e-6
#: Nominal first start (b2, b1, b0, a2, a1): static gain -1 (flap against pitch), mild rate.
NOMINAL_START = np.array([0.0, 0.5, -1.0, 0.05, 0.5])
#: Relative back-off of the gain limit inside the NLP. Ipopt accepts a violation of
#: ``constr_viol_tol = 1e-6`` on ``|K|^2 / L_nlp^2 - 1``, i.e. ``|K| <= L_nlp (1 + 5e-7)``;
#: with ``L_nlp = L (1 - 1e-6)`` a converged sample point is strictly inside ``|K| <= L``, so
#: the a posteriori check ``max_gain <= gain_limit`` needs no tolerance of its own.
GAIN_BACKOFF = 1e-6
#: Relative tolerance of the robust cutting-plane test ``sigma_max(T) <= gamma_T (1 + tol)``
#: on the dense grid. At an active cut the NLP gives ``||T||_F^2 <= gamma_T^2 + 1e-6``, i.e.
#: ``sigma_max <= gamma_T (1 + 5e-7 / gamma_T^2)``; near a resonance ``T`` is nearly rank one
#: (``sigma_max ~ ||T||_F``), so an active cut sits at ``gamma_T`` to ~1e-6. 1e-3 (the margin
#: is reported to three significant figures) stops a re-solve (~10-30 s) for a 0.1 % gap.
ROBUST_CUT_TOL = 1e-3
#: Robust cuts added per speed and round: the worst local peaks of sigma_max above gamma_T.
ROBUST_CUTS_PER_SPEED = 2
#: Each robust cut is a cluster ``omega* (1 + k ROBUST_CLUSTER_STEP)``, k = -2..2. The peaks
#: of sigma_max(T) here have relative half-power half-widths >= ~3 % (70 m/s, default design:
#: 2.44 at the peak, 2.13 at -2 %); a single point is escaped by shifting the resonance by a
#: fraction of that, a 1 % spaced cluster bounds the under-read of a shifted peak to ~5 %.
ROBUST_CLUSTER_STEP = 0.01
#: Ipopt barrier parameter of a warm-started re-solve (default 0.1 re-centres the iterate
#: far from the previous solution; 1e-3 keeps it near while staying interior).
WARM_MU_INIT = 1e-3
#: Candidates screened per Sobol start (:func:`screened_starts`).
SCREEN_FACTOR = 8


def _num(field_name, v, positive=False, nonneg=False):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise BridgeflapInputError(field_name, f"must be a number, got {v!r}")
    v = float(v)
    if not math.isfinite(v):
        raise BridgeflapInputError(field_name, f"must be finite, got {v!r}")
    if positive and v <= 0:
        raise BridgeflapInputError(field_name, f"must be > 0, got {v!r}")
    if nonneg and v < 0:
        raise BridgeflapInputError(field_name, f"must be >= 0, got {v!r}")
    return v


@dataclass(frozen=True)
class DesignSettings:
    """Definition of the design problem (defaults: Humber, seed §6; overridable by TOML).

    Units: lengths [m], speeds [m/s], rates [1/s], frequencies [rad/s], gains [rad/rad].
    """

    bridge: str = "humber"
    n_modes: int = 16
    verification_modes: int = 16
    flap_count: int = 25
    flap_width_m: float = 56.4          # spanwise length of each flap pair: 1410 m / 25
    flap_chord_m: float = 3.0           # chordwise, inside the 22 m deck chord (seed §6)
    leading_edge: bool = True
    trailing_edge: bool = True
    speed_max_m_s: float = 85.0
    design_step_m_s: float = 5.0
    check_step_m_s: float = 0.25
    sigma_min_1_s: float = 0.004
    sigma_per_speed_1_m: float = 2.5e-4
    n_eig: int = 3
    gain_limit: float = 15.0
    omega_min_rad_s: float = 1e-3
    omega_max_rad_s: float = 1e2
    n_omega: int = 120
    robust_design_speeds_m_s: tuple = (20.0, 40.0, 60.0, 70.0, 80.0, 85.0)
    robust_omega_min_rad_s: float = 0.02
    robust_omega_max_rad_s: float = 10.0
    n_robust_omega: int = 20
    robust_speeds_m_s: tuple = (10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 85.0)
    weight_robust: float = 1.0
    weight_regularisation: float = 1e-3
    weight_buffeting: float = 0.0
    buffeting_speeds_m_s: tuple = (10.0, 20.0, 25.0)
    optimise_placement: bool = False
    weight_flaps: float = 0.0
    starts: int = 2
    seed: int = 1
    parallel: bool = False
    max_iter: int = 80
    resolve_max_iter: int = 20
    cutting_plane_rounds: int = 2
    b_bound: float = 15.0
    a2_bounds: tuple = (1e-3, 5.0)
    a1_bounds: tuple = (1e-2, 10.0)
    min_flap_counts: tuple = (25, 21, 17, 13, 9, 7, 5, 3, 1)
    extras: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        """Validate (one field named per error)."""
        _num("gain_limit", self.gain_limit, positive=True)
        for name in ("flap_width_m", "flap_chord_m", "speed_max_m_s", "design_step_m_s",
                     "check_step_m_s", "omega_min_rad_s", "omega_max_rad_s",
                     "robust_omega_min_rad_s", "robust_omega_max_rad_s"):
            _num(name, getattr(self, name), positive=True)
        for name in ("sigma_min_1_s", "sigma_per_speed_1_m", "weight_regularisation",
                     "weight_buffeting", "weight_robust", "weight_flaps"):
            _num(name, getattr(self, name), nonneg=True)
        for name in ("n_modes", "verification_modes", "flap_count", "n_eig", "n_omega",
                     "n_robust_omega", "starts", "max_iter", "resolve_max_iter"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise BridgeflapInputError(name, f"must be a positive integer, got {v!r}")
        if self.omega_max_rad_s <= self.omega_min_rad_s:
            raise BridgeflapInputError("omega_max_rad_s", "must exceed omega_min_rad_s")
        if self.robust_omega_max_rad_s <= self.robust_omega_min_rad_s:
            raise BridgeflapInputError("robust_omega_max_rad_s",
                                       "must exceed robust_omega_min_rad_s")
        if self.a2_bounds[0] <= 0 or self.a1_bounds[0] <= 0:
            raise BridgeflapInputError("a2_bounds", "lower bounds of a2 and a1 must be > 0 "
                                                    "(stable, proper compensator)")
        if not (self.leading_edge or self.trailing_edge):
            raise BridgeflapInputError("trailing_edge", "no flap fitted")
        for name in ("robust_design_speeds_m_s", "robust_speeds_m_s", "buffeting_speeds_m_s"):
            for v in getattr(self, name):
                _num(name, v, positive=True)
        if not isinstance(self.optimise_placement, bool):
            raise BridgeflapInputError("optimise_placement", "must be true or false")

    def positions(self, count: int | None = None) -> np.ndarray:
        """Evenly spaced, touching flap centres from the main-span mid-point [m]."""
        count = self.flap_count if count is None else int(count)
        return (np.arange(count) - 0.5 * (count - 1)) * self.flap_width_m

    def design_speeds(self) -> np.ndarray:
        """Design grid [m/s], 0 .. speed_max inclusive."""
        n = int(round(self.speed_max_m_s / self.design_step_m_s))
        return np.unique(np.append(np.linspace(0.0, n * self.design_step_m_s, n + 1),
                                   self.speed_max_m_s))

    def check_speeds(self) -> np.ndarray:
        """Dense verification grid [m/s]."""
        n = int(round(self.speed_max_m_s / self.check_step_m_s))
        return np.linspace(0.0, self.speed_max_m_s, n + 1)

    def sigma_required(self, U) -> np.ndarray:
        """Required decay rate ``min(sigma_min, sigma_per_speed U)`` [1/s] (``sigma_min`` at 0)."""
        U = np.asarray(U, float)
        return np.where(U > 0, np.minimum(self.sigma_min_1_s, self.sigma_per_speed_1_m * U),
                        self.sigma_min_1_s)


_TOML_KEYS = {f for f in DesignSettings.__dataclass_fields__ if f != "extras"}


def load_settings(path=None, **overrides) -> DesignSettings:
    """Defaults (embedded here) overridden by a TOML file and keyword arguments.

    Raises
    ------
    BridgeflapInputError
        Unknown key, bad value, missing or unreadable file.
    """
    data = {}
    if path is not None:
        p = Path(path)
        try:
            data = tomllib.loads(p.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise BridgeflapInputError("design", f"file not found: {p}") from None
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise BridgeflapInputError("design", f"invalid TOML in {p}: {exc}") from None
    flat = {}
    for key, value in data.items():
        if isinstance(value, dict):         # allow [tables] for grouping
            for k, v in value.items():
                flat[k] = v
        else:
            flat[key] = value
    flat.update(overrides)
    unknown = sorted(set(flat) - _TOML_KEYS)
    if unknown:
        raise BridgeflapInputError(unknown[0], "unknown design setting")
    for key in ("a2_bounds", "a1_bounds", "min_flap_counts", "robust_speeds_m_s",
                "robust_design_speeds_m_s", "buffeting_speeds_m_s"):
        if key in flat:
            flat[key] = tuple(flat[key])
    return DesignSettings(**flat)


# --------------------------------------------------------------------------- plant and robustness


def plant_factors(model, U, s) -> tuple[np.ndarray, np.ndarray]:
    """Factors of the flap-loop plant ``G(s) = Phi_a X(s) diag(w)`` (RFA aerodynamics).

    ``G`` maps the flap drive angles [rad] to the deck pitch at the flaps [rad]: the open-loop
    generalised equation ``D(s) q = F(s) beta`` with the flap loads as inputs, ``C(k)`` from the
    same RFA as the state space (``s`` complex, so ``G`` is the exact transfer function of the
    RFA state space), ``X = D^{-1} F`` for unit weights.

    Parameters
    ----------
    model : model.flaps.ClosedLoopModel
    U : float
        Wind speed [m/s].
    s : array_like
        Complex frequencies [1/s] (``1j * omega`` for a frequency response).

    Returns
    -------
    Pa : ndarray (n_flaps, n_modes)
        Pitch at the flap strips per unit modal coordinate [rad].
    X : ndarray (len(s), n_modes, n_flaps) complex
    """
    ol, fl = model.open_loop, model.flaps
    B, a, rfa = ol.basis, ol.aero, ol.rfa
    b, rho = a.half_chord, a.air_density
    sc = fl.width_m
    ld = fl.loads
    Hk = [(fl.phi_h.T * e[0] + fl.phi_a.T * e[1]) * sc for e in (ld.e0, ld.e1, ld.e2)]
    PF = (-2 * np.pi * rho * b * fl.phi_h.T + np.pi * rho * b * b * fl.phi_a.T) * sc
    s = np.atleast_1d(np.asarray(s, complex))
    X = np.zeros((len(s), B.n, fl.n_flaps), complex)
    Mt = B.M + a.M_nc
    for i, p in enumerate(s):
        sbar = p * b / U if U > 0 else 0.0
        C = 1.0 - np.sum(rfa.gains * sbar / (sbar + rfa.poles)) if U > 0 else 1.0
        D = p * p * Mt + p * (B.C + U * a.D_nc) + B.K - U * C * a.P @ (p * a.G1 + U * a.G0)
        F = p * p * Hk[2] + U * p * Hk[1] + U * U * Hk[0] + U * C * PF * (U * ld.g0
                                                                          + b * ld.g1 * p)
        X[i] = np.linalg.solve(D, F)
    return np.asarray(fl.phi_a, float), X


def plant_frequency_response(model, U, omega, weights=None) -> np.ndarray:
    """``G(jw)`` (n_omega, n_flaps, n_flaps) [rad/rad] (:func:`plant_factors`)."""
    Pa, X = plant_factors(model, U, 1j * np.asarray(omega, float))
    w = np.ones(Pa.shape[0]) if weights is None else np.asarray(weights, float)
    return np.einsum("fn,knj->kfj", Pa, X) * w[None, None, :]


def _k_complex(th, om):
    """Real and imaginary parts of ``K(j om)`` for symbolic or numeric theta."""
    b2, b1, b0, a2, a1 = (th[i] for i in range(5))
    nr, ni = b0 - b2 * om * om, b1 * om
    dr, di = 1 - a2 * om * om, a1 * om
    d2 = dr * dr + di * di
    return (nr * dr + ni * di) / d2, (ni * dr - nr * di) / d2


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
    Kr, Ki = _k_complex(th, om)
    Wd = ca.repmat(w.T, n, 1)
    XWr, XWi = Xr * Wd, Xi * Wd
    P = ca.DM(Pa)
    Nr, Ni = ca.mtimes(XWr, P), ca.mtimes(XWi, P)
    Mr = ca.DM.eye(n) - (Kr * Nr - Ki * Ni)
    Mi = -(Kr * Ni + Ki * Nr)
    big = ca.vertcat(ca.horzcat(Mr, -Mi), ca.horzcat(Mi, Mr))
    Z = ca.solve(big, ca.vertcat(XWr, XWi), "lapacklu", {})
    f = (Kr * Kr + Ki * Ki) * (ca.sumsqr(ca.mtimes(P, Z[:n, :]))
                               + ca.sumsqr(ca.mtimes(P, Z[n:, :])))
    return ca.Function("T_fro2", [th, w, om, Xr, Xi], [f], ["theta", "w", "omega", "Xr", "Xi"],
                       ["T_fro2"])


def true_t_peak(theta, Pa, X, omega, weights) -> np.ndarray:
    """``sigma_max(T(j omega_k))`` per frequency [-] (numpy, for the a posteriori margin)."""
    K = Compensator(*(float(v) for v in theta)).frequency_response(omega)
    w = np.asarray(weights, float)
    out = np.empty(len(omega))
    eye = np.eye(Pa.shape[1])
    for i in range(len(omega)):
        XW = X[i] * w[None, :]
        Z = np.linalg.solve(eye - K[i] * XW @ Pa, XW)
        out[i] = np.linalg.norm(K[i] * Pa @ Z, 2)
    return out


def t_sigma_function(model, U, theta, weights):
    """``omega -> sigma_max(T(j omega, U))`` (vectorised over ``omega``) for one speed."""
    def f(omega):
        omega = np.atleast_1d(np.asarray(omega, float))
        Pa, X = plant_factors(model, float(U), 1j * omega)
        return true_t_peak(theta, Pa, X, omega, weights)
    return f


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


class _BuffetingCallback(ca.Callback):
    """``J_buf(p)``: closed-loop buffeting cost (module docstring), forward-difference Jacobian."""

    def __init__(self, problem, n_p, step=1e-4):
        ca.Callback.__init__(self)
        self._prob = problem
        self._n_p = n_p
        self.step = step
        self._cache = {}
        self._jac = None
        self.construct("buffeting_cost", {})

    def get_n_in(self):
        return 1

    def get_n_out(self):
        return 1

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense(self._n_p, 1)

    def get_sparsity_out(self, i):
        return ca.Sparsity.dense(1, 1)

    def value(self, p):
        p = np.asarray(p, float).ravel()
        key = p.tobytes()
        if key not in self._cache:
            self._cache[key] = self._prob.buffeting_cost(p[:5], p[5:] if p.size > 5 else None)
        return self._cache[key]

    def eval(self, arg):
        return [ca.DM(self.value(arg[0]))]

    def has_jacobian(self):
        return True

    def get_jacobian(self, name, inames, onames, opts):
        parent = self

        class _J(ca.Callback):
            def __init__(self):
                ca.Callback.__init__(self)
                self.construct(name, {})

            def get_n_in(self):
                return 2

            def get_n_out(self):
                return 1

            def get_sparsity_in(self, i):
                return ca.Sparsity.dense(parent._n_p, 1) if i == 0 else ca.Sparsity.dense(1, 1)

            def get_sparsity_out(self, i):
                return ca.Sparsity.dense(1, parent._n_p)

            def eval(self, arg):
                p = np.asarray(arg[0], float).ravel()
                f0 = parent.value(p)
                g = np.zeros(p.size)
                for k in range(p.size):
                    h = parent.step * max(1.0, abs(p[k]))
                    e = np.zeros(p.size)
                    e[k] = h
                    g[k] = (parent.value(p + e) - f0) / h
                return [ca.DM(g[None, :])]

        self._jac = _J()
        return self._jac


# --------------------------------------------------------------------------- the problem


def _lag_free_indices(model) -> np.ndarray:
    ol = model.open_loop
    nx = model.casadi_functions()["A_cl"].size1_out(0)
    keep = np.ones(nx, bool)
    keep[ol.index.aero_lag] = False
    return np.flatnonzero(keep)


def closed_loop_abscissa(A_parts, U) -> np.ndarray:
    """Spectral abscissa [1/s] of ``A0 + U A1 + U^2 A2`` per speed (lag states dropped at 0)."""
    A0, A1, A2, keep0 = A_parts
    out = []
    for u in np.atleast_1d(U):
        A = A0 + u * A1 + u * u * A2
        if u == 0:
            A = A[np.ix_(keep0, keep0)]
        out.append(np.max(scipy.linalg.eigvals(A).real))
    return np.array(out)


def top_real_parts_numeric(A_parts, U, m) -> np.ndarray:
    """The ``m`` largest real parts [1/s] at one speed (as the optimiser sees them)."""
    A0, A1, A2, keep0 = A_parts
    A = A0 + U * A1 + U * U * A2
    if U == 0:
        A = A[np.ix_(keep0, keep0)]
    lam = scipy.linalg.eigvals(A)
    return np.sort(lam.real)[::-1][:m]


class DesignProblem:
    """Compensator NLP for a flap layout (build once, solve from many starts).

    Parameters
    ----------
    settings : DesignSettings
    model : model.flaps.ClosedLoopModel
    weights : array_like, optional
        Per-flap weights [0, 1] (1 = fitted); the start point when ``optimise_placement``.
    spec : model.spec.BridgeSpec, optional
        Needed only for the buffeting term (wind defaults).
    """

    def __init__(self, settings: DesignSettings, model, weights=None, spec=None):
        self.settings = settings
        self.model = model
        self.spec = spec
        self.weights = (np.ones(model.n_flaps) if weights is None
                        else np.asarray(weights, float).ravel())
        self.functions = model.casadi_functions()
        self.keep0 = _lag_free_indices(model)
        self.callbacks: dict = {}      # kept alive (design.eigen docstring)
        self._robust = None
        self._robust_base = None
        self._buffeting_ref = None
        #: Cutting planes added by :meth:`solve_with_cuts`: robust (speed, omega) points and
        #: gain-constraint frequencies, on top of the settings' sample grids.
        self.robust_cuts: list[tuple[float, float]] = []
        self.gain_cuts: list[float] = []

    @property
    def n_p(self) -> int:
        """Number of callback parameters: theta, plus the weights when placement is free."""
        return 5 + (self.model.n_flaps if self.settings.optimise_placement else 0)

    # ---- pieces
    def parts_function(self) -> ca.Function:
        """``p -> (A0, A1, A2)`` with ``p = theta`` or ``(theta, w)`` (placement)."""
        th = ca.SX.sym("theta", 5)
        if self.settings.optimise_placement:
            w = ca.SX.sym("w", self.model.n_flaps)
            p = ca.vertcat(th, w)
            parts = self.functions["A_parts"](th, w)
        else:
            p = th
            parts = self.functions["A_parts"](th, ca.DM(self.weights))
        return ca.Function("A_parts_p", [p], list(parts))

    def grid_callback(self, speeds) -> PolynomialTopRealParts:
        """Top-m real parts at ``speeds`` (lag states dropped at U = 0), cached per grid."""
        key = tuple(float(u) for u in speeds)
        if key not in self.callbacks:
            self.callbacks[key] = PolynomialTopRealParts(
                self.parts_function(), np.array(key), self.settings.n_eig,
                subsets={0.0: self.keep0}, name=f"top_grid_{len(self.callbacks)}")
        return self.callbacks[key]

    def A_parts(self, theta, weights=None) -> tuple:
        """Numeric ``(A0, A1, A2, keep0)`` of the closed loop at ``theta``."""
        w = self.weights if weights is None else np.asarray(weights, float)
        A0, A1, A2 = self.functions["A_parts"](ca.DM(theta), ca.DM(w))
        return A0.full(), A1.full(), A2.full(), self.keep0

    def omega_grid(self) -> np.ndarray:
        """Frequency grid of the gain constraint [rad/s]: log grid plus the gain cuts."""
        s = self.settings
        w = np.logspace(np.log10(s.omega_min_rad_s), np.log10(s.omega_max_rad_s), s.n_omega)
        return np.unique(np.concatenate([w, np.asarray(self.gain_cuts, float)]))

    def structural_frequencies(self) -> np.ndarray:
        """In-vacuo structural circular frequencies [rad/s]."""
        B = self.model.open_loop.basis
        return np.sqrt(np.abs(scipy.linalg.eigvals(B.K, B.M).real))

    def robust_omega_grid(self) -> np.ndarray:
        """Frequencies of the robustness constraint [rad/s]: log grid + structural modes."""
        s = self.settings
        w = np.logspace(np.log10(s.robust_omega_min_rad_s), np.log10(s.robust_omega_max_rad_s),
                        s.n_robust_omega)
        ws = self.structural_frequencies()
        ws = ws[(ws > s.robust_omega_min_rad_s) & (ws < s.robust_omega_max_rad_s)]
        # the peaks of |T| sit on the lightly damped closed-loop modes: a linear band over
        # the structural frequency range as well (n_robust_omega points)
        band = np.linspace(0.8 * ws.min(), 1.2 * ws.max(), s.n_robust_omega) if ws.size else []
        return np.unique(np.concatenate([w, ws, band]))

    def robust_check_speeds(self) -> np.ndarray:
        """Speeds of the dense robust check and cuts [m/s]: design and reported speeds."""
        s = self.settings
        return np.unique(np.asarray(tuple(s.robust_design_speeds_m_s)
                                    + tuple(s.robust_speeds_m_s), float))

    def robust_function(self) -> tuple[ca.Function, list]:
        """``(theta, w) -> ||T||_F^2`` at every (robust design speed, frequency) and at every
        robust cut (:attr:`robust_cuts`), and the ``(speed, omega)`` points."""
        key = tuple(self.robust_cuts)
        if self._robust is None or self._robust[2] != key:
            s = self.settings
            if self._robust_base is None:
                om = self.robust_omega_grid()
                Xr, Xi, oms, pts = [], [], [], []
                Pa = None
                for U in s.robust_design_speeds_m_s:
                    Pa, X = plant_factors(self.model, float(U), 1j * om)
                    for k in range(len(om)):
                        Xr.append(X[k].real)
                        Xi.append(X[k].imag)
                        oms.append(om[k])
                        pts.append((float(U), float(om[k])))
                self._robust_base = (Pa, Xr, Xi, oms, pts)
            Pa, Xr, Xi, oms, pts = self._robust_base
            Xr, Xi, oms, pts = list(Xr), list(Xi), list(oms), list(pts)
            for U, omc in key:
                Pa, X = plant_factors(self.model, float(U), [1j * omc])
                Xr.append(X[0].real)
                Xi.append(X[0].imag)
                oms.append(omc)
                pts.append((float(U), float(omc)))
            f1 = robust_point_function(Pa)
            N = len(pts)
            fm = f1.map(N, "serial")
            th = ca.MX.sym("theta", 5)
            w = ca.MX.sym("w", self.model.n_flaps)
            val = fm(th, w, ca.DM(np.array(oms)[None, :]), ca.DM(np.hstack(Xr)),
                     ca.DM(np.hstack(Xi)))
            fun = ca.Function("T_fro2_grid", [th, w], [val.T], ["theta", "w"], ["T_fro2"])
            self._robust = (fun, pts, key)
        return self._robust[:2]

    # ---- buffeting
    def buffeting_rms(self, theta, weights=None, speeds=None) -> tuple[np.ndarray, np.ndarray]:
        """Max RMS vertical [m] and torsional [rad] response at ``speeds`` (closed loop)."""
        from model.buffeting import buffeting
        from model.spec import load_bridge

        spec = self.spec if self.spec is not None else load_bridge(self.settings.bridge)
        w = self.weights if weights is None else np.asarray(weights, float)
        speeds = self.settings.buffeting_speeds_m_s if speeds is None else speeds
        sys_cl = self.model.system(Compensator(*(float(v) for v in theta)), weights=w)
        r = buffeting(sys_cl, np.asarray(speeds, float), spec=spec,
                      n_modes=int(self.model.open_loop.basis.n))
        return r.rms_vertical, r.rms_torsion

    def buffeting_cost(self, theta, weights=None) -> float:
        """``J_buf``: mean of the squared RMS ratios to the open loop (NaN/unstable -> 1e3)."""
        if self._buffeting_ref is None:
            self._buffeting_ref = self.buffeting_rms([0.0, 0.0, 0.0, 1.0, 1.0])
        try:
            ok = theta[3] > 0 and theta[4] > 0
            z, a = self.buffeting_rms(theta, weights) if ok else (np.nan, np.nan)
        except Exception:  # noqa: BLE001 - infeasible iterate: a large finite cost
            return 1e3
        z0, a0 = self._buffeting_ref
        v = 0.5 * np.mean((np.asarray(z) / z0) ** 2 + (np.asarray(a) / a0) ** 2)
        return float(v) if np.isfinite(v) else 1e3

    def constraint_values(self, theta, speeds) -> np.ndarray:
        """``top_m Re lambda + sigma_req`` per speed (n_speeds, m) [1/s]; <= 0 is feasible."""
        parts = self.A_parts(theta)
        sig = self.settings.sigma_required(speeds)
        return np.array([top_real_parts_numeric(parts, u, self.settings.n_eig) + sg
                         for u, sg in zip(speeds, sig, strict=True)])

    # ---- one solve
    def solve(self, theta0, speeds, max_iter=None, weights0=None, gamma0=None,
              warm=False) -> dict:
        """Solve the NLP from ``theta0`` (and ``weights0``) on the design ``speeds`` [m/s].

        ``gamma0`` (warm start) is raised to the epigraph value at ``theta0`` when lower, so
        the start satisfies the robust constraints whatever cuts were added; ``warm``
        starts Ipopt's barrier at ``WARM_MU_INIT`` (a re-solve after cuts).

        Returns a dict with ``theta``, ``weights``, ``gamma_T``, ``status`` (Ipopt return
        status), ``success``, ``iterations``, ``time_s``, ``objective``, ``constraints_eig``.
        """
        s = self.settings
        nF = self.model.n_flaps
        speeds = np.asarray(speeds, float)
        th = ca.MX.sym("theta", 5)
        gT = ca.MX.sym("gamma_T")
        if s.optimise_placement:
            w = ca.MX.sym("w", nF)
            p = ca.vertcat(th, w)
            x = ca.vertcat(th, gT, w)
        else:
            w = ca.DM(self.weights)
            p = th
            x = ca.vertcat(th, gT)
        cb = self.grid_callback(speeds)
        sig = np.repeat(s.sigma_required(speeds), s.n_eig)
        g = [EIG_SCALE * (cb(p) + sig)]
        lbg, ubg = [np.full(sig.size, -np.inf)], [np.zeros(sig.size)]
        # gain limit |K(j w)| <= L_nlp on the grid (+ gain cuts), at omega = 0 (b0) and at
        # omega -> inf (b2/a2); L_nlp backed off by GAIN_BACKOFF (see there)
        L2 = (s.gain_limit * (1.0 - GAIN_BACKOFF)) ** 2
        oms = self.omega_grid()
        for om in oms:
            Kr, Ki = _k_complex(th, om)
            g.append((Kr * Kr + Ki * Ki) / L2 - 1.0)
        g.append(th[2] * th[2] / L2 - 1.0)
        # omega -> inf as (b2/a2)^2 / L^2 - 1 (a2 >= a2_min > 0): scaled like the grid
        # points, so constr_viol_tol bounds the relative gain error (not a2^2 times it)
        g.append(th[0] * th[0] / (th[3] * th[3] * L2) - 1.0)
        lbg.append(np.full(len(oms) + 2, -np.inf))
        ubg.append(np.zeros(len(oms) + 2))
        f = s.weight_regularisation * ca.sumsqr(th / THETA_SCALE)
        n_rob = 0
        if s.weight_robust > 0 and (s.robust_design_speeds_m_s or self.robust_cuts):
            rob, pts = self.robust_function()
            g.append(rob(th, w) - gT * gT)
            n_rob = len(pts)
            lbg.append(np.full(n_rob, -np.inf))
            ubg.append(np.zeros(n_rob))
            f = f + s.weight_robust * gT
        if s.weight_buffeting > 0:
            bcb = _BuffetingCallback(self, self.n_p)
            self.callbacks["buffeting"] = bcb
            f = f + s.weight_buffeting * bcb(p)
        if s.optimise_placement and s.weight_flaps > 0:
            f = f + s.weight_flaps * ca.sum1(w) / nF
        lbx = [-s.b_bound, -s.b_bound, -s.b_bound, s.a2_bounds[0], s.a1_bounds[0], 0.0]
        ubx = [s.b_bound, s.b_bound, s.b_bound, s.a2_bounds[1], s.a1_bounds[1], 1e4]
        theta0 = np.asarray(theta0, float)
        w0 = self.weights if weights0 is None else np.asarray(weights0, float)
        gT0 = 1.0
        if n_rob:
            vals = np.asarray(self.robust_function()[0](theta0, w0).full()).ravel()
            gT0 = float(np.sqrt(np.max(vals))) if np.all(np.isfinite(vals)) else 10.0
            gT0 = min(max(gT0, 1e-3, 0.0 if gamma0 is None else float(gamma0)), 1e3)
        x0 = np.append(theta0, gT0)
        if s.optimise_placement:
            lbx += [0.0] * nF
            ubx += [1.0] * nF
            x0 = np.append(x0, w0)
        nlp = {"x": x, "f": f, "g": ca.vertcat(*g)}
        opts = {"ipopt.hessian_approximation": "limited-memory",
                "ipopt.max_iter": int(max_iter or s.max_iter), "ipopt.print_level": 0,
                "print_time": False, "ipopt.tol": 1e-6, "ipopt.acceptable_tol": 1e-4,
                "ipopt.acceptable_iter": 5, "ipopt.sb": "yes", "ipopt.constr_viol_tol": 1e-6,
                # an "acceptable" exit must be as feasible as an optimal one (default 1e-2)
                "ipopt.acceptable_constr_viol_tol": 1e-6}
        if warm:
            opts["ipopt.mu_init"] = WARM_MU_INIT
        solver = ca.nlpsol("design", "ipopt", nlp, opts)
        ev0, et0 = cb.evaluations, cb.eval_time_s
        t0 = time.perf_counter()
        sol = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=np.concatenate(lbg), ubg=np.concatenate(ubg))
        elapsed = time.perf_counter() - t0
        st = solver.stats()
        xs = np.asarray(sol["x"].full()).ravel()
        gs = np.asarray(sol["g"].full()).ravel()
        n_eig_cons = len(speeds) * s.n_eig
        evals = cb.evaluations - ev0
        return {"theta": xs[:5], "gamma_T": float(xs[5]),
                "weights": xs[6:] if s.optimise_placement else self.weights.copy(),
                "status": st["return_status"], "success": bool(st["success"]),
                "iterations": int(st["iter_count"]), "time_s": elapsed,
                "objective": float(sol["f"]),
                "constraints_eig": gs[:n_eig_cons] / EIG_SCALE, "n_speeds": len(speeds),
                "eig_evaluations": evals,
                "eig_time_per_speed_s": (cb.eval_time_s - et0) / max(evals, 1) / len(speeds)}

    # ---- verification
    def verify(self, theta, weights=None) -> dict:
        """Dense a posteriori check: abscissa on the check grid, constraint, peak gain."""
        s = self.settings
        U = s.check_speeds()
        parts = self.A_parts(theta, weights)
        absc = closed_loop_abscissa(parts, U)
        viol = absc + s.sigma_required(U)
        comp = Compensator(*(float(v) for v in theta))
        stable = absc < 0
        stable_to = float(U[-1]) if stable.all() else (
            float(U[np.argmax(~stable) - 1]) if np.argmax(~stable) > 0 else 0.0)
        return {"speeds": U, "abscissa": absc, "violation": viol,
                "max_violation": float(viol.max()), "stable_everywhere": bool(stable.all()),
                "stable_to_m_s": stable_to, "max_gain": comp.max_gain(),
                "modes": int(self.model.open_loop.basis.n), "step_m_s": s.check_step_m_s}

    def solve_with_cuts(self, theta0, weights0=None) -> dict:
        """Solve and re-solve with cutting planes (at most ``cutting_plane_rounds`` re-solves).

        After each solve the design is checked a posteriori and the worst violations join the
        NLP's sample sets before a warm-started re-solve:

        * decay rate: abscissa on the dense ``check_step_m_s`` grid; the worst speed of each run
          of violations joins the design speeds;
        * gain limit: the true peak :meth:`model.control.Compensator.max_gain`; if above
          ``gain_limit`` the stationary frequencies of ``|K(jw)|`` join the gain grid;
        * robustness: ``sigma_max(T)`` on a dense frequency grid (:meth:`robust_margin`) at
          :meth:`robust_check_speeds`; the worst (speed, frequency) peaks above
          ``gamma_T (1 + ROBUST_CUT_TOL)`` join the robust epigraph points.

        Returns the last :meth:`solve` result plus ``verification``, ``rounds`` (one record per
        solve), ``design_speeds``, ``gain_ok``, ``robust`` (dense check of the final design),
        ``robust_bound_holds`` (dense peak <= gamma_T within ``ROBUST_CUT_TOL``) and the cuts.
        """
        s = self.settings
        speeds = list(self.settings.design_speeds())
        history = []
        theta = np.asarray(theta0, float)
        w = self.weights if weights0 is None else np.asarray(weights0, float)
        gamma = None
        res = ver = rob = None
        kept = []
        use_rob = s.weight_robust > 0 and (bool(s.robust_design_speeds_m_s)
                                           or bool(s.robust_speeds_m_s))
        for rnd in range(s.cutting_plane_rounds + 1):
            res = self.solve(theta, np.array(sorted(speeds)), weights0=w, gamma0=gamma,
                             warm=rnd > 0,
                             max_iter=s.resolve_max_iter if rnd > 0 else s.max_iter)
            theta, w = res["theta"], res["weights"]
            gamma = res["gamma_T"] if use_rob else None
            ver = self.verify(theta, w)
            eig_ok = ver["max_violation"] <= VIOLATION_TOL
            gain_ok = ver["max_gain"] <= s.gain_limit
            rob_ok, new_rob = True, []
            rob = None
            if use_rob and _a2_ok(theta):
                rob = self.robust_margin(theta, speeds=self.robust_check_speeds(), weights=w,
                                         peaks=ROBUST_CUTS_PER_SPEED)
                lim = gamma * (1.0 + ROBUST_CUT_TOL)
                rob_ok = bool(np.max(rob["T_inf"]) <= lim)
                for U, pk in zip(rob["speeds_m_s"], rob["peaks"], strict=True):
                    new_rob += [(float(U), om * (1.0 + k * ROBUST_CLUSTER_STEP))
                                for om, v in pk if v > lim for k in (-2, -1, 0, 1, 2)]
                new_rob = [c for c in dict.fromkeys(new_rob) if c not in self.robust_cuts]
            new_gain = []
            if not gain_ok:
                comp = Compensator(*(float(v) for v in theta))
                wst = comp._stationary_frequencies()
                new_gain = [float(x) for x in wst
                            if abs(comp.frequency_response(x)) > s.gain_limit
                            * (1.0 - GAIN_BACKOFF) and float(x) not in self.gain_cuts]
            new_speeds = []
            if not eig_ok:
                new_speeds = [u for u in _worst_per_run(ver["speeds"],
                                                        ver["violation"] > VIOLATION_TOL,
                                                        ver["violation"]) if u not in speeds]
            history.append({
                "round": rnd, "status": res["status"], "iterations": res["iterations"],
                "theta": [float(v) for v in theta],
                "time_s": res["time_s"], "n_speeds": len(speeds),
                "max_violation_1_s": ver["max_violation"], "max_gain": ver["max_gain"],
                "gamma_T_frobenius": res["gamma_T"],
                "dense_T_peak": float(np.max(rob["T_inf"])) if rob else float("nan"),
                "n_robust_points": len(self.robust_function()[1]) if use_rob else 0,
                "n_gain_points": len(self.omega_grid()),
                "new_cuts": {"speeds": len(new_speeds), "gain": len(new_gain),
                             "robust": len(new_rob)},
                "eig_time_per_speed_s": res["eig_time_per_speed_s"]})
            peak = float(np.max(rob["T_inf"])) if rob else float("nan")
            kept.append((res, ver, rob, dict(speeds=sorted(speeds), robust_cuts=list(
                self.robust_cuts), gain_cuts=list(self.gain_cuts)), eig_ok and gain_ok, peak))
            if (eig_ok and gain_ok and rob_ok) or not _a2_ok(theta):
                break
            if rnd == s.cutting_plane_rounds or not (new_speeds or new_gain or new_rob):
                break
            speeds.extend(new_speeds)
            self.gain_cuts.extend(new_gain)
            self.robust_cuts.extend(new_rob)
        # a re-solve sees only the sample points and can land on a design whose dense peak
        # (or gain, decay rate) is worse than before the cuts: return the best round --
        # feasible (decay rate and gain) first, then the smallest dense peak of sigma_max(T)
        def rank(i):
            _, _, _, _, ok, pk = kept[i]
            return (not ok, pk if np.isfinite(pk) else np.inf, -i)
        ibest = min(range(len(kept)), key=rank)
        res, ver, rob, cuts, _, _ = kept[ibest]
        for i, h in enumerate(history):
            h["chosen"] = i == ibest
        res = dict(res)
        res["verification"] = ver
        res["rounds"] = history
        res["chosen_round"] = ibest
        res["design_speeds"] = cuts["speeds"]
        res["gain_ok"] = bool(ver["max_gain"] <= s.gain_limit)
        res["robust"] = rob
        res["robust_bound_holds"] = (bool(rob is not None and np.max(rob["T_inf"])
                                          <= res["gamma_T"] * (1.0 + ROBUST_CUT_TOL))
                                     if use_rob else None)
        res["robust_cuts"] = [list(c) for c in cuts["robust_cuts"]]
        res["gain_cuts"] = list(cuts["gain_cuts"])
        return res

    # ---- robustness
    def robust_dense_omega(self, theta, U, weights=None) -> np.ndarray:
        """Dense check frequencies [rad/s] at speed ``U``: 400 log-spaced on 0.01..30 rad/s,
        the structural frequencies and the damped frequencies ``|Im lambda|`` of the closed
        loop in that band (the peaks of ``sigma_max(T)`` sit on its lightly damped poles)."""
        A0, A1, A2, _ = self.A_parts(theta, weights)
        lam = scipy.linalg.eigvals(A0 + U * A1 + U * U * A2)
        wd = np.abs(lam.imag)
        wd = wd[(wd > 1e-2) & (wd < 30.0)]
        return np.unique(np.concatenate([np.logspace(-2, np.log10(30.0), 400),
                                         self.structural_frequencies(), wd]))

    def robust_margin(self, theta, speeds=None, omega=None, weights=None, peaks=1) -> dict:
        """True small-gain margin ``1 / max_U sup_w sigma_max(T(jw))`` on a dense grid.

        ``T = (I - L)^{-1} L``, ``L(jw) = K(jw) G(jw)`` (positive feedback ``beta = K alpha``):
        the transfer from a perturbation ``d`` of the flap inputs (``beta_applied = beta + d``)
        to the controller output; ``sigma_max`` by SVD (not the Frobenius bound of the NLP).
        Default grid: ``robust_speeds_m_s`` x :meth:`robust_dense_omega`; the largest discrete
        local maxima (at least 8, and ``peaks``) are polished by a bounded scalar search
        (:func:`refine_peaks`), so a resonance between grid points is not under-read.
        ``peaks`` gives the ``(omega, sigma_max)`` local peaks per speed returned in ``peaks``.
        """
        s = self.settings
        speeds = np.asarray(s.robust_speeds_m_s if speeds is None else speeds, float)
        w = self.weights if weights is None else np.asarray(weights, float)
        theta = np.asarray(theta, float)
        out_peaks, T_inf, at = [], [], []
        for U in speeds:
            om = (self.robust_dense_omega(theta, float(U), w) if omega is None
                  else np.asarray(omega, float))
            fun = t_sigma_function(self.model, float(U), theta, w)
            pk = refine_peaks(fun, om, fun(om), max(8, int(peaks)))
            out_peaks.append(pk[:max(1, int(peaks))])
            T_inf.append(pk[0][1])
            at.append(pk[0][0])
        T_inf = np.array(T_inf)
        return {"speeds_m_s": speeds, "T_inf": T_inf, "peak_omega_rad_s": np.array(at),
                "peaks": out_peaks,
                "margin": float(1.0 / T_inf.max()) if T_inf.size else float("nan"),
                "norm": "sigma_max (SVD), peaks polished"}


def _worst_per_run(U, bad, viol) -> list[float]:
    """The worst speed in each run of consecutive violations."""
    out, i = [], 0
    while i < len(U):
        if bad[i]:
            j = i
            while j + 1 < len(U) and bad[j + 1]:
                j += 1
            out.append(float(U[i + int(np.argmax(viol[i:j + 1]))]))
            i = j + 1
        else:
            i += 1
    return out


def _a2_ok(theta) -> bool:
    return bool(theta[3] > 0 and theta[4] > 0)


# --------------------------------------------------------------------------- multistart


def sobol_starts(settings: DesignSettings, count: int) -> np.ndarray:
    """Sobol points in the compensator box (b's in [-5, 5], a2, a1 log-uniform) (count, 5)."""
    from scipy.stats import qmc

    m = max(1, int(np.ceil(np.log2(max(count, 1)))))
    pts = qmc.Sobol(5, scramble=True, seed=settings.seed).random_base2(m)[:count]
    lo_a2, hi_a2 = np.log10(0.01), np.log10(1.0)
    lo_a1, hi_a1 = np.log10(0.05), np.log10(3.0)
    th = np.empty((count, 5))
    th[:, :3] = -5.0 + 10.0 * pts[:, :3]
    th[:, 3] = 10 ** (lo_a2 + (hi_a2 - lo_a2) * pts[:, 3])
    th[:, 4] = 10 ** (lo_a1 + (hi_a1 - lo_a1) * pts[:, 4])
    th[:, 0] = np.clip(th[:, 0], -0.5 * settings.gain_limit * th[:, 3],
                       0.5 * settings.gain_limit * th[:, 3])
    return th


def screened_starts(settings: DesignSettings, count: int, model=None) -> np.ndarray:
    """``count`` Sobol starts, the best of ``SCREEN_FACTOR * count`` Sobol candidates.

    Raw Sobol points in the compensator box are mostly far from feasible (positive static
    gain, fast lead) and a start from there can use the whole Ipopt budget (80 iterations,
    ~80 s on 16 modes) to reach a poor local solution. Each candidate is scored by the NLP's
    own merit at the start point: ``weight_robust * gamma_T0 + EIG_SCALE * max(0, max
    violation of the decay-rate constraints)`` (objective plus an exact l-inf penalty on the
    scaled eigenvalue constraints, unit weight) on a 10 m/s speed grid and the robust sample
    points; candidates with ``sup|K| > gain_limit`` are rejected first. Cost: one eig per
    speed and one epigraph evaluation per candidate (~0.2 s on 16 modes).
    """
    if count <= 0:
        return np.empty((0, 5))
    cand = sobol_starts(settings, SCREEN_FACTOR * count)
    if model is None:
        _, model = _build_model(settings)
    prob = DesignProblem(replace(settings, optimise_placement=False), model)
    speeds = np.unique(np.append(np.arange(0.0, settings.speed_max_m_s, 10.0),
                                 settings.speed_max_m_s))
    use_rob = settings.weight_robust > 0 and bool(settings.robust_design_speeds_m_s)
    rob = prob.robust_function()[0] if use_rob else None
    w = np.ones(model.n_flaps)
    scores = []
    for th in cand:
        if Compensator(*(float(v) for v in th)).max_gain() > settings.gain_limit:
            scores.append(np.inf)
            continue
        viol = float(np.max(prob.constraint_values(th, speeds)))
        gam = float(np.sqrt(np.max(np.asarray(rob(th, w).full())))) if rob else 0.0
        sc = settings.weight_robust * gam + EIG_SCALE * max(0.0, viol)
        scores.append(sc if np.isfinite(sc) else np.inf)
    order = np.argsort(np.asarray(scores), kind="stable")
    return cand[order[:count]]


def _build_model(settings: DesignSettings, count=None, modal=None, n_modes=None,
                 positions=None):
    from model.flaps import closed_loop_model
    from model.spec import load_bridge

    spec = load_bridge(settings.bridge)
    pos = settings.positions(count) if positions is None else np.asarray(positions, float)
    return spec, closed_loop_model(spec, pos, settings.flap_width_m,
                                   settings.n_modes if n_modes is None else int(n_modes),
                                   settings.flap_chord_m, settings.leading_edge,
                                   settings.trailing_edge, modal=modal)


def verify_layout(settings: DesignSettings, theta, positions, n_modes=None) -> dict:
    """Dense check of ``theta`` on the layout ``positions`` with ``n_modes`` (default: the
    verification model, ``settings.verification_modes``), as ``bridgeflap flutter`` sees it."""
    nm = settings.verification_modes if n_modes is None else int(n_modes)
    _, model = _build_model(settings, n_modes=nm, positions=positions)
    ver = DesignProblem(replace(settings, optimise_placement=False), model).verify(theta)
    return {k: v for k, v in ver.items() if k not in ("speeds", "abscissa", "violation")} | {
        "meets_decay_rate": bool(ver["max_violation"] <= VIOLATION_TOL),
        "max_abscissa_1_s": float(np.max(ver["abscissa"]))}


def _run_start(args):
    settings, theta0, index = args
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    t0 = time.perf_counter()
    spec, model = _build_model(settings)
    prob = DesignProblem(settings, model, spec=spec)
    record = {"start": index, "theta0": [float(v) for v in theta0]}
    try:
        res = prob.solve_with_cuts(theta0)
        rounds = list(res["rounds"])
        weights = np.ones(model.n_flaps)
        if settings.optimise_placement:
            w_cont = np.asarray(res["weights"], float)
            weights = (w_cont > 0.5).astype(float)
            record["weights_continuous"] = [float(v) for v in w_cont]
            if not weights.any():
                weights[np.argmax(w_cont)] = 1.0
            fixed = DesignProblem(replace(settings, optimise_placement=False), model,
                                  weights=weights, spec=spec)
            res = fixed.solve_with_cuts(res["theta"])
            rounds += [dict(r, placement="rounded") for r in res["rounds"]]
            prob = fixed
    except Exception as exc:  # noqa: BLE001 - solver failure is data (STYLE)
        return record | {"status": f"failed: {exc}", "success": False,
                         "time_s": time.perf_counter() - t0}
    theta = res["theta"]
    ver = res["verification"]
    rob = prob.robust_margin(theta, weights=weights)
    positions = settings.positions()[weights > 0.5]
    ver16 = (verify_layout(settings, theta, positions)
             if settings.verification_modes != settings.n_modes else
             {k: v for k, v in ver.items() if k not in ("speeds", "abscissa", "violation")}
             | {"meets_decay_rate": bool(ver["max_violation"] <= VIOLATION_TOL),
                "max_abscissa_1_s": float(np.max(ver["abscissa"]))})
    meets = bool(ver["max_violation"] <= VIOLATION_TOL)
    gain_ok = bool(ver["max_gain"] <= settings.gain_limit)
    dense_peak = (float(np.max(res["robust"]["T_inf"])) if res.get("robust") is not None
                  else float("nan"))
    return record | {
        "theta": [float(v) for v in theta], "status": res["status"], "success": res["success"],
        "iterations": sum(r["iterations"] for r in rounds),
        "time_s": time.perf_counter() - t0, "rounds": rounds, "cut_rounds": len(rounds) - 1,
        "max_violation_1_s": ver["max_violation"], "stable_to_m_s": ver["stable_to_m_s"],
        "stable_everywhere": ver["stable_everywhere"], "max_gain": ver["max_gain"],
        "meets_decay_rate": meets, "gain_ok": gain_ok,
        # verified: every a posteriori check holds, whatever Ipopt's exit status
        "verified": bool(meets and gain_ok and ver16.get("stable_everywhere")),
        "gamma_T_frobenius": res["gamma_T"],
        "dense_T_peak_check_speeds": dense_peak,
        "robust_bound_holds": res["robust_bound_holds"],
        "robust_margin": rob["margin"],
        "robust_T_inf_by_speed": {f"{u:g}": float(t) for u, t in
                                  zip(rob["speeds_m_s"], rob["T_inf"], strict=True)},
        "robust_peak_omega_by_speed": {f"{u:g}": float(o) for u, o in
                                       zip(rob["speeds_m_s"], rob["peak_omega_rad_s"],
                                           strict=True)},
        "robust_cuts": res["robust_cuts"], "gain_cuts": res["gain_cuts"],
        "flap_positions_m": [float(x) for x in positions],
        "verification": ver16, "design_speeds": res["design_speeds"]}


def _start_row(r: dict, chosen: bool) -> dict:
    """One row of the start table (``summary()["start_table"]``)."""
    return {"start": r.get("start"), "status": r.get("status"),
            "iterations": r.get("iterations", 0), "cut_rounds": r.get("cut_rounds", 0),
            "time_s": r.get("time_s", float("nan")),
            "robust_margin": r.get("robust_margin", float("nan")),
            "gamma_T_frobenius": r.get("gamma_T_frobenius", float("nan")),
            "max_gain": r.get("max_gain", float("nan")),
            "verified": bool(r.get("verified", False)), "chosen": bool(chosen)}


@dataclass(frozen=True)
class DesignResult:
    """Outcome of :func:`design` (status, chosen controller, per-start records)."""

    status: str
    settings: DesignSettings
    controller: Controller | None
    starts: tuple
    best: dict
    abscissa_speeds: np.ndarray
    abscissa: np.ndarray
    min_flaps: dict
    wall_time_s: float
    extras: dict = field(default_factory=dict, compare=False)

    def summary(self) -> dict:
        """JSON-ready summary (the ``bridgeflap optimise`` contract)."""
        k = self.controller.compensator if self.controller else None
        coeffs = ({n: getattr(k, n) for n in THETA_NAMES} if k else
                  {n: float("nan") for n in THETA_NAMES})
        return {
            "status": self.status,
            "coefficients": coeffs,
            "flap_count": self.controller.n_flaps if self.controller else 0,
            "max_gain": self.best.get("max_gain", float("nan")),
            "gain_limit": self.settings.gain_limit,
            "robust_margin": self.best.get("robust_margin", float("nan")),
            "robust_margin_definition": "1 / max over robust_speeds_m_s and a dense frequency "
                                        "grid of sigma_max(T(jw)), T the input complementary "
                                        "sensitivity of the flap loop (small-gain theorem)",
            "robust_T_inf_by_speed": self.best.get("robust_T_inf_by_speed", {}),
            "gamma_T_frobenius": self.best.get("gamma_T_frobenius", float("nan")),
            "closed_loop_stable_to_m_s": self.best.get("stable_to_m_s", float("nan")),
            "design_modes": self.settings.n_modes,
            "verification": self.best.get("verification", {}),
            "flap_positions_m": self.best.get("flap_positions_m", []),
            "buffeting": self.extras.get("buffeting", {}),
            "sigma_min_1_s": self.settings.sigma_min_1_s,
            "spectral_abscissa_by_speed": [
                {"speed_m_s": float(u), "abscissa_1_s": float(a)}
                for u, a in zip(self.abscissa_speeds, self.abscissa, strict=True)],
            "chosen_start": self.best.get("start"),
            "start_table": [_start_row(s, s.get("start") == self.best.get("start"))
                            for s in self.starts],
            "dense_T_peak": (1.0 / self.best["robust_margin"]
                             if self.best.get("robust_margin") else float("nan")),
            "robust_bound_holds": self.best.get("robust_bound_holds"),
            "starts": [{k2: v for k2, v in s.items() if k2 != "design_speeds"}
                       for s in self.starts],
            "minimum_flaps": self.min_flaps,
            "wall_time_s": self.wall_time_s,
            "settings": {k2: v for k2, v in asdict(self.settings).items() if k2 != "extras"},
        }

    def plot_bode(self, ax=None):
        """|K(jw)| and phase of the designed compensator with the gain limit."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(2, 1, figsize=(6, 5), sharex=True)
        k = self.controller.compensator
        w = np.logspace(-3, 2, 600)
        K = k.frequency_response(w)
        ax[0].loglog(w, np.abs(K), "b-")
        ax[0].axhline(self.settings.gain_limit, color="r", ls="--", label="gain limit")
        ax[0].set_ylabel("|K(jw)| [rad/rad]")
        ax[0].legend()
        ax[1].semilogx(w, np.degrees(np.angle(K)), "b-")
        ax[1].set_ylabel("phase [deg]")
        ax[1].set_xlabel("omega [rad/s]")
        for a_ in ax:
            a_.grid(alpha=0.3, which="both")
        ax[0].set_title("designed compensator K(s)")
        return ax

    def plot_margins(self, ax=None):
        """Spectral abscissa against speed with the required decay rate, and the layout."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(1, 2, figsize=(11, 4))
        ax[0].plot(self.abscissa_speeds, self.abscissa, "b-", label="closed loop")
        ol = self.extras.get("open_loop_abscissa")
        if ol is not None:
            ax[0].plot(self.abscissa_speeds, ol, "k--", label="open loop")
        ax[0].plot(self.abscissa_speeds, -self.settings.sigma_required(self.abscissa_speeds),
                   "r:", label="-sigma_req")
        ax[0].axhline(0, color="k", lw=0.7)
        ax[0].set_xlabel("U [m/s]")
        ax[0].set_ylabel("max Re lambda [1/s]")
        ax[0].legend()
        ax[0].grid(alpha=0.3)
        pos = np.asarray(self.controller.flap_strip_positions_m)
        w = self.controller.flap_width_m
        for x in pos:
            ax[1].add_patch(plt.Rectangle((x - w / 2, -0.5), w, 1.0, color="tab:blue", alpha=0.6))
        ax[1].set_xlim(-705, 705)
        ax[1].set_ylim(-1, 1)
        ax[1].set_xlabel("x from main-span mid-point [m]")
        ax[1].set_yticks([])
        ax[1].set_title(f"flap layout: {len(pos)} LE+TE flap pairs")
        return ax


def minimum_flap_count(settings: DesignSettings, theta, counts=None, modal=None) -> dict:
    """Fewest evenly spaced flaps (around mid-span) still stable 0..U_max with the margin.

    The optimised ``theta`` is kept; each count is verified on the dense grid with the
    required decay rate ``sigma_req`` on the verification model (``verification_modes``).
    Returns the records per count and the minimum.
    """
    counts = settings.min_flap_counts if counts is None else counts
    rows = []
    best = None
    for c in counts:
        if c > settings.flap_count:
            continue
        _, model = _build_model(settings, c, modal, n_modes=settings.verification_modes)
        prob = DesignProblem(replace(settings, optimise_placement=False), model)
        ver = prob.verify(theta)
        ok = ver["max_violation"] <= VIOLATION_TOL
        rows.append({"flap_count": int(c), "meets_margin": ok,
                     "stable_everywhere": ver["stable_everywhere"],
                     "stable_to_m_s": ver["stable_to_m_s"],
                     "max_violation_1_s": ver["max_violation"]})
        if ok:
            best = int(c) if best is None else min(best, int(c))
    return {"minimum": best, "counts": rows, "modes": settings.verification_modes,
            "criterion": "max Re lambda <= -sigma_req(U) on the dense grid, same K(s)"}


def buffeting_comparison(settings: DesignSettings, controller: Controller, speeds=None) -> dict:
    """Open- vs closed-loop max RMS response (``model.buffeting``, verification model)."""
    from model.buffeting import buffeting
    from model.spec import load_bridge

    spec = load_bridge(settings.bridge)
    speeds = np.asarray(settings.buffeting_speeds_m_s if speeds is None else speeds, float)
    nm = settings.verification_modes
    ol = buffeting(spec, speeds, n_modes=nm)
    cl = buffeting(spec, speeds, n_modes=nm, controller=controller)
    return {"speeds_m_s": speeds.tolist(), "modes": nm,
            "open_loop_rms_vertical_m": ol.rms_vertical.tolist(),
            "closed_loop_rms_vertical_m": cl.rms_vertical.tolist(),
            "open_loop_rms_torsion_rad": ol.rms_torsion.tolist(),
            "closed_loop_rms_torsion_rad": cl.rms_torsion.tolist()}


def select_start(records, gain_limit) -> tuple[dict, str]:
    """Chosen start and design status from the per-start records of :func:`_run_start`.

    ``converged``: the best *verified* start (decay rate on the design model's dense grid,
    true peak gain ``max_gain <= gain_limit`` -- no tolerance, the NLP backs off by
    ``GAIN_BACKOFF`` --, stable on the verification model), by the true dense robust margin,
    whatever its Ipopt exit status; ``unverified``: feasible on the design model only;
    ``infeasible``: no start meets the decay rate and the gain limit (the least violating is
    reported, never as converged); ``failed``: no start produced a design.
    """
    feasible = [r for r in records if r.get("meets_decay_rate")
                and r.get("max_gain", np.inf) <= gain_limit]
    verified = [r for r in feasible if r.get("verified")]
    if verified:
        return max(verified, key=lambda r: r["robust_margin"]), "converged"
    if feasible:
        return max(feasible, key=lambda r: r["verification"].get("stable_to_m_s", 0.0)), \
            "unverified"
    cands = [r for r in records if "theta" in r]
    if not cands:
        return {}, "failed"
    return min(cands, key=lambda r: (max(r["max_violation_1_s"], 0.0),
                                     r.get("max_gain", np.inf))), "infeasible"


def design(settings: DesignSettings, progress=None) -> DesignResult:
    """Multistart design with cutting planes, 16-mode verification and flap-count search.

    Status: ``converged`` (a start meets the decay rate on the design model's dense grid, the
    gain limit, and is stable on the verification model's dense grid), ``unverified`` (the
    design model is satisfied but the verification model is not stable everywhere -- only
    possible with a reduced design model), ``infeasible`` or ``failed``.
    """
    t0 = time.perf_counter()
    log = progress or (lambda msg: None)
    # start 0 is a nominal phase-lead-free design (K ~ -1 static, light lag), the others Sobol
    starts0 = np.vstack([NOMINAL_START, screened_starts(settings, settings.starts - 1)])[
        :settings.starts]
    jobs = [(settings, th, i) for i, th in enumerate(starts0)]
    if settings.parallel and settings.starts > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(max_workers=min(2, settings.starts)) as ex:
            records = list(ex.map(_run_start, jobs))
    else:
        records = [_run_start(job) for job in jobs]
    for r in records:
        log(f"start {r['start']}: {r['status']} in {r.get('time_s', 0):.1f} s, "
            f"{r.get('iterations', 0)} iterations, {r.get('cut_rounds', 0)} cut rounds, "
            f"violation {r.get('max_violation_1_s', float('nan')):.2e}, max gain "
            f"{r.get('max_gain', float('nan')):.4g}, margin "
            f"{r.get('robust_margin', float('nan')):.3g} (gamma_T "
            f"{r.get('gamma_T_frobenius', float('nan')):.3g}), "
            f"{settings.verification_modes}-mode check stable: "
            f"{r.get('verification', {}).get('stable_everywhere')}, verified: "
            f"{r.get('verified', False)}")
    best, status = select_start(records, settings.gain_limit)
    controller = None
    absc_u = settings.check_speeds()
    absc = np.full(absc_u.shape, np.nan)
    extras = {}
    min_flaps = {"minimum": None, "counts": []}
    if "theta" in best:
        theta = np.asarray(best["theta"])
        positions = np.asarray(best["flap_positions_m"])
        spec, model = _build_model(settings, n_modes=settings.verification_modes,
                                   positions=positions)
        prob = DesignProblem(replace(settings, optimise_placement=False), model)
        absc = prob.verify(theta)["abscissa"]
        _, model_ol = _build_model(settings, n_modes=settings.verification_modes)
        ol_parts = DesignProblem(settings, model_ol).A_parts(np.array([0.0, 0.0, 0.0, 1.0, 1.0]))
        extras["open_loop_abscissa"] = closed_loop_abscissa(ol_parts, absc_u)
        extras["closed_loop"] = model.system(Compensator(*(float(v) for v in theta)))
        controller = Controller(Compensator(*(float(v) for v in theta)),
                                tuple(float(x) for x in positions),
                                settings.flap_width_m, settings.leading_edge,
                                settings.trailing_edge, settings.gain_limit)
        if status in ("converged", "unverified"):
            min_flaps = minimum_flap_count(settings, theta)
            log(f"minimum flap count: {min_flaps['minimum']}")
            try:
                extras["buffeting"] = buffeting_comparison(settings, controller)
            except Exception as exc:  # noqa: BLE001 - a report item, not the design
                extras["buffeting"] = {"status": f"failed: {exc}"}
    return DesignResult(status=status, settings=settings, controller=controller,
                        starts=tuple(records), best=best, abscissa_speeds=absc_u,
                        abscissa=absc, min_flaps=min_flaps,
                        wall_time_s=time.perf_counter() - t0, extras=extras)


def quick_settings(settings: DesignSettings) -> DesignSettings:
    """Reduced settings for CI/--quick: one start, coarser design grid, one cut round,
    fewer flap counts.

    The design model keeps its modes (a design on 8 modes flutters at 79.75 m/s on the
    16-mode model); the dense verification on ``verification_modes`` is unchanged and the
    status says whether it holds.
    """
    return replace(settings, starts=1, design_step_m_s=max(settings.design_step_m_s, 10.0),
                   cutting_plane_rounds=1, min_flap_counts=(25, 13, 5))
