"""Stability over a wind-speed grid: eigenvalue sweep, branch tracking, flutter and divergence.

Method (docs/methods.md#stability):

* at every grid speed all eigenvalues of ``A(U)`` (dense ``eigvals``);
* structural branches are tracked from ``U = 0`` (also when the grid starts above 0) by linear
  assignment on the distance to a linear prediction; a step whose assignment is ambiguous (an
  oscillatory branch not clearly nearest its prediction) is halved, eigenvalues only, within a
  budget of extra evaluations, so coarse grids keep their labels. Each branch keeps the label of
  its structural mode at ``U = 0``; the critical eigenvector's modal participation is computed at
  the flutter speed itself;
* **flutter**: first sign change of the largest real part among oscillatory eigenvalues
  (``|Im| > omega_tol``), refined by Brent's method to ``speed_tol``;
* **divergence**: first real eigenvalue crossing zero, refined by Brent's method on the real
  eigenvalue nearest zero, and cross-checked against the static condition
  ``det(K - U^2 P G0) = 0`` (exact because ``C(0) = 1`` for the RFA);
* **verification** of every refined crossing (:func:`_verify`): the critical eigenvalue,
  continued a small bracket either side, changes the sign of its real part; it is the
  continuation of the tracked branch that crossed between the grid speeds (which names it); and
  the refined point is a root. Otherwise the crossing is ``unverified_crossing``;
* every result has a status: ``converged``, ``no_crossing_in_range``, ``bracket_failed``,
  ``unverified_crossing`` or ``unstable_at_first_speed``; numbers without ``converged`` are NaN;
* the **second-critical branch** (the next tracked oscillatory branch to cross) and the damping
  slope at the crossing (soft or hard onset, :data:`HARD_ONSET_DAMPING_SLOPE_S_PER_M`).

:func:`pk_sweep` is the exact-Theodorsen p-k cross-check on the same generalised coordinates;
its branches are continued with adaptive sub-steps and its crossing is verified the same way.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

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
#: Brent found a sign change of the indicator, but the tracked branch does not change sign
#: across a small bracket around it, jumps between the grid speeds, or the point is no root
UNVERIFIED = "unverified_crossing"
#: the second-critical branch is only searched for when the critical crossing converged
NOT_EVALUATED = "not_evaluated"

#: a continuation step is accepted when the eigenvalue given to a branch is nearer its linear
#: prediction than this fraction of the distance to the next-nearest candidate (one half: the
#: prediction error is then below the half-gap, so no two branches can have swapped)
UNAMBIGUOUS = 0.5
#: extra eigenvalue evaluations the sweep may spend on tracking sub-steps: this many per grid
#: speed plus :data:`TRACKING_BUDGET_MIN` (a grid starting above 0, a coarse grid)
TRACKING_BUDGET_FACTOR = 1
TRACKING_BUDGET_MIN = 100
#: flutter onset is "hard" when the damping ratio falls faster than this past the crossing,
#: -d zeta/dU [s/m]: 1e-3 per m/s loses 1 % of critical damping within 10 m/s (about 15 % of
#: the speed of a long-span bridge); slower is "soft" (a gradual, often torsional, onset)
HARD_ONSET_DAMPING_SLOPE_S_PER_M = 1e-3


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
    """A stability boundary: speed [m/s], frequency [Hz] and status.

    ``bracket`` is the grid interval [m/s] of the sign change; ``re_slope_per_m`` the slope
    ``d Re lambda / dU`` [1/s per m/s = 1/m] of the crossing eigenvalue, measured across the
    verification bracket; ``branch`` the tracked structural branch (-1 when the crossing
    eigenvalue is none of them) and ``label`` its name, from ``label_source`` (``"tracking"``
    from U = 0, or ``"participation"``: the largest kinetic-energy share of the crossing
    eigenvector); ``reason`` says why a crossing is not ``converged``.
    """

    speed: float
    frequency_hz: float
    status: str
    bracket: tuple = (float("nan"), float("nan"))
    re_slope_per_m: float = float("nan")
    branch: int = -1
    label: str = ""
    reason: str = ""
    label_source: str = ""

    def damping_slope_s_per_m(self) -> float:
        """``d zeta / dU`` [s/m] at the crossing: ``-(d Re lambda/dU) / |lambda|`` (Re = 0)."""
        w = 2 * np.pi * self.frequency_hz
        if self.status != CONVERGED or not w > 0:
            return float("nan")
        return float(-self.re_slope_per_m / w)

    def onset(self) -> str:
        """``"hard"`` or ``"soft"`` flutter (:data:`HARD_ONSET_DAMPING_SLOPE_S_PER_M`), or ""."""
        dz = self.damping_slope_s_per_m()
        if not np.isfinite(dz):
            return ""
        return "hard" if -dz >= HARD_ONSET_DAMPING_SLOPE_S_PER_M else "soft"


def static_status(u_static: float, speeds) -> str:
    """Status of the static divergence root ``u_static`` [m/s] on the grid ``speeds``.

    ``converged`` inside the grid; ``no_crossing_in_range`` when there is no root or it lies
    above the grid; ``unstable_at_first_speed`` when it lies below the first speed.
    """
    if not np.isfinite(u_static) or u_static > speeds[-1]:
        return NO_CROSSING
    if u_static < speeds[0]:
        return UNSTABLE_AT_FIRST
    return CONVERGED


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
    divergence_static_speed : float
        Root [m/s] of the static condition, wherever it lies (NaN when none): the summary
        reports it only inside the grid (:func:`static_status`).
    critical_participation : dict
        Share of each structural coordinate in the flutter eigenvector (kinetic energy).
    second_flutter : Crossing
        The next tracked oscillatory branch to cross after the critical one.
    tracking_substeps, tracking_forced_steps : int
        Extra eigenvalue evaluations spent on tracking sub-steps, and steps still ambiguous
        at the smallest sub-step or with the budget spent.
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
    second_flutter: Crossing = field(
        default_factory=lambda: Crossing(float("nan"), float("nan"), NOT_EVALUATED))
    tracking_substeps: int = 0
    tracking_forced_steps: int = 0

    @property
    def divergence_static_status(self) -> str:
        """:func:`static_status` of the static divergence root on this grid."""
        return static_status(self.divergence_static_speed, self.speeds)

    def damping_ratios(self) -> np.ndarray:
        """Branch damping ratios ``-Re/|lambda|`` (n_b, n_u)."""
        lam = self.branches
        with np.errstate(invalid="ignore", divide="ignore"):
            return -lam.real / np.abs(lam)

    def frequencies_hz(self) -> np.ndarray:
        """Branch frequencies ``|Im|/2pi`` [Hz] (n_b, n_u)."""
        return np.abs(self.branches.imag) / (2 * np.pi)

    def summary(self) -> dict:
        """JSON-ready numbers of the flutter/divergence contract.

        Besides speeds and statuses: ``flutter_re_lambda_slope_per_m`` (``d Re lambda/dU``
        [1/m]), ``flutter_damping_slope_s_per_m`` (``d zeta/dU`` [s/m]) and ``flutter_onset``
        (hard/soft) at the crossing; the second-critical branch (``second_critical_branch_label``,
        ``second_flutter_speed_m_s`` and its status); ``divergence_static_status`` with the
        static speed NaN unless inside the grid; ``<kind>_bracket_m_s`` and ``<kind>_reason``
        for a crossing seen but not converged.
        """
        part = sorted(self.critical_participation.items(), key=lambda kv: -kv[1])[:4]
        extra = {}
        for k, c in (("flutter", self.flutter), ("divergence", self.divergence)):
            if c.status == UNSTABLE_AT_FIRST:
                extra[f"{k}_unstable_from_m_s"] = c.bracket[0]
            elif c.status in (BRACKET_FAILED, UNVERIFIED):
                extra[f"{k}_bracket_m_s"] = [float(c.bracket[0]), float(c.bracket[1])]
                extra[f"{k}_reason"] = c.reason
        static_st = self.divergence_static_status
        sec = self.second_flutter
        return {
            **extra,
            "flutter_speed_m_s": self.flutter.speed,
            "flutter_frequency_hz": self.flutter.frequency_hz,
            "flutter_status": self.flutter.status,
            "flutter_re_lambda_slope_per_m": (self.flutter.re_slope_per_m
                                              if self.flutter.status == CONVERGED
                                              else float("nan")),
            "flutter_damping_slope_s_per_m": self.flutter.damping_slope_s_per_m(),
            "flutter_onset": self.flutter.onset(),
            "divergence_speed_m_s": self.divergence.speed,
            "divergence_status": self.divergence.status,
            "divergence_re_lambda_slope_per_m": (self.divergence.re_slope_per_m
                                                 if self.divergence.status == CONVERGED
                                                 else float("nan")),
            "divergence_branch_label": self.divergence.label,
            "divergence_branch_label_source": self.divergence.label_source,
            "divergence_static_speed_m_s": (self.divergence_static_speed
                                            if static_st == CONVERGED else float("nan")),
            "divergence_static_status": static_st,
            "critical_branch_label": self.critical_branch,
            "critical_branch_label_source": self.flutter.label_source,
            "critical_participation": dict(part),
            "second_critical_branch_label": sec.label,
            "second_flutter_speed_m_s": sec.speed,
            "second_flutter_frequency_hz": sec.frequency_hz,
            "second_flutter_status": sec.status,
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


# ------------------------------------------------------------------ continuation of branches


class _Budget:
    """Counter of the extra eigenvalue evaluations spent on tracking sub-steps."""

    def __init__(self, limit: int):
        self.limit, self.used, self.forced = int(limit), 0, 0

    def take(self) -> bool:
        if self.used >= self.limit:
            return False
        self.used += 1
        return True


def _assign(pred, lam, omega_tol):
    """Assign each predicted branch value to one eigenvalue of ``lam``.

    The branches are both halves of every structural pair (a pair that turns real gives two
    real eigenvalues, one to each half). Returns the assigned values and whether the assignment
    is ambiguous: an oscillatory branch whose assigned eigenvalue is not nearer its prediction
    than :data:`UNAMBIGUOUS` times the next-nearest oscillatory eigenvalue on its side of the
    real axis (so the step may have swapped two branches; a pair's own halves cannot swap).
    """
    dist = np.abs(pred[:, None] - lam[None, :])
    scale = np.maximum(np.abs(pred), omega_tol)[:, None]
    rows, cols = linear_sum_assignment(dist / scale)
    cols = cols[np.argsort(rows)]
    rng = np.arange(len(pred))
    d1 = dist[rng, cols]
    other = dist.copy()
    other[rng, cols] = np.inf
    side = np.sign(pred.imag)[:, None] * lam.imag[None, :] <= omega_tol
    other[side] = np.inf
    d2 = other.min(axis=1)
    osc = np.abs(pred.imag) > omega_tol
    return lam[cols], bool(np.any(osc & (d1 > UNAMBIGUOUS * d2)))


def _track_interval(system, u0, l0, s0, u1, lam1, omega_tol, budget, halvings=6):
    """Continue the branch values ``l0`` at ``u0`` [m/s] (slopes ``s0`` [1/s per m/s]) to ``u1``.

    ``lam1`` are the eigenvalues at ``u1`` (already computed by the sweep). The step is halved
    (eigenvalues only, at the intermediate speed) while the assignment is ambiguous, down to
    ``2**-halvings`` of the interval or until the sweep's budget of extra evaluations is spent;
    a step taken at that limit is counted in ``budget.forced``.
    """
    u, l, s = float(u0), np.asarray(l0), np.asarray(s0)
    h = u1 - u0
    h_min = h / 2 ** halvings
    while u < u1:
        step = min(h, u1 - u)
        t = u1 if u1 - (u + step) <= 1e-12 * max(u1, 1.0) else u + step
        lam = lam1 if t == u1 else np.linalg.eigvals(system.A(t))
        cur, ambiguous = _assign(l + (t - u) * s, lam, omega_tol)
        if ambiguous and step > 1.5 * h_min and budget.take():
            h = step / 2
            continue
        budget.forced += int(ambiguous)
        s = (cur - l) / (t - u)
        l, u, h = cur, t, 2 * step
    return l, s


def _follow(system, u0, lam0, u1, omega_tol, halvings=10):
    """One eigenvalue ``lam0`` of ``A(u0)`` continued to ``A(u1)`` [m/s].

    Steps are halved until the eigenvalue nearest the (linear) prediction is nearer than
    :data:`UNAMBIGUOUS` times the next-nearest one. Returns ``(lambda, ok)``; ``ok`` is False
    when the smallest step was still ambiguous (the continuation may have jumped).
    """
    u, lam_c, s = float(u0), complex(lam0), 0.0j
    h = u1 - u0
    h_min = abs(h) / 2 ** halvings
    ok = True
    while u != u1:
        step = np.copysign(min(abs(h), abs(u1 - u)), h)
        t = u1 if abs(u1 - (u + step)) <= 1e-12 * max(abs(u1), 1.0) else u + step
        lam = np.linalg.eigvals(system.A(t))
        pred = lam_c + (t - u) * s
        d = np.abs(lam - pred)
        k = int(np.argmin(d))
        d2 = np.partition(d, 1)[1] if d.size > 1 else np.inf
        if d[k] > UNAMBIGUOUS * d2 and abs(step) > 1.5 * h_min:
            h = step / 2
            continue
        ok &= bool(d[k] <= UNAMBIGUOUS * d2)
        s = (lam[k] - lam_c) / (t - u)
        lam_c, u, h = complex(lam[k]), t, 2 * step
    return lam_c, ok


def _branch_of(value, column):
    """Index of the tracked branch whose value in ``column`` is ``value`` (or -1)."""
    cand = np.abs(column - value)
    j = int(np.argmin(cand))
    return j if cand[j] <= 1e-6 * max(abs(value), 1e-12) + 1e-12 else -1


# ------------------------------------------------------------------ the sweep


def sweep(system: AeroelasticSystem, speeds, speed_tol: float = 1e-3) -> StabilitySweep:
    """Eigenvalue sweep with branch tracking and refined, verified flutter/divergence speeds.

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
    dominant = np.argmax(np.abs(V0[:n, up]) ** 2, axis=0)
    labels = tuple(system.basis.labels[d] for d in dominant)
    n_u, nx = len(speeds), system.n_states
    all_lam = np.zeros((n_u, nx), dtype=complex)
    branches = np.zeros((n, n_u), dtype=complex)
    flutter_vals = np.zeros(n_u)
    div_vals = np.zeros(n_u)
    budget = _Budget(TRACKING_BUDGET_FACTOR * n_u + TRACKING_BUDGET_MIN)
    # branches start at the structure's own eigenvalues at U = 0, also for a grid that starts
    # above 0: the first interval is then (0, speeds[0]) with more halvings, so the labels come
    # from U = 0, never from the first grid point
    u_prev, cur = 0.0, np.concatenate([lam0[up], lam0[up].conj()])
    slope = np.zeros(2 * n, dtype=complex)
    tracked = np.zeros((2 * n, n_u), dtype=complex)  # rows n.. : the lower halves
    for i, U in enumerate(speeds):
        lam = np.linalg.eigvals(system.A(U))
        all_lam[i] = lam
        osc_mask = np.abs(lam.imag) > omega_tol
        flutter_vals[i] = lam[osc_mask].real.max() if np.any(osc_mask) else -np.inf
        div_vals[i] = _max_real_real(lam, omega_tol) if U > 0 else -np.inf
        if U == 0.0:
            cur, _ = _assign(cur, lam, omega_tol)
        else:
            cur, slope = _track_interval(system, u_prev, cur, slope, U, lam, omega_tol, budget,
                                         halvings=6 if i > 0 else 12)
        tracked[:, i] = cur
        u_prev = U
    branches = tracked[:n]
    flutter = _locate(system, speeds, flutter_vals, speed_tol, omega_tol, "flutter", tracked)
    divergence = _locate(system, speeds, div_vals, speed_tol, omega_tol, "divergence", tracked)
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
        # label: the branch tracked from U = 0 that the critical eigenvalue continues; a
        # critical eigenvalue that is no tracked branch (a compensator or lag mode) is named
        # by its largest participation
        if flutter.branch >= 0:
            flutter = replace(flutter, branch=flutter.branch % n,
                              label=labels[flutter.branch % n], label_source="tracking")
        else:
            flutter = replace(flutter, label=max(participation, key=participation.get),
                              label_source="participation")
        critical = flutter.label
    if divergence.status == CONVERGED:
        if divergence.branch >= 0:
            divergence = replace(divergence, branch=divergence.branch % n,
                                 label=labels[divergence.branch % n], label_source="tracking")
        else:
            # the real eigenvalue continued to the grid speeds passes the point where its
            # complex pair split, and the tracking may have kept its partner: name it by its
            # strain-energy participation (a static mode has no kinetic energy), K_jj |q_j|^2
            lam, V = _eig(system.A(divergence.speed))
            real = np.where(np.abs(lam.imag) <= omega_tol)[0]
            k = real[np.argmin(np.abs(lam[real].real))]
            vq = np.real(np.diag(system.basis.K)) * np.abs(V[iq, k]) ** 2
            divergence = replace(divergence, label=system.basis.labels[int(np.argmax(vq))],
                                 label_source="participation")
    second = _second_crossing(system, speeds, branches, labels, flutter, speed_tol, omega_tol)
    return StabilitySweep(speeds=speeds, eigenvalues=all_lam, branches=branches,
                          branch_labels=labels, flutter=flutter, divergence=divergence,
                          divergence_static_speed=u_static, critical_branch=critical,
                          critical_participation=participation, second_flutter=second,
                          tracking_substeps=budget.used, tracking_forced_steps=budget.forced)


def _bracket_half_width(u: float, tol: float) -> float:
    """Half-width [m/s] of the verification bracket around a refined crossing ``u``."""
    return max(10 * tol, 1e-3 * u)


def _verify(system, u, lam_u, a, b, i, tol, omega_tol, kind, tracked):
    """Check a refined crossing ``u`` in the grid bracket ``(a, b)`` (index ``i``).

    ``lam_u`` is the critical eigenvalue of ``A(u)``. Verified when (1) the eigenvalue,
    continued a small bracket ``u -+ d`` either side (:func:`_bracket_half_width`), changes the
    sign of its real part and stays oscillatory (flutter) or real (divergence); (2) it is the
    continuation of the branch that crossed: continued to the grid speeds it is stable at ``a``
    and not stable at ``b`` (flutter, which also names the branch tracked from U = 0); (3) its
    real part is a root: ``|Re lambda(u)| <= 4 |d Re lambda/dU| tol`` (Brent's tolerance), or
    at round-off level. Returns ``(ok, slope [1/m], branch index or -1, reason)``.
    """
    d = _bracket_half_width(u, tol)
    lo, hi = max(u - d, 0.5 * u), u + d
    l_lo, ok_lo = _follow(system, u, lam_u, lo, omega_tol)
    l_hi, ok_hi = _follow(system, u, lam_u, hi, omega_tol)
    slope = (l_hi.real - l_lo.real) / (hi - lo)
    if kind == "flutter":
        typed = abs(l_lo.imag) > omega_tol and abs(l_hi.imag) > omega_tol
    else:
        typed = abs(l_lo.imag) <= omega_tol and abs(l_hi.imag) <= omega_tol
    if not (ok_lo and ok_hi and typed and l_lo.real < 0 < l_hi.real):
        return False, slope, -1, "no sign change of the tracked branch across the bracket"
    if abs(lam_u.real) > 4 * abs(slope) * (tol + 1e-12 * u) + 1e-10 * abs(lam_u) + 1e-14:
        return False, slope, -1, "the refined point is not a root"
    l_a, ok_a = _follow(system, u, lam_u, a, omega_tol) if a != u else (lam_u, True)
    l_b, ok_b = _follow(system, u, lam_u, b, omega_tol) if b != u else (lam_u, True)
    branch = _branch_of(l_a, tracked[:, i])
    if branch < 0 and kind == "divergence":
        branch = _branch_of(l_b, tracked[:, i + 1])
    if kind == "flutter":
        stable_a = l_a.real < 0 or (a == 0.0 and l_a.real <= 1e-6 * omega_tol)
        if not (ok_a and ok_b and stable_a and l_b.real >= 0):
            return False, slope, branch, "the branch jumps between the grid speeds"
    return True, slope, branch, ""


def _indicator(system, u, omega_tol, kind) -> float:
    """The sweep's indicator at ``u`` [m/s]: flutter envelope or largest real eigenvalue."""
    if kind == "flutter":
        return flutter_function(system, u, omega_tol)
    return _max_real_real(np.linalg.eigvals(system.A(u)), omega_tol)


def _locate(system, speeds, vals, tol, omega_tol, kind, branches) -> Crossing:
    """First crossing of the indicator ``vals`` on the grid, refined and verified.

    A bracket whose end values do not hold, or whose refined point fails :func:`_verify`, is
    split into eight and the first sub-bracket with a sign change is tried once more (a coarse
    grid can straddle a branch switch); what still fails is ``bracket_failed`` or
    ``unverified_crossing``, with NaN numbers and the grid bracket.
    """
    if np.isfinite(vals[0]) and vals[0] > 1e-6 * omega_tol:
        # unstable from the first grid speed on: the boundary lies below the grid, and a later
        # sign change would be a second crossing, not the stability limit. The threshold
        # (1e-9 of the lowest natural frequency) keeps an undamped structure at U = 0, whose
        # real parts are zero to round-off, from counting as unstable.
        u0 = float(speeds[0])
        return Crossing(float("nan"), float("nan"), UNSTABLE_AT_FIRST, (u0, u0))
    stable = vals < 0
    # U = 0 is neutral (an undamped structure in still air, real parts zero to round-off)
    stable[0] |= bool(speeds[0] == 0.0 and vals[0] <= 1e-6 * omega_tol)
    idx = np.where(stable[:-1] & (vals[1:] >= 0))[0]
    if idx.size == 0:
        return Crossing(float("nan"), float("nan"), NO_CROSSING)
    i = int(idx[0])
    a, b = float(speeds[i]), float(speeds[i + 1])
    first = _refine(system, a, b, i, a, b, tol, omega_tol, kind, branches)
    if first.status == CONVERGED:
        return first
    sub = np.linspace(a, b, 9)
    sv = np.array([vals[i], *(_indicator(system, s, omega_tol, kind) for s in sub[1:-1]),
                   vals[i + 1]])
    k = np.where((sv[:-1] < 0) & (sv[1:] >= 0))[0]
    if k.size:
        retry = _refine(system, float(sub[k[0]]), float(sub[k[0] + 1]), i, a, b, tol,
                        omega_tol, kind, branches)
        if retry.status == CONVERGED:
            return retry
    return first


def _stable_start(fun, a: float, b: float) -> float:
    """``a``, or for a neutral ``a = 0`` (``fun(0)`` zero to round-off) the largest
    ``b / 2**m`` (m <= 40) where ``fun`` is negative: Brent needs a strict sign change."""
    if a != 0.0 or fun(a) < 0:
        return a
    t = b
    for _ in range(40):
        t /= 2
        if fun(t) < 0:
            return t
    return a


def _refine(system, a, b, i, grid_a, grid_b, tol, omega_tol, kind, branches) -> Crossing:
    """Brent's method on ``(a, b)`` inside the grid bracket ``(grid_a, grid_b)`` (index ``i``),
    then :func:`_verify`.

    Flutter: on the flutter indicator. Divergence: on the real eigenvalue nearest zero, or,
    where that does not bracket (a stable real eigenvalue nearer zero than the diverging one
    at ``b``, e.g. on a coarse grid), on the largest real eigenvalue (the sweep's indicator).
    """
    funs = ([lambda u: flutter_function(system, u, omega_tol)] if kind == "flutter" else
            [lambda u: _divergence_function(system, u, omega_tol),
             lambda u: _indicator(system, u, omega_tol, kind)])
    try:
        for fun in funs:
            a0 = _stable_start(fun, a, b)
            fa, fb = fun(a0), fun(b)
            if fa < 0 <= fb and np.isfinite(fa) and np.isfinite(fb):
                break
        else:
            return Crossing(float("nan"), float("nan"), BRACKET_FAILED, (grid_a, grid_b),
                            reason="the bracket does not hold")
        u = float(brentq(fun, a0, b, xtol=tol, rtol=1e-12, maxiter=200))
    except (ValueError, RuntimeError) as exc:
        return Crossing(float("nan"), float("nan"), BRACKET_FAILED, (grid_a, grid_b),
                        reason=f"Brent: {exc}")
    lam = np.linalg.eigvals(system.A(u))
    if kind == "flutter":
        sel = np.where(np.abs(lam.imag) > omega_tol)[0]
        k = sel[np.argmax(lam[sel].real)] if sel.size else -1
    else:
        sel = np.where(np.abs(lam.imag) <= omega_tol)[0]
        k = sel[np.argmin(np.abs(lam[sel].real))] if sel.size else -1
    if k < 0:
        return Crossing(float("nan"), float("nan"), UNVERIFIED, (grid_a, grid_b),
                        reason="no critical eigenvalue at the refined point")
    ok, slope, branch, why = _verify(system, u, complex(lam[k]), grid_a, grid_b, i, tol,
                                     omega_tol, kind, branches)
    if not ok:
        return Crossing(float("nan"), float("nan"), UNVERIFIED, (grid_a, grid_b), reason=why)
    freq = float(abs(lam[k].imag) / (2 * np.pi)) if kind == "flutter" else 0.0
    return Crossing(u, freq, CONVERGED, (grid_a, grid_b), re_slope_per_m=slope, branch=branch)


def _second_crossing(system, speeds, branches, labels, flutter, tol, omega_tol) -> Crossing:
    """The next tracked oscillatory branch to cross after the critical one (or none).

    Every tracked branch other than the critical one is searched for its first grid sign change
    of ``Re lambda`` (oscillatory at both ends); the earliest is refined by Brent's method on
    that branch continued from the grid speed below (:func:`_follow`) and verified like the
    critical crossing.
    """
    if flutter.status != CONVERGED:
        return Crossing(float("nan"), float("nan"), NOT_EVALUATED)
    re = branches.real
    osc = np.abs(branches.imag) > omega_tol
    best = None
    for j in range(branches.shape[0]):
        if j == flutter.branch:
            continue
        idx = np.where((re[j, :-1] < 0) & (re[j, 1:] >= 0) & osc[j, :-1] & osc[j, 1:])[0]
        if idx.size and (best is None or idx[0] < best[1]):
            best = (j, int(idx[0]))
    if best is None:
        return Crossing(float("nan"), float("nan"), NO_CROSSING)
    j, i = best
    a, b, la = float(speeds[i]), float(speeds[i + 1]), complex(branches[j, i])
    label = labels[j]

    def g(u):
        return _follow(system, a, la, u, omega_tol)[0].real if u != a else la.real

    try:
        u = float(brentq(g, a, b, xtol=tol, rtol=1e-12, maxiter=200))
    except (ValueError, RuntimeError):
        return Crossing(float("nan"), float("nan"), BRACKET_FAILED, (a, b), label=label,
                        branch=j)
    lam_u, ok_u = _follow(system, a, la, u, omega_tol)
    ok, slope, branch, why = _verify(system, u, lam_u, a, b, i, tol, omega_tol, "flutter",
                                     branches)
    if not (ok and ok_u and branch == j):
        return Crossing(float("nan"), float("nan"), UNVERIFIED, (a, b), label=label, branch=j,
                        reason=why or "the continuation left the branch")
    return Crossing(u, float(abs(lam_u.imag) / (2 * np.pi)), CONVERGED, (a, b),
                    re_slope_per_m=slope, label=label, branch=j, label_source="tracking")


# --------------------------------------------------------------------------- p-k check

#: relative residual below which a p-k point solves its own frozen-C equation (the k iteration
#: stops at a relative change of 1e-10; 1e-7 leaves three orders for round-off of larger models)
PK_RESIDUAL_TOL = 1e-7


@dataclass(frozen=True)
class PKResult:
    """Exact-Theodorsen p-k branches and the flutter crossing.

    ``converged`` (n_b, n_u): the k iteration converged and every continuation sub-step was
    unambiguous. ``residual`` is :func:`pk_residual` and ``exact_residual``
    :func:`exact_residual` (normalised) at the crossing, NaN elsewhere.
    """

    speeds: np.ndarray
    branches: np.ndarray
    branch_labels: tuple
    flutter: Crossing
    converged: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), bool))
    residual: float = float("nan")
    exact_residual: float = float("nan")

    def summary(self) -> dict:
        """The flutter keys of :meth:`StabilitySweep.summary` from the p-k solution."""
        c = self.flutter
        out = {"flutter_speed_m_s": c.speed, "flutter_frequency_hz": c.frequency_hz,
               "flutter_status": c.status,
               "flutter_re_lambda_slope_per_m": (c.re_slope_per_m if c.status == CONVERGED
                                                 else float("nan")),
               "flutter_damping_slope_s_per_m": c.damping_slope_s_per_m(),
               "flutter_onset": c.onset(), "critical_branch_label": c.label,
               "critical_branch_label_source": c.label_source}
        if c.status in (BRACKET_FAILED, UNVERIFIED):
            out["flutter_bracket_m_s"] = [float(c.bracket[0]), float(c.bracket[1])]
            out["flutter_reason"] = c.reason
        return out


