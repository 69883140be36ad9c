"""Stability over a wind-speed grid: eigenvalue sweep, branch tracking, flutter and divergence.

Method (docs/methods.md#stability):

* at every grid speed all eigenvalues of ``A(U)`` (dense ``eig``);
* structural branches are tracked from ``U = 0`` by linear assignment on the distance to a
  linear prediction from the two previous speeds (eigenvalues only: eigenvectors cost ten
  times more), and each branch keeps the label of its structural mode at ``U = 0``; the
  critical eigenvector's modal participation is computed at the flutter speed itself;
* **flutter**: first sign change of the largest real part among oscillatory eigenvalues
  (``|Im| > omega_tol``), refined by Brent's method to ``speed_tol``;
* **divergence**: first real eigenvalue crossing zero, refined by Brent's method on the real
  eigenvalue nearest zero, and cross-checked against the static condition
  ``det(K - U^2 P G0) = 0`` (exact because ``C(0) = 1`` for the RFA);
* every result has a status: ``converged``, ``no_crossing_in_range`` or ``bracket_failed``;
  numbers without ``converged`` are NaN.

:func:`pk_sweep` is the exact-Theodorsen p-k cross-check on the same generalised coordinates.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
from scipy.optimize import brentq, linear_sum_assignment

from model.errors import BridgeflapInputError
from model.statespace import AeroelasticSystem, divergence_speed_static, exact_dynamic_matrix
from model.theodorsen import theodorsen

CONVERGED = "converged"
NO_CROSSING = "no_crossing_in_range"
BRACKET_FAILED = "bracket_failed"
#: the system is already unstable at the first speed of the grid: no crossing can be located
UNSTABLE_AT_FIRST = "unstable_at_first_speed"


def check_speeds(speeds) -> np.ndarray:
    """Validate a wind-speed grid [m/s]: finite, non-negative, increasing, at least 2 points."""
    try:
        u = np.asarray(speeds, dtype=float).ravel()
    except (TypeError, ValueError):
        raise BridgeflapInputError("speeds", "not numeric") from None
    if u.size < 2:
        raise BridgeflapInputError("speeds", "the grid needs at least two speeds")
    if not np.all(np.isfinite(u)):
        raise BridgeflapInputError("speeds", "must be finite")
    if np.any(u < 0):
        raise BridgeflapInputError("speeds", f"must not be negative (min {u.min()})")
    if np.any(np.diff(u) <= 0):
        raise BridgeflapInputError("speeds", "must be strictly increasing")
    return u


@dataclass(frozen=True)
class Crossing:
    """A stability boundary: speed [m/s], frequency [Hz] and status."""

    speed: float
    frequency_hz: float
    status: str
    bracket: tuple = (float("nan"), float("nan"))


@dataclass(frozen=True)
class StabilitySweep:
    """Result of :func:`sweep`.

    Attributes
    ----------
    speeds : ndarray (n_u,)
        [m/s].
    eigenvalues : ndarray (n_u, n_x)
        All eigenvalues [1/s] at each speed.
    branches : ndarray (n_b, n_u)
        Tracked structural branches [1/s].
    branch_labels : tuple of str
        Structural mode of each branch at U = 0.
    flutter, divergence : Crossing
    critical_participation : dict
        Share of each structural coordinate in the flutter eigenvector (|q|^2 normalised).
    """

    speeds: np.ndarray
    eigenvalues: np.ndarray
    branches: np.ndarray
    branch_labels: tuple
    flutter: Crossing
    divergence: Crossing
    divergence_static_speed: float
    critical_branch: str
    critical_participation: dict = field(default_factory=dict)

    def damping_ratios(self) -> np.ndarray:
        """Branch damping ratios ``-Re/|lambda|`` (n_b, n_u)."""
        lam = self.branches
        with np.errstate(invalid="ignore", divide="ignore"):
            return -lam.real / np.abs(lam)

    def frequencies_hz(self) -> np.ndarray:
        """Branch frequencies ``|Im|/2pi`` [Hz] (n_b, n_u)."""
        return np.abs(self.branches.imag) / (2 * np.pi)

    def summary(self) -> dict:
        """JSON-ready numbers of the flutter/divergence contract."""
        part = sorted(self.critical_participation.items(), key=lambda kv: -kv[1])[:4]
        first = {f"{k}_unstable_from_m_s": c.bracket[0]
                 for k, c in (("flutter", self.flutter), ("divergence", self.divergence))
                 if c.status == UNSTABLE_AT_FIRST}
        return {
            **first,
            "flutter_speed_m_s": self.flutter.speed,
            "flutter_frequency_hz": self.flutter.frequency_hz,
            "flutter_status": self.flutter.status,
            "divergence_speed_m_s": self.divergence.speed,
            "divergence_status": self.divergence.status,
            "divergence_static_speed_m_s": self.divergence_static_speed,
            "critical_branch_label": self.critical_branch,
            "critical_participation": dict(part),
            "speed_min_m_s": float(self.speeds[0]),
            "speed_max_m_s": float(self.speeds[-1]),
        }

    def plot_root_locus(self, ax=None, title: str = "root locus (magenta: U = 0)"):
        """Tracked branches in the complex plane, coloured by wind speed, with a colour bar."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 4.5), layout="constrained")
        sc = None
        for k in range(self.branches.shape[0]):
            lam = self.branches[k]
            sc = ax.scatter(lam.real, lam.imag / (2 * np.pi), c=self.speeds, s=4, cmap="viridis")
            ax.plot(lam.real[0], lam.imag[0] / (2 * np.pi), "m.", ms=8)
        ax.axvline(0, color="k", lw=0.8)
        ax.set_xlabel("Re(lambda) [1/s]")
        ax.set_ylabel("Im(lambda)/2pi [Hz]")
        ax.set_title(title)
        if sc is not None:
            ax.figure.colorbar(sc, ax=ax, label="U [m/s]")
        return ax

    def plot(self, axes=None, title: str = ""):
        """Root locus (left) and damping ratio / frequency against speed (right)."""
        import matplotlib.pyplot as plt

        if axes is None:
            fig, axes = plt.subplots(1, 3, figsize=(15, 4.5), layout="constrained")
        ax0, ax1, ax2 = axes
        self.plot_root_locus(ax0)
        z = self.damping_ratios()
        f = self.frequencies_hz()
        for k, lab in enumerate(self.branch_labels):
            style = "-" if lab.startswith("T") else "--"
            ax1.plot(self.speeds, 100 * z[k], style, lw=1, label=lab)
            ax2.plot(self.speeds, f[k], style, lw=1, label=lab)
        for ax in (ax1, ax2):
            for c, col in ((self.flutter, "r"), (self.divergence, "b")):
                if c.status == CONVERGED:
                    ax.axvline(c.speed, color=col, lw=0.8, ls=":")
            ax.set_xlabel("U [m/s]")
            ax.grid(alpha=0.3)
        ax1.axhline(0, color="k", lw=0.8)
        ax1.set_ylabel("damping ratio [%]")
        ax1.set_ylim(-5, 15)
        ax2.set_ylabel("frequency [Hz]")
        ax1.legend(fontsize=6, ncol=2)
        fl = (f"flutter {self.flutter.speed:.2f} m/s" if self.flutter.status == CONVERGED
              else f"flutter: {self.flutter.status}")
        dv = (f"divergence {self.divergence.speed:.2f} m/s"
              if self.divergence.status == CONVERGED else f"divergence: {self.divergence.status}")
        (ax0.figure).suptitle(f"{title}  {fl}, {dv}".strip())
        return axes


