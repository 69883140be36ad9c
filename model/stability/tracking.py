"""Branch continuation and the building blocks of a verified stability crossing.

Statuses, the :class:`Crossing` record and the speed-grid check shared by the RFA sweep
(:mod:`bridgeflap.model.stability.sweeps`) and the exact p-k (:mod:`bridgeflap.model.stability.pk`);
eigenvalue-only continuation of branches with adaptive sub-steps (:func:`_track_interval` for all
structural branches at once,
:func:`_follow` for one eigenvalue near a crossing), both on the step-halving loop
:func:`continue_adaptive` that the p-k continuation shares; one eigenpair continued by Newton,
linear solves only (:func:`continue_eigenpair`, :func:`eigen_sensitivity`: the fast sweep's,
:mod:`bridgeflap.model.stability.hopf`). Method: docs/methods.md#stability.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from scipy.optimize import linear_sum_assignment

from bridgeflap.model.aeroelastic.statespace import AeroelasticSystem
from bridgeflap.model.grid import speed_grid

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
#: eigenvalues nearer each other than this fraction of their modulus are one value to the
#: assignment when it is given ``coincident=COINCIDENT`` (the fast sweep,
# :mod:`model.stability.hopf`):
#: Great Belt's identical side spans give a pair of modes (V-sprogoe4, V-halsskov3) 3.6e-7
#: rad/s apart (6e-8 of |lambda|) at every speed, below the 2.7e-7 rad/s scatter of ``eigvals``
#: on that near-double pair, so no step halving can ever separate them; distinct branches
#: passing this close to each other at one speed keep their identity through the predictor's
#: slope (the secant from the previous, distinct speed)
COINCIDENT = 1e-6
#: flutter onset is "hard" when the damping ratio falls faster than this past the crossing,
#: -d zeta/dU [s/m]: 1e-3 per m/s loses 1 % of critical damping within 10 m/s (about 15 % of
#: the speed of a long-span bridge); slower is "soft" (a gradual, often torsional, onset)
HARD_ONSET_DAMPING_SLOPE_S_PER_M = 1e-3


def check_speeds(speeds) -> np.ndarray:
    """Validate a wind-speed grid [m/s]: finite, non-negative, increasing, at least 2 points.

    ``speeds``: any form of :func:`bridgeflap.model.grid.speed_grid` (``"0:85:0.5"`` text included).
    """
    return speed_grid(speeds, min_points=2, increasing=True)


@dataclass(frozen=True)
class Crossing:
    """A stability boundary: speed [m/s], frequency [Hz] and status.

    ``bracket`` is the grid interval [m/s] of the sign change; ``re_slope_per_m`` the slope
    ``d Re lambda / dU`` [1/s per m/s = 1/m] of the crossing eigenvalue, measured across the
    verification bracket; ``branch`` the tracked structural branch (-1 when the crossing
    eigenvalue is none of them) and ``label`` its name, from ``label_source`` (``"tracking"``
    from U = 0, or ``"participation"``: the largest kinetic-energy share of the crossing
    eigenvector; for divergence ``"static_aero_work"``: the coordinate whose deflection does the
    largest share of the static aerodynamic work,
    :func:`bridgeflap.model.stability.sweeps.divergence_mechanism`); ``reason`` says why a crossing
    is not ``converged``; ``mechanism`` names a divergence by the family of the coordinates that
    generate its static aerodynamic load (``"torsional"``
    for strip loads, where only twist makes static lift and moment).
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
    mechanism: str = ""

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


