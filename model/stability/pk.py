"""Exact-Theodorsen p-k cross-check on the generalised coordinates of an aeroelastic system.

Branches continued from U = 0 with adaptive sub-steps, flutter refined by Brent's method on the
crossing branch and verified (docs/methods.md#p-k-check). By default the branches are marched
together and stopped at the first crossing, on the lean kernel of
:mod:`bridgeflap.model.stability.pk_kernel` (secant k iteration); ``pk_sweep(..., full_grid=True)``
is the reference (whole grid, fixed-point k iteration on the frozen system's own matrices).
Re-exported by
:mod:`bridgeflap.model.stability.sweeps`. :func:`closed_loop_pk_flutter` is the p-k check of a
flapped deck's closed loop (it was in :mod:`bridgeflap.model.aeroelastic.flaps`, which sits below
the stability layer).

May import: the foundation, bridgeflap.model.aero, bridgeflap.model.aeroelastic (types of the closed
loop only under ``TYPE_CHECKING``) and of bridgeflap.model.stability only
:mod:`~bridgeflap.model.stability.pk_kernel` and
:mod:`~bridgeflap.model.stability.tracking`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import brentq

from bridgeflap.model.aero.theodorsen import theodorsen
from bridgeflap.model.aeroelastic.statespace import AeroelasticSystem, exact_dynamic_matrix
from bridgeflap.model.arguments import checked, flag
from bridgeflap.model.results import ResultData
from bridgeflap.model.stability.pk_kernel import BranchMemory, kernel_for
from bridgeflap.model.stability.tracking import (
    BRACKET_FAILED,
    CONVERGED,
    NO_CROSSING,
    UNAMBIGUOUS,
    UNSTABLE_AT_FIRST,
    UNVERIFIED,
    Crossing,
    _bracket_half_width,
    _eig,
    _stable_start,
    check_speeds,
    continue_adaptive,
    oscillation_tolerance,
)
from bridgeflap.model.structure.bridge_arg import check_system

if TYPE_CHECKING:
    from bridgeflap.model.aeroelastic.control import Compensator
    from bridgeflap.model.aeroelastic.flaps import ClosedLoopModel

#: relative residual below which a p-k point solves its own frozen-C equation (the k iteration
#: stops at a relative change of 1e-10; 1e-7 leaves three orders for round-off of larger models)
PK_RESIDUAL_TOL = 1e-7


@dataclass(frozen=True)
class PKResult(ResultData):
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
        """The flutter keys of :meth:`StabilitySweep.summary` from the p-k solution.

        Returns
        -------
        dict
            Plain Python numbers and strings: ``flutter_speed_m_s`` [m/s],
            ``flutter_frequency_hz`` [Hz], ``flutter_status`` and the slope, onset and branch
            keys.
        """
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


    def plot(self, ax=None):
        """Damping ratio ``-Re p/|p|`` [-] of each p-k branch against wind speed [m/s].

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 4), layout="constrained")
        with np.errstate(invalid="ignore", divide="ignore"):
            zeta = -self.branches.real / np.abs(self.branches)
        for label, z in zip(self.branch_labels, zeta, strict=True):
            ax.plot(self.speeds, z, label=label)
        ax.axhline(0.0, color="k", lw=0.8)
        if self.flutter.status == CONVERGED:
            ax.axvline(self.flutter.speed, color="C3", ls=":", label="flutter")
        ax.set_xlabel("wind speed [m/s]")
        ax.set_ylabel("damping ratio [-]")
        ax.set_title("p-k branches (exact Theodorsen)")
        ax.legend(fontsize=7, ncol=2)
        return ax


def _frozen_matrix(frozen, U: float, kr: float):
    """First-order matrix at speed ``U`` with the aerodynamics frozen at reduced frequency ``kr``:
    the exact Theodorsen ``C(kr)``, or interpolated flutter derivatives where the frozen system
    carries them (``matrix_at_k``, :mod:`bridgeflap.model.aeroelastic.derivative_system`)."""
    if hasattr(frozen, "matrix_at_k"):
        return frozen.matrix_at_k(U, kr)
    return frozen.matrix(U, theodorsen(kr) if kr > 0 else 1.0 + 0j)


def _pk_point(frozen, U, p_guess, tol=1e-10, maxit=100):
    """One p-k point: eigenvalue ``p`` of ``frozen.matrix(U, C(|Im p| b / U))`` near ``p_guess``.

    Returns ``(p, converged, eigenvalues of the last matrix, index of p among them)``.
    """
    b = frozen.half_chord
    p = p_guess
    lam, k = np.array([p]), 0
    for _ in range(maxit):
        lam = np.linalg.eigvals(_frozen_matrix(frozen, U, abs(p.imag) * b / U))
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