def _pk_point(frozen, U, p_guess, tol=1e-10, maxit=100):
    """One p-k point: eigenvalue ``p`` of ``frozen.matrix(U, C(|Im p| b / U))`` near ``p_guess``.

    Returns ``(p, converged, eigenvalues of the last matrix, index of p among them)``.
    """
    b = frozen.half_chord
    p = p_guess
    lam, k = np.array([p]), 0
    for _ in range(maxit):
        kr = abs(p.imag) * b / U
        c = theodorsen(kr) if kr > 0 else 1.0 + 0j
        lam = np.linalg.eigvals(frozen.matrix(U, c))
        k = int(np.argmin(np.abs(lam - p)))
        p_new = lam[k]
        if abs(p_new - p) < tol * max(1.0, abs(p)):
            return p_new, True, lam, k
        p = p_new
    return p, False, lam, k


def _pk_solve(frozen, U, p_guess, tol=1e-10, maxit=100):
    """One p-k point near ``p_guess`` (:func:`_pk_point`); returns ``(p, converged)``."""
    p, ok, _, _ = _pk_point(frozen, U, p_guess, tol, maxit)
    return p, ok


def _pk_continue(frozen, u0, p0, s0, u1, halvings=12):
    """Continue one p-k root from ``(u0, p0)`` (slope ``s0`` [1/s per m/s]) to ``u1`` [m/s].

    Each sub-step solves the k iteration from the linear prediction and is accepted when it
    converged and the root is nearer the prediction than :data:`UNAMBIGUOUS` times the next
    eigenvalue of the same matrix; otherwise the step is halved (down to ``2**-halvings`` of
    ``|u1 - u0|``). A coarse grid therefore cannot let two branches collapse onto one root.
    Returns ``(p, slope, ok)``; ``ok`` is False if a step was accepted at the smallest size.
    """
    u, p, s = float(u0), complex(p0), complex(s0)
    h = u1 - u0
    h_min = abs(h) / 2 ** halvings
    ok = True
    while u != u1:
        step = np.copysign(min(abs(h), abs(u1 - u)), h)
        t = u1 if abs(u1 - (u + step)) <= 1e-12 * max(abs(u1), 1.0) else u + step
        pred = p + (t - u) * s
        q, conv, lam, k = _pk_point(frozen, t, pred)
        d = np.abs(lam - pred)
        d1 = d[k]
        d[k] = np.inf
        good = conv and d1 <= UNAMBIGUOUS * d.min()
        if not good and abs(step) > 1.5 * h_min:
            h = step / 2
            continue
        ok &= bool(good)
        s = (q - p) / (t - u)
        p, u, h = complex(q), t, 2 * step
    return p, s, ok


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


