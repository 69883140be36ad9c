"""Flap compensator design: Ipopt over K(s) with spectral-abscissa constraints (seed §6).

Problem (METHODS §4-5)::

    minimise     gamma + w_reg |theta / theta_scale|^2 + w_buffeting * RMS(theta)   (hook)
    over         theta = (b2, b1, b0, a2, a1), gamma
    subject to   top-m Re lambda(A_cl(U_i, theta)) <= -sigma_req(U_i)   at every design speed
                 |K(j omega_k)|^2 <= gamma^2  on a frequency grid,  gamma <= gain_limit
                 a2 >= a2_min > 0,  a1 >= a1_min > 0                (stable, proper K)

``sigma_req(U) = min(sigma_min, sigma_per_speed * U)``: the slowest aerodynamic lag pole of the
RFA moves as ``-beta_1 U / b`` and is (almost) uncontrollable by the flaps, so a fixed decay rate
cannot be demanded at low speed. At ``U = 0`` the lag states are exactly decoupled (their
input is proportional to ``U``), their zero eigenvalues are dropped, and the structural ones
must satisfy ``sigma_min``.

Minimising the peak gain ``gamma`` gives the smallest compensator that achieves the decay
rate: a robustness proxy. The small-gain margin ``1/||T||_inf`` (T the input complementary
sensitivity of the flap loop) is computed for every converged start and the start with the
largest margin is chosen among the feasible ones (robustness maximised by selection).
The eigenvalue constraints use :class:`design.eigen.TopRealParts` (analytic eigenvalue
Jacobians, limited-memory Hessian). Every solution is verified a posteriori on a dense speed
grid; violating speeds are added to the design grid and the problem re-solved (cutting
planes). The peak gain is verified with :meth:`model.control.Compensator.max_gain`.
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

from design.eigen import TopRealParts
from model.control import Compensator, Controller
from model.errors import BridgeflapInputError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

THETA_NAMES = ("b2", "b1", "b0", "a2", "a1")


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
    n_modes: int = 12
    flap_count: int = 25
    flap_width_m: float = 56.4          # spanwise length of each flap: 1410 m / 25
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
    weight_regularisation: float = 1e-3
    weight_buffeting: float = 0.0
    starts: int = 2
    seed: int = 1
    parallel: bool = False
    max_iter: int = 150
    cutting_plane_rounds: int = 3
    b_bound: float = 15.0
    a2_bounds: tuple = (1e-3, 5.0)
    a1_bounds: tuple = (1e-2, 10.0)
    min_flap_counts: tuple = (25, 21, 17, 13, 9, 7, 5, 3, 1)
    robust_speeds_m_s: tuple = (20.0, 40.0, 60.0, 70.0, 80.0, 85.0)
    extras: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        """Validate (one field named per error)."""
        _num("gain_limit", self.gain_limit, positive=True)
        for name in ("flap_width_m", "flap_chord_m", "speed_max_m_s", "design_step_m_s",
                     "check_step_m_s", "omega_min_rad_s", "omega_max_rad_s"):
            _num(name, getattr(self, name), positive=True)
        for name in ("sigma_min_1_s", "sigma_per_speed_1_m", "weight_regularisation",
                     "weight_buffeting"):
            _num(name, getattr(self, name), nonneg=True)
        for name in ("n_modes", "flap_count", "n_eig", "n_omega", "starts", "max_iter"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise BridgeflapInputError(name, f"must be a positive integer, got {v!r}")
        if self.omega_max_rad_s <= self.omega_min_rad_s:
            raise BridgeflapInputError("omega_max_rad_s", "must exceed omega_min_rad_s")
        if self.a2_bounds[0] <= 0 or self.a1_bounds[0] <= 0:
            raise BridgeflapInputError("a2_bounds", "lower bounds of a2 and a1 must be > 0 "
                                                    "(stable, proper compensator)")
        if not (self.leading_edge or self.trailing_edge):
            raise BridgeflapInputError("trailing_edge", "no flap fitted")

    def positions(self, count: int | None = None) -> np.ndarray:
        """Evenly spaced flap centres from the main-span mid-point [m] (touching strips)."""
        count = self.flap_count if count is None else int(count)
        # pitch a hair above the width so touching strips pass Controller's overlap check
        offsets = (np.arange(count) - 0.5 * (count - 1)) * self.flap_width_m * (1 + 1e-12)
        return offsets

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
    for key in ("a2_bounds", "a1_bounds", "min_flap_counts", "robust_speeds_m_s"):
        if key in flat:
            flat[key] = tuple(flat[key])
    return DesignSettings(**flat)


# --------------------------------------------------------------------------- eigen callback


class _TopRealPartsFast(TopRealParts):
    """:class:`TopRealParts` whose Jacobian contracts only the selected eigenvectors.

    Same formula (``w^H dA v / w^H v``); falls back to the parent (finite differences) for
    nearly defective eigenvalues.
    """

    def jacobian(self, p):
        p = np.asarray(p, dtype=float).ravel()
        key = p.tobytes()
        if key == self._cache_key:
            return self._cache.copy()
        A = self.matrix(p)
        lam, vl, vr = scipy.linalg.eig(A, left=True, right=True)
        idx = self._order(lam)
        dA = np.asarray(self._dA_fun(ca.DM(p)).full()).reshape(
            (self._n, self._n, self._n_p), order="F")
        wl, vv = vl[:, idx], vr[:, idx]
        whv = np.einsum("ai,ai->i", wl.conj(), vv)
        cond = np.abs(whv) / (np.linalg.norm(wl, axis=0) * np.linalg.norm(vv, axis=0))
        if np.any(cond < self.defect_tol) or not np.all(np.isfinite(A)):
            return super().jacobian(p)
        J = np.empty((self.m, self._n_p))
        for k in range(self._n_p):
            J[:, k] = (np.einsum("ai,ai->i", wl.conj(), dA[:, :, k] @ vv) / whv).real
        self.last_fd_rows = ()
        self._cache_key, self._cache = key, J.copy()
        return J


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
        out.append(np.max(np.linalg.eigvals(A).real))
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
    """Compensator NLP for a fixed flap layout (build once, solve from many starts).

    Parameters
    ----------
    settings : DesignSettings
    model : model.flaps.ClosedLoopModel
    weights : array_like, optional
        Per-flap weights [0, 1] (1 = fitted).
    """

    def __init__(self, settings: DesignSettings, model, weights=None):
        self.settings = settings
        self.model = model
        self.weights = (np.ones(model.n_flaps) if weights is None
                        else np.asarray(weights, float).ravel())
        self.functions = model.casadi_functions()
        self.keep0 = _lag_free_indices(model)
        self.callbacks: dict[float, TopRealParts] = {}   # kept alive (design.eigen docstring)
        self.evaluations = 0
        self.eval_time = 0.0

    # ---- pieces
    def callback(self, U: float) -> TopRealParts:
        """TopRealParts of ``A_cl(U, theta)`` (lag states dropped at U = 0), cached per speed."""
        U = float(U)
        if U not in self.callbacks:
            p = ca.MX.sym("p", 5)
            A = self.functions["A_cl"](U, p, ca.DM(self.weights))
            if U == 0.0:
                k = [int(i) for i in self.keep0]
                A = A[k, k]
            A_fun = ca.Function(f"A_{U:g}".replace(".", "p"), [p], [A])
            self.callbacks[U] = _TopRealPartsFast(A_fun, self.settings.n_eig,
                                                  name=f"top_{U:g}".replace(".", "p"))
        return self.callbacks[U]

    def A_parts(self, theta) -> tuple:
        """Numeric ``(A0, A1, A2, keep0)`` of the closed loop at ``theta``."""
        A0, A1, A2 = self.functions["A_parts"](ca.DM(theta), ca.DM(self.weights))
        return A0.full(), A1.full(), A2.full(), self.keep0

    def omega_grid(self) -> np.ndarray:
        """Frequency grid of the gain constraint [rad/s]."""
        s = self.settings
        return np.logspace(np.log10(s.omega_min_rad_s), np.log10(s.omega_max_rad_s), s.n_omega)

    def constraint_values(self, theta, speeds) -> np.ndarray:
        """``top_m Re lambda + sigma_req`` per speed (n_speeds, m) [1/s]; <= 0 is feasible."""
        parts = self.A_parts(theta)
        sig = self.settings.sigma_required(speeds)
        return np.array([top_real_parts_numeric(parts, u, self.settings.n_eig) + sg
                         for u, sg in zip(speeds, sig, strict=True)])

    # ---- one solve
    def solve(self, theta0, speeds, max_iter=None) -> dict:
        """Solve the NLP from ``theta0`` on the design ``speeds`` [m/s].

        Returns a dict with ``theta``, ``gamma``, ``status`` (Ipopt return status),
        ``success``, ``iterations``, ``time_s``, ``objective``.
        """
        s = self.settings
        th = ca.MX.sym("theta", 5)
        gam = ca.MX.sym("gamma")
        x = ca.vertcat(th, gam)
        scale_eig = 100.0      # [s]: eigenvalue constraints ~ 0.01 1/s -> O(1)
        g, lbg, ubg = [], [], []
        for u, sg in zip(speeds, s.sigma_required(speeds), strict=True):
            g.append(scale_eig * (self.callback(u)(th) + sg))
            lbg.append(-np.inf * np.ones(s.n_eig))
            ubg.append(np.zeros(s.n_eig))
        b2, b1, b0, a2, a1 = (th[i] for i in range(5))
        for w in self.omega_grid():
            nr, ni = b0 - b2 * w * w, b1 * w
            dr, di = 1 - a2 * w * w, a1 * w
            g.append((nr * nr + ni * ni) / (dr * dr + di * di) / s.gain_limit**2
                     - gam * gam / s.gain_limit**2)
            lbg.append([-np.inf])
            ubg.append([0.0])
        g.append((b2 * b2 - gam * gam * a2 * a2) / s.gain_limit**2)   # omega -> inf
        lbg.append([-np.inf])
        ubg.append([0.0])
        scale = np.array([1.0, 1.0, 1.0, 0.1, 1.0])
        f = gam / s.gain_limit + s.weight_regularisation * ca.sumsqr(th / scale)
        # buffeting hook: weight_buffeting * RMS (model.buffeting) -- see module docstring
        lbx = [-s.b_bound, -s.b_bound, -s.b_bound, s.a2_bounds[0], s.a1_bounds[0], 0.0]
        ubx = [s.b_bound, s.b_bound, s.b_bound, s.a2_bounds[1], s.a1_bounds[1], s.gain_limit]
        nlp = {"x": x, "f": f, "g": ca.vertcat(*g)}
        opts = {"ipopt.hessian_approximation": "limited-memory",
                "ipopt.max_iter": int(max_iter or s.max_iter), "ipopt.print_level": 0,
                "print_time": False, "ipopt.tol": 1e-6, "ipopt.acceptable_tol": 1e-4,
                "ipopt.sb": "yes", "ipopt.constr_viol_tol": 1e-6}
        solver = ca.nlpsol("design", "ipopt", nlp, opts)
        theta0 = np.asarray(theta0, float)
        gam0 = min(s.gain_limit, Compensator(*theta0).max_gain())
        t0 = time.perf_counter()
        sol = solver(x0=np.append(theta0, gam0), lbx=lbx, ubx=ubx,
                     lbg=np.concatenate(lbg), ubg=np.concatenate(ubg))
        elapsed = time.perf_counter() - t0
        st = solver.stats()
        xs = np.asarray(sol["x"].full()).ravel()
        n_eig_cons = len(speeds) * s.n_eig
        return {"theta": xs[:5], "gamma": float(xs[5]), "status": st["return_status"],
                "success": bool(st["success"]), "iterations": int(st["iter_count"]),
                "time_s": elapsed, "objective": float(sol["f"]),
                "constraints_eig": np.asarray(sol["g"].full()).ravel()[:n_eig_cons]
                / scale_eig,
                "n_speeds": len(speeds)}

    # ---- verification
    def verify(self, theta) -> dict:
        """Dense a posteriori check: abscissa on the check grid, constraint, peak gain."""
        s = self.settings
        U = s.check_speeds()
        parts = self.A_parts(theta)
        absc = closed_loop_abscissa(parts, U)
        viol = absc + s.sigma_required(U)
        comp = Compensator(*(float(v) for v in theta))
        stable = absc < 0
        stable_to = float(U[-1]) if stable.all() else (
            float(U[np.argmax(~stable) - 1]) if np.argmax(~stable) > 0 else 0.0)
        return {"speeds": U, "abscissa": absc, "violation": viol,
                "max_violation": float(viol.max()), "stable_everywhere": bool(stable.all()),
                "stable_to_m_s": stable_to, "max_gain": comp.max_gain()}

    def solve_with_cuts(self, theta0) -> dict:
        """Solve, verify densely, add violating speeds, re-solve (cutting planes)."""
        s = self.settings
        speeds = list(self.settings.design_speeds())
        history = []
        theta = np.asarray(theta0, float)
        res = None
        for rnd in range(s.cutting_plane_rounds + 1):
            res = self.solve(theta, np.array(sorted(speeds)))
            theta = res["theta"]
            ver = self.verify(theta)
            history.append({"round": rnd, "status": res["status"], "iterations": res["iterations"],
                            "time_s": res["time_s"], "n_speeds": len(speeds),
                            "max_violation_1_s": ver["max_violation"]})
            if ver["max_violation"] <= 1e-6 or not _a2_ok(theta):
                break
            # worst violating speed in each run of consecutive violations
            bad = ver["violation"] > 1e-6
            Ub = ver["speeds"]
            new = []
            i = 0
            while i < len(Ub):
                if bad[i]:
                    j = i
                    while j + 1 < len(Ub) and bad[j + 1]:
                        j += 1
                    k = i + int(np.argmax(ver["violation"][i:j + 1]))
                    new.append(float(Ub[k]))
                    i = j + 1
                else:
                    i += 1
            new = [u for u in new if u not in speeds]
            if not new:
                break
            speeds.extend(new)
        res = dict(res)
        res["verification"] = ver
        res["rounds"] = history
        res["design_speeds"] = sorted(speeds)
        return res

    # ---- robustness
    def robust_margin(self, theta, speeds=None, omega=None) -> dict:
        """Small-gain multiplicative margin ``1 / max_U ||T(j w)||_inf`` at the flap inputs.

        ``T = (I - L)^{-1} L`` with ``L(jw) = K(jw) G(jw)``, ``G`` the map from the flap drive
        angles to the deck pitch at the flaps (positive feedback ``beta = K alpha``),
        evaluated from the closed-loop state space: ``T`` is the transfer from an input
        perturbation ``d`` (``beta_applied = beta + d``) to the controller output ``beta``.
        The perturbation enters through the plant's ``beta, beta', beta''`` channels, so it is
        computed as ``T = -(I - L)^{-1} L`` with ``L`` from the open-loop frequency response.
        """
        s = self.settings
        speeds = np.asarray(s.robust_speeds_m_s if speeds is None else speeds, float)
        omega = np.logspace(-2, 1.5, 300) if omega is None else np.asarray(omega, float)
        comp = Compensator(*(float(v) for v in theta))
        K = comp.frequency_response(omega)
        peaks = []
        for U in speeds:
            G = plant_frequency_response(self.model, U, omega, self.weights)
            peak = 0.0
            for i in range(len(omega)):
                L = K[i] * G[i]
                T = np.linalg.solve(np.eye(L.shape[0]) - L, L)
                peak = max(peak, float(np.linalg.norm(T, 2)))
            peaks.append(peak)
        peaks = np.array(peaks)
        return {"speeds_m_s": speeds, "T_inf": peaks,
                "margin": float(1.0 / peaks.max()) if peaks.size else float("nan")}


def _a2_ok(theta) -> bool:
    return bool(theta[3] > 0 and theta[4] > 0)


def plant_frequency_response(model, U, omega, weights=None) -> np.ndarray:
    """``G(jw)``: flap drive angles -> deck pitch at the flaps, RFA aerodynamics [rad/rad].

    Open-loop generalised equation with the flap loads as inputs, C(k) from the same RFA as
    the state space; shape (n_omega, n_flap, n_flap).
    """
    ol, fl = model.open_loop, model.flaps
    B, a, rfa = ol.basis, ol.aero, ol.rfa
    b, rho = a.half_chord, a.air_density
    w = np.ones(fl.n_flaps) if weights is None else np.asarray(weights, float)
    sc = fl.width_m * w
    ld = fl.loads
    Hk = [(fl.phi_h.T * e[0] + fl.phi_a.T * e[1]) * sc for e in (ld.e0, ld.e1, ld.e2)]
    PF = (-2 * np.pi * rho * b * fl.phi_h.T + np.pi * rho * b * b * fl.phi_a.T) * sc
    out = np.zeros((len(omega), fl.n_flaps, fl.n_flaps), complex)
    Mt = B.M + a.M_nc
    for i, om in enumerate(omega):
        p = 1j * om
        sbar = p * b / U if U > 0 else 0.0
        C = 1.0 - np.sum(rfa.gains * sbar / (sbar + rfa.poles)) if U > 0 else 1.0
        D = p * p * Mt + p * (B.C + U * a.D_nc) + B.K - U * C * a.P @ (p * a.G1 + U * a.G0)
        F = p * p * Hk[2] + U * p * Hk[1] + U * U * Hk[0] + U * C * PF * (U * ld.g0
                                                                          + b * ld.g1 * p)
        out[i] = fl.phi_a @ np.linalg.solve(D, F)
    return out


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


def _build_model(settings: DesignSettings, count=None, modal=None):
    from model.flaps import closed_loop_model
    from model.spec import load_bridge

    spec = load_bridge(settings.bridge)
    return spec, closed_loop_model(spec, settings.positions(count), settings.flap_width_m,
                                   settings.n_modes, settings.flap_chord_m,
                                   settings.leading_edge, settings.trailing_edge, modal=modal)


def _run_start(args):
    settings, theta0, index = args
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    _, model = _build_model(settings)
    prob = DesignProblem(settings, model)
    t0 = time.perf_counter()
    try:
        res = prob.solve_with_cuts(theta0)
    except Exception as exc:  # noqa: BLE001 - solver failure is data (STYLE)
        return {"start": index, "theta0": list(theta0), "status": f"failed: {exc}",
                "success": False, "time_s": time.perf_counter() - t0}
    ver = res["verification"]
    rob = prob.robust_margin(res["theta"])
    return {"start": index, "theta0": [float(v) for v in theta0],
            "theta": [float(v) for v in res["theta"]], "status": res["status"],
            "success": res["success"], "iterations": sum(r["iterations"] for r in res["rounds"]),
            "time_s": time.perf_counter() - t0, "rounds": res["rounds"],
            "max_violation_1_s": ver["max_violation"], "stable_to_m_s": ver["stable_to_m_s"],
            "stable_everywhere": ver["stable_everywhere"], "max_gain": ver["max_gain"],
            "robust_margin": rob["margin"], "evaluations": prob.evaluations,
            "design_speeds": res["design_speeds"]}


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
            "closed_loop_stable_to_m_s": self.best.get("stable_to_m_s", float("nan")),
            "sigma_min_1_s": self.settings.sigma_min_1_s,
            "spectral_abscissa_by_speed": [
                {"speed_m_s": float(u), "abscissa_1_s": float(a)}
                for u, a in zip(self.abscissa_speeds, self.abscissa, strict=True)],
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
    required decay rate ``sigma_req``. Returns the records per count and the minimum.
    """
    counts = settings.min_flap_counts if counts is None else counts
    rows = []
    best = None
    for c in counts:
        if c > settings.flap_count:
            continue
        _, model = _build_model(settings, c, modal)
        prob = DesignProblem(settings, model)
        ver = prob.verify(theta)
        ok = ver["max_violation"] <= 1e-9
        rows.append({"flap_count": int(c), "meets_margin": ok,
                     "stable_everywhere": ver["stable_everywhere"],
                     "stable_to_m_s": ver["stable_to_m_s"],
                     "max_violation_1_s": ver["max_violation"]})
        if ok:
            best = int(c)
    return {"minimum": best, "counts": rows,
            "criterion": "max Re lambda <= -sigma_req(U) on the dense grid, same K(s)"}