def _eig(A):
    lam, V = sla.eig(A)
    return lam, V


def oscillation_tolerance(system: AeroelasticSystem) -> float:
    """Threshold [rad/s] on ``|Im lambda|`` between oscillatory and real eigenvalues.

    ``1e-3`` of the lowest structural natural frequency ``sqrt(K_ii / M_ii)``.
    """
    w = np.sqrt(np.abs(np.diag(system.basis.K) / np.diag(system.basis.M)))
    return 1e-3 * float(np.min(w[w > 0])) if np.any(w > 0) else 1e-6


def flutter_function(system: AeroelasticSystem, U: float, omega_tol: float) -> float:
    """Largest real part among oscillatory eigenvalues of ``A(U)`` [1/s]."""
    lam = np.linalg.eigvals(system.A(U))
    osc = lam[np.abs(lam.imag) > omega_tol]
    return float(osc.real.max()) if osc.size else -np.inf


def _divergence_function(system: AeroelasticSystem, U: float, omega_tol: float) -> float:
    lam = np.linalg.eigvals(system.A(U))
    real = lam[np.abs(lam.imag) <= omega_tol].real
    if real.size == 0:
        return -np.inf
    return float(real[np.argmin(np.abs(real))])


def _max_real_real(lam, omega_tol):
    real = lam[np.abs(lam.imag) <= omega_tol].real
    return float(real.max()) if real.size else -np.inf