def _reference_point(frozen):
    """Point solver of the reference path: :func:`_pk_point` (fixed-point k iteration)."""

    def point(U, p_guess, hint=None):
        return _pk_point(frozen, U, p_guess)

    return point


def _pk_continue(point, u0, p0, s0, u1, halvings=12, hint=None):
    """Continue one p-k root from ``(u0, p0)`` (slope ``s0`` [1/s per m/s]) to ``u1`` [m/s].

    ``point(U, p_guess, hint)`` is the point solver (:func:`_reference_point`, or
    :meth:`bridgeflap.model.stability.pk_kernel.Kernel.point`). Each sub-step solves the k iteration
    from the linear prediction and is accepted when it converged and the root is nearer the
    prediction than
    :data:`UNAMBIGUOUS` times the next eigenvalue of the same matrix; otherwise the step is
    halved (down to ``2**-halvings`` of ``|u1 - u0|``;
    :func:`bridgeflap.model.stability.tracking.continue_adaptive`). A coarse grid therefore cannot
    let two branches collapse onto one root. Returns ``(p, slope, ok)``; ``ok`` is False if a step
    was accepted at the smallest size.
    """

    def step(t, pred):
        q, conv, lam, k = point(t, pred, hint)
        d = np.abs(lam - pred)
        d1 = d[k]
        d[k] = np.inf
        return complex(q), bool(conv and d1 <= UNAMBIGUOUS * d.min())

    p, s, forced = continue_adaptive(step, float(u0), complex(p0), complex(s0), float(u1),
                                     halvings)
    return p, s, forced == 0


def _crossing_into(branches, i, omega_tol, from_zero):
    """:func:`_first_crossing` of the grid so far when it had none before column ``i``: a sign
    change into column ``i`` (``(branch, i - 1)``), or for ``i = 0`` on a grid from U = 0 an
    oscillatory branch already unstable (``(branch, -1)``); the lowest branch first."""
    for j in range(branches.shape[0]):
        cur = complex(branches[j, i])
        if abs(cur.imag) <= omega_tol or cur.real < 0:
            continue
        if i == 0:
            if from_zero:
                return j, -1
            continue
        prev = complex(branches[j, i - 1])
        if prev.real < 0 and abs(prev.imag) > omega_tol:
            return j, i - 1
    return None


def _first_crossing(branches, omega_tol, from_zero):
    """``(branch, grid index i)`` of the first sign change of an oscillatory branch between
    grid speeds ``i`` and ``i + 1`` (``i = -1``: unstable at the first speed of a grid from
    U = 0), lowest branch first among equals; None without one."""
    best = None
    for j in range(branches.shape[0]):
        re = branches[j].real
        osc = np.abs(branches[j].imag) > omega_tol
        idx = np.where((re[:-1] < 0) & (re[1:] >= 0) & osc[:-1] & osc[1:])[0]
        if from_zero and osc[0] and re[0] >= 0:
            # a grid from U = 0: the structure is stable (or neutral) in still air, so a
            # branch unstable at the first positive speed crossed below it
            idx = np.array([-1])
        if idx.size and (best is None or idx[0] < best[1]):
            best = (j, int(idx[0]))
    return best


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
    A = _frozen_matrix(frozen, U, kr)
    s = np.linalg.svd(A - p * np.eye(A.shape[0]), compute_uv=False)
    return float(s[-1] / max(np.linalg.norm(A, 2), abs(p), 1e-300))