def pk_residual(frozen, p: complex, U: float) -> float:
    """Relative residual of a p-k point: ``sigma_min(A(U, C(k)) - p I) / ||A||_2`` with
    ``k = |Im p| b / U`` recomputed from ``p`` itself (zero when ``p`` solves its own frozen-C
    equation, i.e. the k iteration is consistent)."""
    kr = abs(p.imag) * frozen.half_chord / U
    A = frozen.matrix(U, theodorsen(kr) if kr > 0 else 1.0 + 0j)
    s = np.linalg.svd(A - p * np.eye(A.shape[0]), compute_uv=False)
    return float(s[-1] / max(np.linalg.norm(A, 2), abs(p), 1e-300))


def pk_sweep(system: AeroelasticSystem, speeds, speed_tol: float = 1e-3) -> PKResult:
    """p-k solution with the exact Theodorsen function on the same coordinates.

    Open or closed loop: the first-order matrix with ``C(k)`` frozen
    (:meth:`~model.statespace.AeroelasticSystem.frozen`) contains the compensator states, so
    ``K(p)`` is exact. Each structural branch is continued from its U = 0 eigenvalue with
    adaptive sub-steps (:func:`_pk_continue`); at each speed the reduced frequency is iterated
    to consistency, ``k = |Im p| b / U``. Flutter is the first speed where an oscillatory
    branch's real part changes sign, refined by Brent's method on that branch (continued from
    the grid speed below) to ``speed_tol`` [m/s], then verified: sign change of the branch
    across ``u -+ max(10 tol, 1e-3 u)``, continuation to the next grid speed landing on the
    branch's own value there (no jump), the k iteration converged and the residuals
    (:func:`pk_residual`, :func:`exact_residual` for the open loop) below
    :data:`PK_RESIDUAL_TOL`. Otherwise ``unverified_crossing`` with the grid bracket.
    """
    speeds_in = check_speeds(speeds)
    speeds = speeds_in[speeds_in > 0]
    frozen = system.frozen()
    lam0 = system.structural_eigenvalues()
    n = len(lam0)
    branches = np.zeros((n, len(speeds)), dtype=complex)
    slopes = np.zeros((n, len(speeds)), dtype=complex)
    conv = np.zeros((n, len(speeds)), dtype=bool)
    for j in range(n):
        p, s, u = lam0[j], 0.0j, 0.0
        for i, U in enumerate(speeds):
            p, s, ok = _pk_continue(frozen, u, p, s, U)
            branches[j, i], slopes[j, i], conv[j, i], u = p, s, ok, U
    labels = _structural_labels(system, lam0)
    omega_tol = oscillation_tolerance(system)

    def result(crossing, res=float("nan"), ex=float("nan")):
        return PKResult(speeds, branches, labels, crossing, conv, res, ex)

    from_zero = bool(speeds_in[0] == 0.0)
    best = None
    for j in range(n):
        re = branches[j].real
        osc = np.abs(branches[j].imag) > omega_tol
        idx = np.where((re[:-1] < 0) & (re[1:] >= 0) & osc[:-1] & osc[1:])[0]
        if from_zero and osc[0] and re[0] >= 0:
            # a grid from U = 0: the structure is stable (or neutral) in still air, so a
            # branch unstable at the first positive speed crossed below it
            idx = np.array([-1])
        if idx.size and (best is None or idx[0] < best[1]):
            best = (j, int(idx[0]))
    if best is None:
        if np.any((branches[:, 0].real > 1e-6 * omega_tol)
                  & (np.abs(branches[:, 0].imag) > omega_tol)):
            u0 = float(speeds[0])
            return result(Crossing(float("nan"), float("nan"), UNSTABLE_AT_FIRST, (u0, u0)))
        return result(Crossing(float("nan"), float("nan"), NO_CROSSING))
    j, i = best
    if i < 0:
        a, b, pa, sa = 0.0, float(speeds[0]), complex(lam0[j]), 0.0j
    else:
        a, b = float(speeds[i]), float(speeds[i + 1])
        pa, sa = complex(branches[j, i]), complex(slopes[j, i])

    def cont(U):
        return _pk_continue(frozen, a, pa, sa, U)

    def f(U):
        return cont(U)[0].real

    def failed(status, reason):
        return result(Crossing(float("nan"), float("nan"), status, (a, b), branch=j,
                               label=labels[j], reason=reason))

    try:
        u = float(brentq(f, _stable_start(f, a, b), b, xtol=speed_tol))
    except (ValueError, RuntimeError) as exc:
        return failed(BRACKET_FAILED, f"Brent: {exc}")
    p, s, ok = cont(u)
    d = _bracket_half_width(u, speed_tol)
    lo, hi = max(u - d, 0.5 * u), u + d
    p_lo, _, ok_lo = _pk_continue(frozen, u, p, s, lo)
    p_hi, _, ok_hi = _pk_continue(frozen, u, p, s, hi)
    p_b, _, ok_b = _pk_continue(frozen, u, p, s, b)
    _, conv_u, _, _ = _pk_point(frozen, u, p)
    res = pk_residual(frozen, p, u)
    ex = float("nan")
    if system.compensator is None and system.pieces is not None:
        D = exact_dynamic_matrix(system, p, u, theodorsen(abs(p.imag) * frozen.half_chord / u))
        ex = exact_residual(system, p, u) / max(np.linalg.norm(D, 2), 1e-300)
    slope = (p_lo.real, p_hi.real)
    if not (ok and ok_lo and ok_hi and slope[0] < 0 < slope[1]
            and abs(p_lo.imag) > omega_tol and abs(p_hi.imag) > omega_tol):
        return failed(UNVERIFIED, "no sign change of the tracked branch across the bracket")
    if not (ok_b and abs(p_b - branches[j, i + 1]) <= 1e-6 * max(abs(p_b), 1e-12)):
        return failed(UNVERIFIED, "the branch jumps between the grid speeds")
    if not (conv_u and res <= PK_RESIDUAL_TOL and not ex > PK_RESIDUAL_TOL):
        return failed(UNVERIFIED, f"residual {res:.1e} (exact {ex:.1e}) or k not converged")
    crossing = Crossing(u, abs(p.imag) / (2 * np.pi), CONVERGED, (a, b),
                        re_slope_per_m=(slope[1] - slope[0]) / (hi - lo), branch=j,
                        label=labels[j], label_source="tracking")
    return result(crossing, res, ex)


def exact_residual(system: AeroelasticSystem, p: complex, U: float) -> float:
    """Smallest singular value of the exact dynamic matrix at ``p`` (diagnostic)."""
    k = abs(p.imag) * system.aero.half_chord / U
    D = exact_dynamic_matrix(system, p, U, theodorsen(k))
    return float(np.linalg.svd(D, compute_uv=False)[-1])