def sweep(system: AeroelasticSystem, speeds, speed_tol: float = 1e-3) -> StabilitySweep:
    """Eigenvalue sweep with branch tracking and refined flutter/divergence speeds.

    Parameters
    ----------
    system : AeroelasticSystem
    speeds : array_like
        Wind-speed grid [m/s], non-negative and increasing.
    speed_tol : float
        Absolute tolerance [m/s] of the refined crossing speeds.
    """
    speeds = check_speeds(speeds)
    n = system.basis.n
    iq = system.index.q
    omega_tol = oscillation_tolerance(system)
    # structural eigenpairs at U = 0 (upper half plane)
    lam0, V0 = _eig(system.structural_matrix())
    up = np.argsort(np.where(lam0.imag >= 0, np.abs(lam0), np.inf))[:n]
    prev_lam = lam0[up]
    dominant = np.argmax(np.abs(V0[:n, up]) ** 2, axis=0)
    labels = tuple(system.basis.labels[d] for d in dominant)
    n_u, nx = len(speeds), system.n_states
    all_lam = np.zeros((n_u, nx), dtype=complex)
    branches = np.zeros((n, n_u), dtype=complex)
    flutter_vals = np.zeros(n_u)
    div_vals = np.zeros(n_u)
    pred = prev_lam.copy()
    for i, U in enumerate(speeds):
        lam = np.linalg.eigvals(system.A(U))
        all_lam[i] = lam
        osc_mask = np.abs(lam.imag) > omega_tol
        flutter_vals[i] = lam[osc_mask].real.max() if np.any(osc_mask) else -np.inf
        div_vals[i] = _max_real_real(lam, omega_tol) if U > 0 else -np.inf
        # track by eigenvalue continuity with a linear predictor (eigvals only: the
        # eigenvector back-substitution dominates the cost of a dense eig)
        cand = np.where(lam.imag >= -omega_tol)[0]
        scale = np.maximum(np.abs(pred), omega_tol)[:, None]
        cost = np.abs(pred[:, None] - lam[cand][None, :]) / scale
        rows, cols = linear_sum_assignment(cost)
        cur = lam[cand[cols[np.argsort(rows)]]]
        branches[:, i] = cur
        pred = 2 * cur - prev_lam if i > 0 else cur
        prev_lam = cur
    flutter = _refine(lambda u: flutter_function(system, u, omega_tol), speeds, flutter_vals,
                      speed_tol, system, omega_tol, oscillatory=True)
    divergence = _refine(lambda u: _divergence_function(system, u, omega_tol), speeds, div_vals,
                         speed_tol, system, omega_tol, oscillatory=False)
    if speeds[0] == 0.0 and _max_real_real(all_lam[0], omega_tol) > 1e-6 * omega_tol:
        # a real eigenvalue already unstable in still air (e.g. an unstable compensator pole);
        # the aerodynamic lag states are exactly zero at U = 0 and stay below the threshold
        divergence = Crossing(float("nan"), float("nan"), UNSTABLE_AT_FIRST, (0.0, 0.0))
    u_static = divergence_speed_static(system)
    critical, participation = "", {}
    if flutter.status == CONVERGED:
        lam, V = _eig(system.A(flutter.speed))
        osc = np.where(np.abs(lam.imag) > omega_tol)[0]
        k = osc[np.argmax(lam[osc].real)]
        # kinetic-energy shares of the structural coordinates, M_jj |q_j|^2 (mass-normalised
        # modes: |q_j|^2; a 2-DOF section: m |h|^2 against I |alpha|^2, never m + rad)
        vq = np.real(np.diag(system.basis.M)) * np.abs(V[iq, k]) ** 2
        vq = vq / vq.sum()
        participation = {system.basis.labels[j]: float(vq[j]) for j in range(n)}
        # branch label: the tracked branch closest to the critical eigenvalue
        j = int(np.argmin(np.abs(branches[:, np.searchsorted(speeds, flutter.speed) - 1]
                                 - lam[k])))
        critical = labels[j]
    return StabilitySweep(speeds=speeds, eigenvalues=all_lam, branches=branches,
                          branch_labels=labels, flutter=flutter, divergence=divergence,
                          divergence_static_speed=u_static, critical_branch=critical,
                          critical_participation=participation)


