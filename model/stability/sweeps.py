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
sweep as the fallback when unsure (:mod:`model.stability.hopf`); every result counts its
eigen-solutions (``eigen_solutions``) and names its method (``sweep_method``,
``sweep_fallback_reason``).

The building blocks (statuses, :class:`~model.stability.tracking.Crossing`, branch continuation) are
in
:mod:`model.stability.tracking`; :func:`pk_sweep`, the exact-Theodorsen p-k cross-check on the same
generalised coordinates, is in :mod:`model.stability.pk` (its branches are continued with adaptive
sub-steps and its crossing is verified the same way). Both are re-exported here.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import brentq, linear_sum_assignment

from model.aeroelastic.statespace import (
    AeroelasticSystem,
    divergence_mechanism,
    divergence_speed_static,
)
from model.errors import BridgeflapInputError
from model.results import ResultData, sweep_dataset, sweep_frame
from model.stability.pk import (  # noqa: F401 - the p-k check is part of this module's public face
    PK_RESIDUAL_TOL,
    PKResult,
    exact_residual,
    pk_residual,
    pk_sweep,
)
from model.stability.tracking import (  # noqa: F401 - statuses and helpers are re-exported
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


@dataclass(frozen=True)
class StabilitySweep(ResultData):
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
    method : str
        The sweep that produced the numbers, ``"dense"`` or ``"fast"`` (:func:`sweep`).
    eigen_solutions : int
        Dense eigenvalue problems of ``A(U)`` solved (a fast sweep that fell back to dense
        counts both).
    fallback_reason : str
        Why a fast sweep fell back to the dense one ("" otherwise).
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
    method: str = "dense"
    eigen_solutions: int = 0
    fallback_reason: str = ""

    _HEADLINE_KEYS = ("flutter_speed_m_s", "flutter_frequency_hz", "flutter_status",
                      "divergence_speed_m_s", "divergence_status", "critical_branch_label",
                      "speed_min_m_s", "speed_max_m_s", "sweep_method", "eigen_solutions")

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
            "divergence_mechanism": self.divergence.mechanism,
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
            "sweep_method": self.method,
            "sweep_fallback_reason": self.fallback_reason,
            "eigen_solutions": int(self.eigen_solutions),
        }

    def to_dataframe(self):
        """One row per speed x branch (:func:`model.results.sweep_frame`)."""
        return sweep_frame(self)

    def to_xarray(self, attrs=None):
        """The branches on ``(branch, speed_m_s)`` (:func:`model.results.sweep_dataset`)."""
        return sweep_dataset(self, attrs)

    def plot_root_locus(self, ax=None, title: str = "root locus", reference=None):
        """Tracked branches in the complex plane (both axes 1/s, coloured by wind speed);
        ``reference``: another sweep drawn in grey (:func:`model.stability.plots.root_locus`)."""
        from model.stability.plots import root_locus

        return root_locus(self, ax, title=title, reference=reference)

    def plot(self, axes=None, title: str = "", reference=None):
        """Root locus (left), V-g and V-f (right), unclipped
        (:func:`model.stability.plots.stability_panels`)."""
        from model.stability.plots import stability_panels

        return stability_panels(self, axes, title=title, reference=reference)


# ------------------------------------------------------------------ the sweep


#: ``method`` of :func:`sweep`: ``"dense"`` (every grid speed) or ``"fast"``
# (:mod:`model.stability.hopf`)
SWEEP_METHODS = ("dense", "fast")