@checked(system=check_system, full_grid=flag)
def pk_sweep(system: AeroelasticSystem, speeds, speed_tol: float = 1e-3,
             full_grid: bool = False) -> PKResult:
    """p-k solution with the exact Theodorsen function on the same coordinates.

    Open or closed loop: the first-order matrix with ``C(k)`` frozen
    (:meth:`~bridgeflap.model.aeroelastic.statespace.AeroelasticSystem.frozen`) contains the
    compensator states, so ``K(p)`` is exact. Each structural branch is continued from its U = 0
    eigenvalue with adaptive sub-steps (:func:`_pk_continue`); at each speed the reduced frequency
    is iterated to consistency, ``k = |Im p| b / U``. Flutter is the first speed where an
    oscillatory branch's real part changes sign, refined by Brent's method on that branch (continued
    from the grid speed below) to ``speed_tol`` [m/s], then verified: sign change of the branch
    across ``u -+ max(10 tol, 1e-3 u)``, continuation to the next grid speed arriving at the
    branch's own value there (no jump), the k iteration converged and the residuals
    (:func:`pk_residual`, :func:`exact_residual` for the open loop) below
    :data:`PK_RESIDUAL_TOL`. Otherwise ``unverified_crossing`` with the grid bracket.

    Two paths give the same crossing and status (docs/methods.md#p-k-check):

    * default: the lean kernel (:mod:`bridgeflap.model.stability.pk_kernel`: constant matrices per
      speed, secant k iteration), all branches marched together speed by speed and stopped at the
      grid speed above the first crossing; ``speeds``, ``branches`` and ``converged`` of the result
      then end there (the whole grid without a crossing);
    * ``full_grid=True``, the reference: every branch continued over the whole grid with the
      fixed-point k iteration on the frozen system's own matrices.

    Parameters
    ----------
    system : AeroelasticSystem
        Open- or closed-loop system (:func:`bridgeflap.model.bridge_system`).
    speeds : array_like
        Wind speeds [m/s], increasing and non-negative.
    speed_tol : float, default 1e-3
        Width [m/s] to which the flutter crossing is refined.
    full_grid : bool, default False
        Continue every branch over the whole grid (the reference path).

    Returns
    -------
    PKResult
        Branches, flutter speed [m/s] and frequency, reduced frequency and status; ``summary()``,
        ``plot()``.
    """
    speeds_in = check_speeds(speeds)
    speeds = speeds_in[speeds_in > 0]
    frozen = system.frozen()
    lam0 = system.structural_eigenvalues()
    n = len(lam0)
    omega_tol = oscillation_tolerance(system)
    from_zero = bool(speeds_in[0] == 0.0)
    branches = np.zeros((n, len(speeds)), dtype=complex)
    slopes = np.zeros((n, len(speeds)), dtype=complex)
    conv = np.zeros((n, len(speeds)), dtype=bool)
    if full_grid:
        point = _reference_point(frozen)
        hints = [None] * n
        for j in range(n):
            p, s, u = lam0[j], 0.0j, 0.0
            for i, U in enumerate(speeds):
                p, s, ok = _pk_continue(point, u, p, s, U)
                branches[j, i], slopes[j, i], conv[j, i], u = p, s, ok, U
        best = _first_crossing(branches, omega_tol, from_zero)
    else:
        point = kernel_for(frozen).point
        hints = [BranchMemory() for _ in range(n)]
        p, s, u, best = np.array(lam0, complex), np.zeros(n, complex), 0.0, None
        for i, U in enumerate(speeds):
            for j in range(n):
                p[j], s[j], ok = _pk_continue(point, u, p[j], s[j], U, hint=hints[j])
                branches[j, i], slopes[j, i], conv[j, i] = p[j], s[j], ok
            u = U
            best = _crossing_into(branches, i, omega_tol, from_zero)
            if best is not None:
                speeds, branches, slopes, conv = (x[..., :i + 1] for x in
                                                  (speeds, branches, slopes, conv))
                break
    labels = _structural_labels(system, lam0)

    def result(crossing, res=float("nan"), ex=float("nan")):
        return PKResult(speeds, branches, labels, crossing, conv, res, ex)

    if best is None:
        if np.any((branches[:, 0].real > 1e-6 * omega_tol)
                  & (np.abs(branches[:, 0].imag) > omega_tol)):
            u0 = float(speeds[0])
            return result(Crossing(float("nan"), float("nan"), UNSTABLE_AT_FIRST, (u0, u0)))
        return result(Crossing(float("nan"), float("nan"), NO_CROSSING))
    j, i = best
    hint = hints[j]
    if i < 0:
        a, b, pa, sa = 0.0, float(speeds[0]), complex(lam0[j]), 0.0j
    else:
        a, b = float(speeds[i]), float(speeds[i + 1])
        pa, sa = complex(branches[j, i]), complex(slopes[j, i])

    def cont(U):
        return _pk_continue(point, a, pa, sa, U, hint=hint)

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
    p_lo, _, ok_lo = _pk_continue(point, u, p, s, lo, hint=hint)
    p_hi, _, ok_hi = _pk_continue(point, u, p, s, hi, hint=hint)
    p_b, _, ok_b = _pk_continue(point, u, p, s, b, hint=hint)
    _, conv_u, _, _ = point(u, p, hint)
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


# ------------------------------------------------------------------ closed loop


def closed_loop_pk_flutter(model: ClosedLoopModel, compensator: Compensator, speeds,
                           speed_tol: float = 1e-4):
    """Closed-loop flutter speed by the p-k method with exact Theodorsen and ``K(p)``.

    :func:`pk_sweep` of the closed loop (``model``: a
    :class:`bridgeflap.model.aeroelastic.flaps.ClosedLoopModel`; the compensator states are part of
    the frozen-C first-order matrix, so ``K(p)`` is exact). Returns ``(speed [m/s],
    frequency [Hz], status, branches)``.
    """
    res = pk_sweep(model.system(compensator), speeds, speed_tol)
    return res.flutter.speed, res.flutter.frequency_hz, res.flutter.status, res.branches