def _assign(pred, lam, omega_tol, coincident=0.0):
    """Assign each predicted branch value to one eigenvalue of ``lam``.

    The branches are both halves of every structural pair (a pair that turns real gives two
    real eigenvalues, one to each half). Returns the assigned values and whether the assignment
    is ambiguous: an oscillatory branch whose assigned eigenvalue is not nearer its prediction
    than :data:`UNAMBIGUOUS` times the next-nearest oscillatory eigenvalue on its side of the
    real axis (so the step may have swapped two branches; a pair's own halves cannot swap).
    With ``coincident > 0`` eigenvalues within ``coincident`` times the assigned one's modulus
    of it are no other candidate (:data:`COINCIDENT`): a swap among them changes no value.
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
    if coincident > 0:
        got = lam[cols][:, None]
        other[np.abs(lam[None, :] - got) <= coincident * np.maximum(np.abs(got), omega_tol)] = \
            np.inf
    d2 = other.min(axis=1)
    osc = np.abs(pred.imag) > omega_tol
    amb = osc & (d1 > UNAMBIGUOUS * d2)
    if coincident > 0 and np.any(amb):
        amb = _pairs_resolved(pred, lam, cols, other, d1, amb)
    return lam[cols], bool(np.any(amb))


def _pairs_resolved(pred, lam, cols, other, d1, amb):
    """``amb`` less the branches of a near-double pair that moves as one (the fast sweep).

    Branch ``j`` is ambiguous only through the eigenvalue assigned to one branch ``k``, and
    ``k`` only through ``j``'s (no other eigenvalue is near either prediction): the pair is
    the pair's, and within it the assignment is tested as one branch's is, on the difference
    ``lam_j - lam_k`` against its prediction ``pred_j - pred_k``: the identity must be nearer
    than :data:`UNAMBIGUOUS` times the swap (``lam_k - lam_j``). A predictor error common to
    both (the curvature of the pair's joint motion; Great Belt's identical side spans give
    pairs 9e-6 rad/s apart that move 1e-3 rad/s per m/s together) cancels in the difference.
    """
    near = other < (d1 / UNAMBIGUOUS)[:, None]  # the eigenvalues that make a branch ambiguous
    owner = np.full(lam.size, -1)
    owner[cols] = np.arange(cols.size)
    out = amb.copy()
    for j in np.where(amb)[0]:
        m = np.where(near[j])[0]
        k = owner[m[0]] if m.size == 1 else -1
        if k < 0 or not set(np.where(near[k])[0]) <= {cols[j]}:
            continue
        dl, dp = lam[cols[j]] - lam[cols[k]], pred[j] - pred[k]
        if abs(dl - dp) <= UNAMBIGUOUS * abs(dl + dp):
            out[j] = False
    return out


def continue_adaptive(step, u0, y0, s0, u1, halvings, may_halve=None):
    """Continue a value ``y0`` at ``u0`` [m/s] (slope ``s0`` per m/s) to ``u1`` by sub-steps.

    The one step-halving loop of the branch continuations (:func:`_track_interval`,
    :func:`_follow`, the p-k's :func:`bridgeflap.model.stability.pk._pk_continue`). ``step(t,
    prediction)`` returns ``(value at t, good)``; a step that is not good is halved
    (``may_halve()``, when given, must also agree: a budget of extra evaluations) down to
    ``2**-halvings`` of ``|u1 - u0|``, and accepted as it is below that. The linear predictor's
    slope is the last accepted secant (none from a denormal-sized step: a grid starting at 5e-324
    m/s would overflow it).
    Returns ``(value at u1, slope, number of steps accepted although not good)``.
    """
    u, y, s = float(u0), y0, s0
    h = u1 - u0
    h_min = abs(h) / 2 ** halvings
    forced = 0
    while u != u1:
        st = math.copysign(min(abs(h), abs(u1 - u)), h)
        t = u1 if abs(u1 - (u + st)) <= 1e-12 * max(abs(u1), 1.0) else u + st
        val, good = step(t, y + (t - u) * s)
        if not good and abs(st) > 1.5 * h_min and (may_halve is None or may_halve()):
            h = st / 2
            continue
        forced += int(not good)
        if abs(t - u) > 1e-9 * max(abs(u1), 1.0):
            s = (val - y) / (t - u)
        y, u, h = val, t, 2 * st
    return y, s, forced


def _track_interval(system, u0, l0, s0, u1, lam1, omega_tol, budget, halvings=6,
                    coincident=0.0):
    """Continue the branch values ``l0`` at ``u0`` [m/s] (slopes ``s0`` [1/s per m/s]) to ``u1``.

    ``lam1`` are the eigenvalues at ``u1`` (already computed by the sweep). The step is halved
    (eigenvalues only, at the intermediate speed) while the assignment is ambiguous, down to
    ``2**-halvings`` of the interval or until the sweep's budget of extra evaluations is spent;
    a step taken at that limit is counted in ``budget.forced``. ``coincident``: of
    :func:`_assign`.
    """

    half = np.repeat([1.0, -1.0], len(l0) // 2)  # rows: upper halves, then lower halves
    last = [np.asarray(l0)]

    def step(t, pred):
        lam = lam1 if t == u1 else np.linalg.eigvals(system.A(t))
        # a pair that turned real stays on the axis: a linear prediction from its last complex
        # value that overshoots into the other half plane is projected onto the axis (IABSE
        # 1.1c's heave pair turns real at 0.8 m/s, where the overshoot made every step ambiguous)
        over = (half * pred.imag < 0) & (half * last[0].imag >= 0)
        cur, ambiguous = _assign(np.where(over, pred.real, pred), lam, omega_tol, coincident)
        if not ambiguous:
            last[0] = cur
        return cur, not ambiguous

    l, s, forced = continue_adaptive(step, u0, np.asarray(l0), np.asarray(s0), u1, halvings,
                                     budget.take)
    budget.forced += forced
    return l, s


def _follow(system, u0, lam0, u1, omega_tol, halvings=10):
    """One eigenvalue ``lam0`` of ``A(u0)`` continued to ``A(u1)`` [m/s].

    Steps are halved until the eigenvalue nearest the (linear) prediction is nearer than
    :data:`UNAMBIGUOUS` times the next-nearest one. Returns ``(lambda, ok)``; ``ok`` is False
    when the smallest step was still ambiguous (the continuation may have jumped).
    """

    def step(t, pred):
        lam = np.linalg.eigvals(system.A(t))
        d = np.abs(lam - pred)
        k = int(np.argmin(d))
        d2 = np.partition(d, 1)[1] if d.size > 1 else np.inf
        return complex(lam[k]), bool(d[k] <= UNAMBIGUOUS * d2)

    lam, _, forced = continue_adaptive(step, u0, complex(lam0), 0.0j, u1, halvings)
    return lam, forced == 0


def _branch_of(value, column):
    """Index of the tracked branch whose value in ``column`` is ``value`` (or -1)."""
    cand = np.abs(column - value)
    j = int(np.argmin(cand))
    return j if cand[j] <= 1e-6 * max(abs(value), 1e-12) + 1e-12 else -1


def _bracket_half_width(u: float, tol: float) -> float:
    """Half-width [m/s] of the verification bracket around a refined crossing ``u``."""
    return max(10 * tol, 1e-3 * u)



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


# ------------------------------------------------------------------ one eigenpair, by Newton
# (the fast sweep's continuation, :mod:`model.stability.hopf`: linear solves only, no
# eigen-solution)

#: Newton converged: relative residual ``|r| / (|A| |v|)`` [-] (round-off: 1e-16)
NEWTON_RTOL = 1e-11


def _dA(system, U):
    return system.A1 + 2.0 * U * system.A2


def _A(system, U):
    """``A(U)`` from its parts (not counted: no eigen-solution follows)."""
    return system.A0 + U * system.A1 + (U * U) * system.A2


def _scale(A):
    return max(float(np.abs(A).sum(axis=1).max()), 1e-300)


def eigen_sensitivity(system, U, lam, v):
    """``(d lambda / dU [1/m], dv/dU, conditioning |y^H v| / (|y| |v|))`` of a simple eigenpair.

    One LU of the bordered matrix ``[[A - lam I, -v], [c^H, 0]]`` (``c = v / |v|^2``): its
    solution with ``[-dA v; 0]`` is the exact derivative; its conjugate-transposed solve with
    ``[0; 1]`` the left eigenvector ``y`` (``y^H v = -1``).
    """
    A = _A(system, U).astype(complex)
    nx = v.size
    c = v / np.vdot(v, v).real
    B = np.zeros((nx + 1, nx + 1), complex)
    B[:nx, :nx] = A - lam * np.eye(nx)
    B[:nx, nx], B[nx, :nx] = -v, c.conj()
    lu = sla.lu_factor(B, check_finite=False)
    x = sla.lu_solve(lu, np.concatenate([-(_dA(system, U) @ v), [0.0]]), check_finite=False)
    e = np.zeros(nx + 1, complex)
    e[nx] = 1.0
    y = sla.lu_solve(lu, e, trans=2, check_finite=False)[:nx]
    cond = 1.0 / (float(np.linalg.norm(y)) * float(np.linalg.norm(v)))
    return complex(x[nx]), x[:nx], cond


def continue_eigenpair(system, u0, lam0, v0, u1, halvings=8):
    """Eigenpair ``(lam0, v0)`` of ``A(u0)`` continued to ``A(u1)`` by predictor (exact
    derivative) and Newton corrector on ``(A(U) - lam I) v = 0, c^H v = 1``; linear solves only.

    A step is accepted when Newton converges with a correction below a fifth of the step's
    change of ``lambda`` (no jump); else halved, ``halvings`` times at most. ``(lam, v, ok)``.
    """
    u, lam, v = float(u0), complex(lam0), np.asarray(v0, complex)
    h = u1 - u0
    h_min = abs(h) / 2 ** halvings
    while u != u1:
        step = np.copysign(min(abs(h), abs(u1 - u)), h)
        t = u1 if abs(u1 - (u + step)) <= 1e-12 * max(abs(u1), 1.0) else u + step
        dlam, dv, _ = eigen_sensitivity(system, u, lam, v)
        lp, vp = lam + (t - u) * dlam, v + (t - u) * dv
        got = _correct(system, t, lp, vp)
        if got is not None and (abs(got[0] - lp) <= 0.2 * abs(got[0] - lam)
                                + 1e-10 * max(abs(got[0]), 1.0)):
            lam, v, u, h = got[0], got[1], t, 2 * step
            continue
        if abs(step) <= 1.5 * h_min:
            return lam, v, False
        h = step / 2
    return lam, v, True


def _correct(system, U, lam, v, maxiter=8):
    """Newton on ``(A(U) - lam I) v = 0, c^H v = 1`` at fixed ``U``; None if not converged."""
    A = _A(system, U).astype(complex)
    nx = v.size
    c = v / np.vdot(v, v).real
    scale = _scale(A)
    done = False
    for _ in range(maxiter):
        r = A @ v - lam * v
        if done:
            return lam, v
        # one more step once converged: the eigenvalue's error is the residual times its
        # condition number (up to 1e8 here, NEAR_DEFECTIVE), so the residual goes to round-off
        done = bool(np.linalg.norm(r) <= NEWTON_RTOL * scale * np.linalg.norm(v))
        B = np.zeros((nx + 1, nx + 1), complex)
        B[:nx, :nx] = A - lam * np.eye(nx)
        B[:nx, nx], B[nx, :nx] = -v, c.conj()
        try:
            x = np.linalg.solve(B, -np.concatenate([r, [np.vdot(c, v) - 1.0]]))
        except np.linalg.LinAlgError:
            return None
        v, lam = v + x[:nx], lam + x[nx]
    r = A @ v - lam * v
    return (lam, v) if np.linalg.norm(r) <= NEWTON_RTOL * scale * np.linalg.norm(v) else None
