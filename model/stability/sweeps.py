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

``sweep(..., method="fast")`` gives the same result with a fraction of the eigen-solutions: a
coarse tracked sweep, Newton on the Hopf point and the real-eigenvalue crossing, and this dense
sweep as the fallback when unsure (:mod:`bridgeflap.model.stability.hopf`); every result counts its
eigen-solutions (``eigen_solutions``) and names its method (``sweep_method``,
``sweep_fallback_reason``).

The building blocks (statuses, :class:`~bridgeflap.model.stability.tracking.Crossing`, branch
continuation) are in :mod:`bridgeflap.model.stability.tracking`; :func:`pk_sweep`, the
exact-Theodorsen p-k cross-check on the same generalised coordinates, is in
:mod:`bridgeflap.model.stability.pk` (its branches are continued with adaptive sub-steps and its
crossing is verified the same way). Both are re-exported here, as is the sweep's record
:class:`~bridgeflap.model.stability.result.StabilitySweep`; the steps the dense and the fast sweep
share (start, locate, verify, name) live in
:mod:`bridgeflap.model.stability.crossings`.

May import: the foundation, bridgeflap.model.aeroelastic, and of bridgeflap.model.stability the
modules below the sweep (tracking, crossings, result, pk, plots) and
:mod:`bridgeflap.model.stability.hopf` (the fast path, lazily); nothing above
bridgeflap.model.stability.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.optimize import brentq

# divergence_mechanism re-exported
from bridgeflap.model.aeroelastic.statespace import (  # noqa: F401
    AeroelasticSystem,
    divergence_mechanism,
    divergence_speed_static,
)
from bridgeflap.model.arguments import checked, number, optional
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.stability.crossings import (
    _critical_vector,
    _locate,
    _name_divergence,
    _name_flutter,
    _structural_start,
    _verify,
)

# the p-k check is part of this module's public face
from bridgeflap.model.stability.pk import (  # noqa: F401
    PK_RESIDUAL_TOL,
    PKResult,
    exact_residual,
    pk_residual,
    pk_sweep,
)
from bridgeflap.model.stability.result import StabilitySweep

# statuses and helpers are re-exported
from bridgeflap.model.stability.tracking import (  # noqa: F401
    BRACKET_FAILED,
    CONVERGED,
    HARD_ONSET_DAMPING_SLOPE_S_PER_M,
    NO_CROSSING,
    NOT_EVALUATED,
    TRACKING_BUDGET_FACTOR,
    TRACKING_BUDGET_MIN,
    UNAMBIGUOUS,
    UNSTABLE_AT_FIRST,
    UNVERIFIED,
    Crossing,
    _assign,
    _bracket_half_width,
    _branch_of,
    _Budget,
    _divergence_function,
    _eig,
    _follow,
    _max_real_real,
    _stable_start,
    _track_interval,
    check_speeds,
    flutter_function,
    oscillation_tolerance,
    static_status,
)
from bridgeflap.model.structure.bridge_arg import check_system

# ------------------------------------------------------------------ the sweep


#: ``method`` of :func:`sweep`: ``"dense"`` (every grid speed) or ``"fast"``
# (:mod:`model.stability.hopf`)
SWEEP_METHODS = ("dense", "fast")


@checked(system=check_system, stop_after_rel=optional(number(0.0, 10.0, strict=True)))
def sweep(system: AeroelasticSystem, speeds, speed_tol: float = 1e-3,
          method: str = "dense", critical_only: bool = False,
          stop_after_rel: float | None = None) -> StabilitySweep:
    """Eigenvalue sweep with branch tracking and refined, verified flutter/divergence speeds.

    Parameters
    ----------
    system : AeroelasticSystem
    speeds : array_like
        Wind-speed grid [m/s], non-negative and increasing.
    speed_tol : float
        Absolute tolerance [m/s] of the refined crossing speeds (Brent's method; the fast
        path's Newton converges to round-off).
    method : {"dense", "fast"}
        ``dense``: all eigenvalues at every grid speed; ``fast``: a coarse tracked sweep over
        the grid's range and Newton on the critical eigenpairs
        (:mod:`bridgeflap.model.stability.hopf`), falling back to ``dense`` when unsure
        (``fallback_reason``). Both give the same fields and statuses; the fast path's ``speeds``,
        ``eigenvalues`` and ``branches`` are on its coarse speeds.
    critical_only : bool
        Crossings alone (do no harm): no second branch, no label check
        (bridgeflap.model.stability.hopf.fast_sweep).
    stop_after_rel : float, optional
        With ``method="fast"`` and ``critical_only``: end the coarse march this fraction past
        the first unstable speed (the first crossing is all a do-no-harm row reads; a crossing
        more than that fraction above it is reported absent from the shortened range). The
        dense fallback sweeps the whole grid.

    Returns
    -------
    StabilitySweep
        Speeds, eigenvalues and tracked branches; ``flutter`` and ``divergence`` crossings with
        speed [m/s] and status; ``plot()``.

    Raises
    ------
    BridgeflapInputError
        A bad speed grid or ``method``.
    """
    if method not in SWEEP_METHODS:
        raise BridgeflapInputError("sweep", f"must be one of {SWEEP_METHODS}, got {method!r}")
    speeds = check_speeds(speeds)
    from bridgeflap.model.stability.hopf import CountedSystem, fast_sweep

    counted = CountedSystem(system)
    if method == "fast":
        def dense(reason):
            return replace(_dense_sweep(counted, speeds, speed_tol, critical_only),
                           fallback_reason=reason)

        return fast_sweep(counted, speeds, speed_tol, dense, critical_only, stop_after_rel)
    return _dense_sweep(counted, speeds, speed_tol, critical_only)


def _dense_sweep(system, speeds, speed_tol, critical_only=False) -> StabilitySweep:
    """The dense sweep on a validated grid (``system`` counts its eigen-solutions)."""
    n = system.basis.n
    omega_tol = oscillation_tolerance(system)
    # structural eigenpairs at U = 0 (upper half plane)
    labels, start = _structural_start(system)
    n_u, nx = len(speeds), system.n_states
    all_lam = np.zeros((n_u, nx), dtype=complex)
    flutter_vals = np.zeros(n_u)
    div_vals = np.zeros(n_u)
    budget = _Budget(TRACKING_BUDGET_FACTOR * n_u + TRACKING_BUDGET_MIN)
    # branches start at the structure's own eigenvalues at U = 0, also for a grid that starts
    # above 0: the first interval is then (0, speeds[0]) with more halvings, so the labels come
    # from U = 0, never from the first grid point
    u_prev, cur = 0.0, np.concatenate([start, start.conj()])
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
    flutter, participation = _name_flutter(
        system, flutter, labels,
        lambda: _critical_vector(system, flutter.speed, omega_tol, "flutter"))
    divergence, div_participation = _name_divergence(
        system, divergence, labels,
        lambda: _critical_vector(system, divergence.speed, omega_tol, "divergence"))
    second = (Crossing(float("nan"), float("nan"), NOT_EVALUATED) if critical_only else
              _second_crossing(system, speeds, branches, labels, flutter, speed_tol, omega_tol))
    return StabilitySweep(speeds=speeds, eigenvalues=all_lam, branches=branches,
                          branch_labels=labels, flutter=flutter, divergence=divergence,
                          divergence_static_speed=u_static, critical_branch=flutter.label,
                          critical_participation=participation,
                          divergence_participation=div_participation, second_flutter=second,
                          tracking_substeps=budget.used, tracking_forced_steps=budget.forced,
                          method="dense", eigen_solutions=system.count)


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