def _refine(fun, speeds, vals, tol, system, omega_tol, oscillatory: bool) -> Crossing:
    if np.isfinite(vals[0]) and vals[0] > 1e-6 * omega_tol:
        # unstable from the first grid speed on: the boundary lies below the grid, and a later
        # sign change would be a second crossing, not the stability limit. The threshold
        # (1e-9 of the lowest natural frequency) keeps an undamped structure at U = 0, whose
        # real parts are zero to round-off, from counting as unstable.
        u0 = float(speeds[0])
        return Crossing(float("nan"), float("nan"), UNSTABLE_AT_FIRST, (u0, u0))
    idx = np.where((vals[:-1] < 0) & (vals[1:] >= 0))[0]
    if idx.size == 0:
        return Crossing(float("nan"), float("nan"), NO_CROSSING)
    i = int(idx[0])
    a, b = float(speeds[i]), float(speeds[i + 1])
    try:
        fa, fb = fun(a), fun(b)
        if not (fa < 0 <= fb) or not (np.isfinite(fa) and np.isfinite(fb)):
            return Crossing(float("nan"), float("nan"), BRACKET_FAILED, (a, b))
        u = float(brentq(fun, a, b, xtol=tol, rtol=1e-12, maxiter=200))
    except (ValueError, RuntimeError):
        return Crossing(float("nan"), float("nan"), BRACKET_FAILED, (a, b))
    if not np.isfinite(fun(u)) or abs(fun(u)) > 1e-3 * max(omega_tol, 1e-3) * 1e3:
        # brentq landed on a discontinuity (e.g. a pair turning real), not a root
        return Crossing(float("nan"), float("nan"), BRACKET_FAILED, (a, b))
    freq = 0.0
    if oscillatory:
        lam = np.linalg.eigvals(system.A(u))
        osc = lam[np.abs(lam.imag) > omega_tol]
        freq = float(np.abs(osc[np.argmax(osc.real)].imag) / (2 * np.pi))
    return Crossing(u, freq, CONVERGED, (a, b))


# --------------------------------------------------------------------------- p-k check


@dataclass(frozen=True)
class PKResult:
    """Exact-Theodorsen p-k branches and the flutter crossing."""

    speeds: np.ndarray
    branches: np.ndarray
    branch_labels: tuple
    flutter: Crossing