def design(settings: DesignSettings, progress=None) -> DesignResult:
    """Multistart compensator design with cutting planes, verification and flap-count search."""
    t0 = time.perf_counter()
    log = progress or (lambda msg: None)
    starts0 = sobol_starts(settings, settings.starts)
    jobs = [(settings, th, i) for i, th in enumerate(starts0)]
    if settings.parallel and settings.starts > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(max_workers=min(2, settings.starts)) as ex:
            records = list(ex.map(_run_start, jobs))
    else:
        records = []
        for job in jobs:
            r = _run_start(job)
            log(f"start {r['start']}: {r['status']} in {r.get('time_s', 0):.1f} s, "
                f"violation {r.get('max_violation_1_s', float('nan')):.2e}, "
                f"margin {r.get('robust_margin', float('nan')):.3g}")
            records.append(r)
    feasible = [r for r in records if r.get("max_violation_1_s", np.inf) <= 1e-6
                and r.get("max_gain", np.inf) <= settings.gain_limit * (1 + 1e-6)]
    if feasible:
        best = max(feasible, key=lambda r: r["robust_margin"])
        status = "converged"
    else:
        cands = [r for r in records if "theta" in r]
        best = min(cands, key=lambda r: r["max_violation_1_s"]) if cands else {}
        status = "infeasible" if cands else "failed"
    controller = None
    absc_u = settings.check_speeds()
    absc = np.full(absc_u.shape, np.nan)
    extras = {}
    min_flaps = {"minimum": None, "counts": []}
    if "theta" in best:
        spec, model = _build_model(settings)
        prob = DesignProblem(settings, model)
        theta = np.asarray(best["theta"])
        ver = prob.verify(theta)
        absc = ver["abscissa"]
        ol_parts = prob.A_parts(np.array([0.0, 0.0, 0.0, 1.0, 1.0]))
        extras["open_loop_abscissa"] = closed_loop_abscissa(ol_parts, absc_u)
        controller = Controller(Compensator(*(float(v) for v in theta)),
                                tuple(float(x) for x in settings.positions()),
                                settings.flap_width_m, settings.leading_edge,
                                settings.trailing_edge, settings.gain_limit)
        if status == "converged":
            min_flaps = minimum_flap_count(settings, theta)
            log(f"minimum flap count: {min_flaps['minimum']}")
    return DesignResult(status=status, settings=settings, controller=controller,
                        starts=tuple(records), best=best, abscissa_speeds=absc_u,
                        abscissa=absc, min_flaps=min_flaps,
                        wall_time_s=time.perf_counter() - t0, extras=extras)


def quick_settings(settings: DesignSettings) -> DesignSettings:
    """Reduced settings for CI/--quick: fewer modes, starts, coarser check grid."""
    return replace(settings, n_modes=min(settings.n_modes, 8), starts=1,
                   check_step_m_s=1.0, design_step_m_s=max(settings.design_step_m_s, 10.0),
                   cutting_plane_rounds=2, min_flap_counts=(25, 13, 5))