def sweep(system: AeroelasticSystem, speeds, speed_tol: float = 1e-3,
          method: str = "dense", critical_only: bool = False) -> StabilitySweep:
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
        the grid's range and Newton on the critical eigenpairs (:mod:`model.stability.hopf`),
        falling back to ``dense`` when unsure (``fallback_reason``). Both give the same fields and
        statuses; the fast path's ``speeds``, ``eigenvalues`` and ``branches`` are on its
        coarse speeds.
    critical_only : bool
        Crossings alone (do no harm): no second branch, no label check
        (model.stability.hopf.fast_sweep).
    """
    if method not in SWEEP_METHODS:
        raise BridgeflapInputError("sweep", f"must be one of {SWEEP_METHODS}, got {method!r}")
    speeds = check_speeds(speeds)
    from model.stability.hopf import CountedSystem, fast_sweep

    counted = CountedSystem(system)
    if method == "fast":
        def dense(reason):
            return replace(_dense_sweep(counted, speeds, speed_tol, critical_only),
                           fallback_reason=reason)

        return fast_sweep(counted, speeds, speed_tol, dense, critical_only)
    return _dense_sweep(counted, speeds, speed_tol, critical_only)


def _upper(lam, n):
    """Indices of the ``n`` eigenvalues of the upper half plane (real ones too) smallest in
    modulus."""
    return np.argsort(np.where(lam.imag >= 0, np.abs(lam), np.inf))[:n]


def _structural_start(system):
    """Branch labels and the branches' values at ``U = 0`` (upper half plane).

    The labels are the structural modes' (the dominant coordinate of each eigenvector of the
    structure alone, :meth:`~model.aeroelastic.statespace.AeroelasticSystem.structural_matrix`). The
    values are the eigenvalues of the structural block of ``A(0)`` (rows and columns ``q, q'``:
    the structure with the still-air terms of the aerodynamic model, e.g. the apparent mass of
    a Roger fit, whose lag states do not act at ``U = 0``), each matched to the structural mode
    whose shape it has: linear assignment on the mass-weighted overlap
    ``|phi^H M psi|^2 / (phi^H M phi psi^H M psi)`` of the ``q`` parts. Matching by eigenvalue
    distance fails where the still-air terms move the spectrum more than the modes' spacing:
    IABSE 1.1c's fit raises heave from 0.63 to 1.73 rad/s and pitch from 1.75 to 2.78 rad/s,
    and the sweep's assignment at ``U = 0`` gave pitch's label to the shifted heave mode and
    heave a lag state's zero; close modes with different apparent masses swap too (IABSE
    2a:bb3's TS1, 1.749 to 1.730 rad/s, and VA4, 1.769 to 1.747 rad/s, named its TS1-VS1
    flutter VA4; several close pairs of Humber's 30 modes).
    Where ``A(0)`` couples the structure to other states (a compensator), the sweeps' own
    assignment at ``U = 0`` takes these values to the nearest eigenvalues of ``A(0)``.
    """
    n = system.basis.n
    lam0, V0 = _eig(system.structural_matrix())
    up = _upper(lam0, n)
    dominant = np.argmax(np.abs(V0[:n, up]) ** 2, axis=0)
    labels = tuple(system.basis.labels[d] for d in dominant)
    idx = np.arange(system.n_states)
    qq = np.r_[idx[system.index.q], idx[system.index.q_dot]]
    lam_a, V_a = _eig(system.A0[np.ix_(qq, qq)])  # A(0) = A0, from its part (not counted)
    ua = _upper(lam_a, n)
    M = system.basis.M
    phi, psi = V0[:n, up], V_a[:n, ua]
    norm = np.real(np.einsum("ij,ik,kj->j", phi.conj(), M, phi))[:, None] * \
        np.real(np.einsum("ij,ik,kj->j", psi.conj(), M, psi))[None, :]
    overlap = np.abs(phi.conj().T @ M @ psi) ** 2 / norm
    _, cols = linear_sum_assignment(-overlap)
    return labels, lam_a[ua][cols]


def _shares(system, vec, energy="kinetic"):
    """Energy shares of the structural coordinates in the state vector ``vec``: kinetic
    ``M_jj |q_j|^2`` or strain ``K_jj |q_j|^2`` (a static mode has no kinetic energy)."""
    m = system.basis.M if energy == "kinetic" else system.basis.K
    vq = np.real(np.diag(m)) * np.abs(vec[system.index.q]) ** 2
    return vq / vq.sum()


def _name_flutter(system, flutter, labels, vector):
    """Flutter crossing named (and its participation), ``vector()`` its eigenvector."""
    if flutter.status != CONVERGED:
        return flutter, {}
    n = system.basis.n
    # kinetic-energy shares of the structural coordinates, M_jj |q_j|^2 (mass-normalised
    # modes: |q_j|^2; a 2-DOF section: m |h|^2 against I |alpha|^2, never m + rad)
    vq = _shares(system, vector())
    participation = {system.basis.labels[j]: float(vq[j]) for j in range(n)}
    # label: the branch tracked from U = 0 that the critical eigenvalue continues; a
    # critical eigenvalue that is no tracked branch (a compensator or lag mode) is named
    # by its largest participation
    if flutter.branch >= 0:
        return replace(flutter, branch=flutter.branch % n, label=labels[flutter.branch % n],
                       label_source="tracking"), participation
    return replace(flutter, label=max(participation, key=participation.get),
                   label_source="participation"), participation


def _name_divergence(system, divergence, labels, vector):
    """Divergence crossing named by its mechanism, ``vector()`` its (real) eigenvector.

    The label is the coordinate whose deflection does the largest share of the static
    aerodynamic work (:func:`divergence_mechanism`), not the largest strain-energy share: on a
    deck the twist's lift bends the deck, so the heave mode VS1 carries most of the strain
    energy of a torsional divergence (80 % on the built-in Humber) though it makes no static
    load. A branch tracked from U = 0 keeps its index; the tracked name (the mode the real
    eigenvalue's branch started from) is used only when the work cannot be split.
    """
    if divergence.status != CONVERGED:
        return divergence
    n = system.basis.n
    try:
        mechanism, source = divergence_mechanism(system, vector())
    except (AttributeError, TypeError, ValueError, np.linalg.LinAlgError):
        mechanism, source = "", ""  # a system without the static pieces: left unnamed
    branch = divergence.branch % n if divergence.branch >= 0 else -1
    if source:  # the dense and the fast sweep name it alike, tracked or not
        return replace(divergence, branch=branch, label=source, label_source="static_aero_work",
                       mechanism=mechanism)
    if branch >= 0:
        return replace(divergence, branch=branch, label=labels[branch], label_source="tracking")
    vq = _shares(system, vector(), "strain")
    return replace(divergence, label=system.basis.labels[int(np.argmax(vq))],
                   label_source="participation")


def _critical_vector(system, u, omega_tol, kind):
    """Eigenvector of the flutter (largest real part, oscillatory) or divergence (real,
    nearest zero) eigenvalue of ``A(u)``: one dense eigen-solution with vectors."""
    lam, V = _eig(system.A(u))
    if kind == "flutter":
        sel = np.where(np.abs(lam.imag) > omega_tol)[0]
        return V[:, sel[np.argmax(lam[sel].real)]]
    sel = np.where(np.abs(lam.imag) <= omega_tol)[0]
    return V[:, sel[np.argmin(np.abs(lam[sel].real))]]


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
    divergence = _name_divergence(
        system, divergence, labels,
        lambda: _critical_vector(system, divergence.speed, omega_tol, "divergence"))
    second = (Crossing(float("nan"), float("nan"), NOT_EVALUATED) if critical_only else
              _second_crossing(system, speeds, branches, labels, flutter, speed_tol, omega_tol))
    return StabilitySweep(speeds=speeds, eigenvalues=all_lam, branches=branches,
                          branch_labels=labels, flutter=flutter, divergence=divergence,
                          divergence_static_speed=u_static, critical_branch=flutter.label,
                          critical_participation=participation, second_flutter=second,
                          tracking_substeps=budget.used, tracking_forced_steps=budget.forced,
                          method="dense", eigen_solutions=system.count)


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