def _pk_solve(frozen, U, p_guess, tol=1e-10, maxit=100):
    """One p-k point: eigenvalue ``p`` of ``frozen.matrix(U, C(|Im p| b / U))`` near ``p_guess``.

    ``C`` is the exact Theodorsen function; returns ``(p, converged)``.
    """
    b = frozen.half_chord
    p = p_guess
    for _ in range(maxit):
        k = abs(p.imag) * b / U
        if hasattr(frozen, "matrix_at_k"):   # tabulated flutter derivatives (model.derivatives)
            lam = np.linalg.eigvals(frozen.matrix_at_k(U, k))
        else:
            c = theodorsen(k) if k > 0 else 1.0 + 0j
            lam = np.linalg.eigvals(frozen.matrix(U, c))
        p_new = lam[np.argmin(np.abs(lam - p))]
        if abs(p_new - p) < tol * max(1.0, abs(p)):
            return p_new, True
        p = p_new
    return p, False


def _structural_labels(system: AeroelasticSystem, lam0) -> tuple:
    """Label of the structural coordinate dominating each ``U = 0`` eigenvalue."""
    basis = system.basis
    n = basis.n
    l0, V0 = _eig(system.structural_matrix())
    labels = []
    for lam in lam0:
        k = np.argmin(np.abs(l0 - lam))
        labels.append(basis.labels[int(np.argmax(np.abs(V0[:n, k])))])
    return tuple(labels)


def pk_sweep(system: AeroelasticSystem, speeds, speed_tol: float = 1e-3) -> PKResult:
    """p-k solution with the exact Theodorsen function on the same coordinates.

    Open or closed loop: the first-order matrix with ``C(k)`` frozen
    (:meth:`~model.statespace.AeroelasticSystem.frozen`) contains the compensator states, so
    ``K(p)`` is exact. Each structural branch is continued from its U = 0 eigenvalue; at each
    speed the reduced frequency is iterated to consistency, ``k = |Im p| b / U``. Flutter is the
    first speed where an oscillatory branch's real part changes sign, refined by Brent's method
    to ``speed_tol`` [m/s].
    """
    speeds = check_speeds(speeds)
    speeds = speeds[speeds > 0]
    frozen = system.frozen()
    lam0 = system.structural_eigenvalues()
    n = len(lam0)
    branches = np.zeros((n, len(speeds)), dtype=complex)
    for j in range(n):
        p = lam0[j]
        for i, U in enumerate(speeds):
            p, _ = _pk_solve(frozen, U, p)
            branches[j, i] = p
    labels = _structural_labels(system, lam0)
    omega_tol = oscillation_tolerance(system)
    best = None
    for j in range(n):
        re = branches[j].real
        osc = np.abs(branches[j].imag) > omega_tol
        idx = np.where((re[:-1] < 0) & (re[1:] >= 0) & osc[:-1] & osc[1:])[0]
        if idx.size and (best is None or speeds[idx[0]] < speeds[best[1]]):
            best = (j, int(idx[0]))
    if best is None:
        return PKResult(speeds, branches, labels,
                        Crossing(float("nan"), float("nan"), NO_CROSSING))
    j, i = best

    def f(U):
        p, ok = _pk_solve(frozen, U, branches[j, i])
        return p.real if ok else np.nan

    a, b = speeds[i], speeds[i + 1]
    try:
        u = float(brentq(f, a, b, xtol=speed_tol))
    except ValueError:
        return PKResult(speeds, branches, labels,
                        Crossing(float("nan"), float("nan"), BRACKET_FAILED, (a, b)))
    p, _ = _pk_solve(frozen, u, branches[j, i])
    return PKResult(speeds, branches, labels,
                    Crossing(u, abs(p.imag) / (2 * np.pi), CONVERGED, (a, b)))


def exact_residual(system: AeroelasticSystem, p: complex, U: float) -> float:
    """Smallest singular value of the exact dynamic matrix at ``p`` (diagnostic)."""
    k = abs(p.imag) * system.aero.half_chord / U
    D = exact_dynamic_matrix(system, p, U, theodorsen(k))
    return float(np.linalg.svd(D, compute_uv=False)[-1])
