"""Flutter and divergence with few eigen-solutions: a coarse tracked sweep, then Newton.

The dense sweep (:func:`bridgeflap.model.stability.sweeps.sweep`, ``method="dense"``) solves one
eigenvalue problem per grid speed (171 on the default 0:85:0.5 m/s grid) plus Brent's and the
verification's continuations. This module (``method="fast"``) gives the same result with a fraction
of them:

1. **coarse sweep** over the same speed range with the sweep's branch tracking
   (:func:`bridgeflap.model.stability.tracking._track_interval`, from ``U = 0``), at an adaptive
   step: at most ``span / COARSE_INTERVALS``, shortened to ``OVERSHOOT`` times the distance at which
   any stable branch (or the flutter / divergence indicator) is predicted, from its value, slope and
   curvature, to reach ``Re lambda = 0``, never below ``span / MIN_STEP_DIVISOR``; its
   assignment treats coincident eigenvalues as one and tests a near-double pair on its
   difference (:data:`bridgeflap.model.stability.tracking.COINCIDENT`,
   :func:`bridgeflap.model.stability.tracking._pairs_resolved`: Great Belt's identical side spans),
   where no step halving could separate the two;
2. **Newton on the critical eigenpair** in the first bracket of a sign change: the Hopf point
   ``(A(U) - i w I) v = 0, c^H v = 1`` (unknowns ``U, w`` real, ``v`` complex) for flutter,
   ``A(U) v = 0, c^T v = 1`` (``U``, ``v`` real) for divergence, with the exact derivative
   ``dA/dU = A1 + 2 U A2`` (``A(U) = A0 + U A1 + U^2 A2``,
   :mod:`bridgeflap.model.aeroelastic.statespace`); a divergence Newton that fails from the
   interpolated zero restarts at the smallest static root ``det(K - U^2 Q) = 0`` in the bracket
   (:func:`bridgeflap.model.stability.hopf_newton._static_seeded`);
3. **verification** as :func:`bridgeflap.model.stability.crossings._verify`: the point is a root
   (Newton residual), ``d Re lambda / dU > 0`` (exact, bordered solve) and the eigenvalue stays
   oscillatory (flutter) or real (divergence) a bracket either side; the eigenpair continued by
   Newton (linear solves only) to the grid speeds of the bracket is stable at the lower and
   not stable at the upper one, and names the tracked branch if, continued on back through
   the coarse speeds, it stays on that branch (:func:`_confirmed`; else the participation
   names it, as the dense sweep names a crossing its tracking lost); one dense ``eigvals`` at the
   crossing confirms the eigenvalue and that no other eigenvalue of its kind is unstable there;
4. **dense fallback**: when the tracking is unsure (a forced step), Newton does not converge,
   the eigenvalue is nearly defective (:data:`NEAR_DEFECTIVE`) or a verification fails, the
   crossing is located as the dense sweep does on the grid speeds of its coarse bracket
   (:func:`_grid_crossing`); a result there that is not converged (``unverified_crossing``,
   ``bracket_failed``) is the dense sweep's own and kept, anything else runs the whole dense
   sweep and returns its result, with the reason in ``fallback_reason``.

Eigen-solutions are counted as calls of ``A(U)`` through :class:`CountedSystem` (each is one
dense eigenvalue problem); the structural one at ``U = 0`` and the static divergence condition
(``n x n``), common to both methods, are not counted."""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from bridgeflap.model.aeroelastic.statespace import divergence_speed_static
from bridgeflap.model.stability.crossings import (
    _critical_vector,
    _indicator,
    _locate,
    _name_divergence,
    _name_flutter,
    _structural_start,
)

# Newton's solvers are part of this module's face
from bridgeflap.model.stability.hopf_newton import (  # noqa: F401
    NEWTON_MAXITER,
    FastPathError,
    _inverse_vector,
    _static_seeded,
    divergence_newton,
    hopf_newton,
    static_roots,
)
from bridgeflap.model.stability.result import StabilitySweep
from bridgeflap.model.stability.tracking import (
    _A,
    COINCIDENT,
    CONVERGED,
    NEWTON_RTOL,  # noqa: F401 - re-exported with the solvers
    NO_CROSSING,
    NOT_EVALUATED,
    TRACKING_BUDGET_MIN,
    UNSTABLE_AT_FIRST,
    Crossing,
    _assign,
    _bracket_half_width,
    _branch_of,
    _Budget,
    _max_real_real,
    _scale,
    _track_interval,
    continue_eigenpair,
    eigen_sensitivity,
    oscillation_tolerance,
)

#: the coarse step is at most the speed range over this many intervals (10: 8.5 m/s on
#: Humber's 0-85 m/s, a step its 30-mode branches track with few sub-steps)
COARSE_INTERVALS = 10
#: a step ends at this multiple of the predicted distance to the nearest ``Re lambda = 0`` (a
#: little past it, so that one more point brackets the crossing)
OVERSHOOT = 1.3
#: the smallest adaptive step is the range over this many intervals
MIN_STEP_DIVISOR = 400
#: an eigenvalue with ``|y^H v| / (|y| |v|)`` below this is treated as nearly defective (the
#: threshold of :data:`model.spectrum.DEFECT_TOL`; the measure depends on the states' scaling,
#: and simple flutter eigenvalues of the IABSE 2a bridge measure 3e-8)
NEAR_DEFECTIVE = 1e-8


class CountedSystem:
    """An :class:`~bridgeflap.model.aeroelastic.statespace.AeroelasticSystem` whose ``A(U)`` calls
    are counted."""

    def __init__(self, system):
        self._system, self.count = system, 0

    def A(self, wind_speed):
        self.count += 1
        return self._system.A(wind_speed)

    def __getattr__(self, name):
        return getattr(self._system, name)


class BalancedSystem:
    """``A(U)`` parts in balanced coordinates ``D^-1 A D`` for Newton's linear solves.

    ``D`` (:func:`scipy.linalg.matrix_balance` of ``A(speed)``, powers of 2, no permutation)
    equalises row and column norms as LAPACK's ``geev`` does: without it a residual test on a
    matrix whose entries span many decades (stiffness and lag states) stops far from the
    eigenvalue that ``eigvals`` finds. Eigenvalues are unchanged; an eigenvector ``v`` of the
    balanced matrix is ``D v`` in the states. ``A(U)`` (the full, counted matrix for dense
    eigen-solutions) and every other attribute are the original system's.
    """

    def __init__(self, system, speed):
        _, (d, _) = sla.matrix_balance(_A(system, speed), permute=False, separate=True)
        self._system, self.d = system, d
        self.A0, self.A1, self.A2 = ((a * d[None, :]) / d[:, None]
                                     for a in (system.A0, system.A1, system.A2))

    def A(self, wind_speed):
        return self._system.A(wind_speed)

    def states(self, v):  # an eigenvector in the original states
        return None if v is None else self.d * v

    def __getattr__(self, name):
        return getattr(self._system, name)


# ------------------------------------------------------------------ the coarse sweep

class _March:
    """Coarse adaptive sweep: speeds, all eigenvalues, tracked branches, indicators."""

    def __init__(self, system, speeds, start, omega_tol, stop_after_rel=None):
        self.system, self.omega_tol = system, omega_tol
        # the first speed above 0 where an indicator is unstable (stop_after_rel: the march
        # ends this fraction past it)
        unstable_at = None
        u_lo, u_hi = float(speeds[0]), float(speeds[-1])
        span = u_hi - u_lo
        h_max, h_min = span / COARSE_INTERVALS, span / MIN_STEP_DIVISOR
        self.budget = _Budget(TRACKING_BUDGET_MIN)
        cur = np.concatenate([start, start.conj()])
        slope = np.zeros(cur.size, complex)
        pts, lams, tracked, fv, dv, slopes = [], [], [], [], [], []
        u_prev, U = 0.0, u_lo
        while True:
            lam = np.linalg.eigvals(system.A(U))
            if U == 0.0:
                cur, _ = _assign(cur, lam, omega_tol, COINCIDENT)
            else:
                cur, slope = _track_interval(system, u_prev, cur, slope, U, lam, omega_tol,
                                             self.budget, 9 if pts else 12, COINCIDENT)
            osc = np.abs(lam.imag) > omega_tol
            pts.append(U)
            lams.append(lam)
            tracked.append(cur)
            slopes.append(slope)
            fv.append(lam[osc].real.max() if np.any(osc) else -np.inf)
            dv.append(_max_real_real(lam, omega_tol) if U > 0 else -np.inf)
            if U >= u_hi or self.budget.forced:
                break  # a forced step: the fast path will not trust its branches
            if (stop_after_rel is not None and unstable_at is None and U > 0
                    and max(fv[-1], dv[-1]) > 1e-6 * omega_tol):
                unstable_at = U
            if unstable_at is not None and U >= unstable_at * (1.0 + stop_after_rel):
                break  # every crossing up to this speed is bracketed: the first one is known
            h = min(h_max, max(h_min, OVERSHOOT * self._distance(pts, tracked, slopes, fv, dv)))
            u_prev, U = U, (u_hi if U + h >= u_hi - 1e-9 * h_max else U + h)
        self.speeds = np.array(pts)
        self.eigenvalues = np.array(lams)
        self.tracked = np.array(tracked).T
        self.flutter_vals, self.div_vals = np.array(fv), np.array(dv)

    def _distance(self, pts, tracked, slopes, fv, dv) -> float:
        """Smallest predicted speed increment [m/s] at which a stable branch or indicator
        reaches zero: ``q + s h + max(k, 0) h^2 / 2 = 0`` (value, slope, curvature)."""
        neutral = 1e-6 * self.omega_tol
        q, s = tracked[-1].real, slopes[-1].real
        k = np.zeros_like(s)
        if len(pts) >= 2 and pts[-1] > pts[-2]:
            k = (s - slopes[-2].real) / (pts[-1] - pts[-2])
            for vals in (fv, dv):
                if np.isfinite(vals[-1]) and np.isfinite(vals[-2]):
                    q = np.append(q, vals[-1])
                    s = np.append(s, (vals[-1] - vals[-2]) / (pts[-1] - pts[-2]))
                    k = np.append(k, 0.0)
        k = np.maximum(k, 0.0)
        best = np.inf
        for qi, si, ki in zip(q, s, k, strict=True):
            if not qi < -neutral:
                continue
            if ki > 0:
                disc = si * si - 2 * ki * qi
                d = (-si + np.sqrt(disc)) / ki
            elif si > 0:
                d = -qi / si
            else:
                continue
            best = min(best, d)
        return best


def _first_bracket(vals, speeds, omega_tol):
    """Index of the first sign change of ``vals`` (as
    :func:`bridgeflap.model.stability.crossings._locate`), or the
    :class:`Crossing` without one (unstable at the first speed, no crossing in range)."""
    if np.isfinite(vals[0]) and vals[0] > 1e-6 * omega_tol:
        return Crossing(float("nan"), float("nan"), UNSTABLE_AT_FIRST, (speeds[0], speeds[0]))
    stable = vals < 0
    stable[0] |= bool(speeds[0] == 0.0 and vals[0] <= 1e-6 * omega_tol)
    idx = np.where(stable[:-1] & (vals[1:] >= 0))[0]
    return int(idx[0]) if idx.size else Crossing(float("nan"), float("nan"), NO_CROSSING)


def _grid_crossing(system, speeds, march, tol, omega_tol, kind, why, accept=False):
    """A crossing the fast path could not verify (``why``), located as the dense sweep does
    (:func:`bridgeflap.model.stability.crossings._locate`) on the grid speeds around its coarse
    bracket.

    Kept only when not converged there (``unverified_crossing``, ``bracket_failed``: e.g. an
    unstable complex pair turning into two positive real eigenvalues, where no eigenvalue
    passes zero): the dense sweep's first grid sign change is the coarse sweep's, as the fast
    path assumes throughout, so the dense sweep would return the same. Anything else (the grid
    point below the bracket not stable, no grid sign change in it, a converged crossing that
    Newton missed) raises: the whole dense sweep decides. With ``accept`` (the sweep's
    ``critical_only``) a converged crossing is kept too: it is the dense sweep's own Brent
    root and verification on the same grid bracket, only named by its participation, not by
    the dense sweep's branch tracking.
    """
    i = _first_bracket(march.flutter_vals if kind == "flutter" else march.div_vals,
                       march.speeds, omega_tol)
    lo = max(int(np.searchsorted(speeds, march.speeds[i], "right")) - 1, 0)
    vals = []
    for u in speeds[lo:int(np.searchsorted(speeds, march.speeds[i + 1])) + 1]:
        vals.append(_indicator(system, u, omega_tol, kind) if u > 0 or kind == "flutter"
                    else -np.inf)
        if len(vals) > 1 and vals[-1] >= 0:  # the first grid sign change: no more needed
            break
    sub = speeds[lo:lo + len(vals)]
    if not (vals[0] < 0 or speeds[lo] == 0.0):  # the dense sweep's first sign change is below
        raise FastPathError(why)
    got = _locate(system, sub, np.array(vals), tol, omega_tol, kind,
                  np.full((1, sub.size), np.nan))
    if got.status in (NO_CROSSING, UNSTABLE_AT_FIRST) or (got.status == CONVERGED
                                                          and not accept):
        raise FastPathError(why)
    return got


def _interp_zero(a, b, fa, fb):
    return a + (b - a) * (-fa) / (fb - fa) if fb > fa and np.isfinite(fa) else b


def _check_bracket_sides(system, u, lam, v, tol, omega_tol, kind):
    """The crossing eigenvalue continued ``u -+ d`` (:func:`_bracket_half_width`) changes the
    sign of its real part and keeps its kind (oscillatory or real)."""
    d = _bracket_half_width(u, tol)
    lo, hi = max(u - d, 0.5 * u), u + d
    l_lo, _, ok_lo = continue_eigenpair(system, u, lam, v, lo)
    l_hi, _, ok_hi = continue_eigenpair(system, u, lam, v, hi)
    osc = [abs(x.imag) > omega_tol for x in (l_lo, l_hi)]
    typed = all(osc) if kind == "flutter" else not any(osc)
    if not (ok_lo and ok_hi and typed and l_lo.real < 0 < l_hi.real):
        raise FastPathError(f"{kind}: no sign change of the eigenvalue across the bracket")


def _hopf(system, march, i, lam_a, lam_b, tol, omega_tol, kind="flutter"):
    """Newton on the Hopf point of the branch going from ``lam_a`` (speed index ``i``) to
    ``lam_b`` (``i + 1``), verified. Returns ``(U, lam, v, slope, (lam, v) continued to a)``."""
    sp = march.speeds
    a, b = float(sp[i]), float(sp[i + 1])
    u_g = _interp_zero(a, b, lam_a.real, lam_b.real)
    lam_g = lam_a + (lam_b - lam_a) * (u_g - a) / (b - a)
    if lam_g.imag < 0:
        lam_g = lam_g.conjugate()
    def newton(v0):
        # intermediate iterates may leave the bracket; the root must lie in it
        u, w, v, res, _ = hopf_newton(system, u_g, lam_g, v0,
                                      bounds=(max(a - 4 * (b - a), 0.0), b + 4 * (b - a)))
        if not a - 1e-12 * b <= u <= b + 1e-12 * b:
            raise FastPathError(f"{kind}: Newton converged outside the bracket ({u:.6g} m/s)")
        return u, w, v, res

    u, w, v, res = _with_retry(newton, system, u_g, lam_g, omega_tol, "flutter")
    if w < 0:
        w, v = -w, v.conj()
    lam = 1j * w
    dlam, _, cond = eigen_sensitivity(system, u, lam, v)
    if cond < NEAR_DEFECTIVE:
        raise FastPathError(f"{kind}: nearly defective eigenvalue (conditioning {cond:.2g})")
    if not (w > omega_tol and dlam.real > 0):
        raise FastPathError(f"{kind}: no transversal crossing (d Re/dU = {dlam.real:.3g} 1/m)")
    _check_bracket_sides(system, u, lam, v, tol, omega_tol, "flutter")
    l_a, v_a, ok_a = continue_eigenpair(system, u, lam, v, a) if a != u else (lam, v, True)
    l_b, _, ok_b = continue_eigenpair(system, u, lam, v, b) if b != u else (lam, v, True)
    stable_a = l_a.real < 0 or (a == 0.0 and l_a.real <= 1e-6 * omega_tol)
    if not (ok_a and ok_b and stable_a and l_b.real >= 0):
        raise FastPathError(f"{kind}: the branch jumps between the coarse speeds")
    return u, lam, v, float(dlam.real), (l_a, v_a)


def _confirmed(system, march, i, j, lam, v):
    """``j``, when the eigenpair ``(lam, v)`` of tracked branch ``j`` at coarse speed ``i``,
    continued by Newton back through the coarse speeds to the first, is branch ``j`` at each;
    else -1 (the label is then the participation's, as where the dense sweep's tracking lost
    the branch). A coarse step can jump onto another branch where the true continuation turns
    real (no competitor of the assignment): IABSE 1.1c's RFA moves the still-air spectrum far
    from the structure's, and a start matched by eigenvalue distance gave the pitch label to
    the shifted heave mode. The last step, to the first speed, halves as often as the coarse
    sweep's first interval (12 times; 1.1c's branches move fastest below 1 m/s)."""
    n = march.tracked.shape[0] // 2
    for k in range(i - 1, -1, -1):
        lam, v, ok = continue_eigenpair(system, march.speeds[k + 1], lam, v, march.speeds[k],
                                        halvings=12 if k == 0 else 8)
        b = _branch_of(lam, march.tracked[:, k])
        if not ok or b < 0 or b % n != j % n:
            return -1
    return j


def _with_retry(newton, system, u_g, lam_g, omega_tol, kind):
    """``newton(v0)`` from the inverse-iteration vector; if it fails (a cluster of eigenvalues
    near ``lam_g`` slows inverse iteration, e.g. aerodynamic lag and compensator poles near 0),
    once more from the eigenvector of the nearest eigenvalue of its kind at ``u_g`` (one more
    dense eigen-solution)."""
    try:
        return newton(_inverse_vector(system, u_g, lam_g, real=kind == "divergence"))
    except FastPathError:
        lam, V = sla.eig(system.A(u_g))
        osc = np.abs(lam.imag) > omega_tol
        ok = (osc & (lam.imag > 0)) if kind == "flutter" else ~osc
        if not np.any(ok):
            raise
        k = np.where(ok)[0][np.argmin(np.abs(lam[ok] - lam_g))]
        d = getattr(system, "d", None)
        return newton(V[:, k] / d if d is not None else V[:, k])


def _candidates(march, i, omega_tol):
    """Tracked oscillatory branches (upper halves) whose real part changes sign on ``(i, i+1)``,
    earliest interpolated zero first: ``[(u_zero, j)]``."""
    tr = march.tracked
    out = []
    for j in range(tr.shape[0]):
        la, lb = tr[j, i], tr[j, i + 1]
        if not (la.real < 0 <= lb.real or (i == 0 and la.real <= 0 <= lb.real)):
            continue
        if la.imag > omega_tol and lb.imag > omega_tol:
            out.append((_interp_zero(march.speeds[i], march.speeds[i + 1], la.real, lb.real), j))
    return sorted(out)


def _flutter(system, march, tol, omega_tol, confirm=True):
    """Verified flutter crossing of the coarse sweep: ``(Crossing, eigenvector or None)``.

    ``confirm=False`` (``critical_only``) skips :func:`_confirmed`: the branch is then named
    by the participation (the speed, frequency and status are the same)."""
    sp = march.speeds
    i = _first_bracket(march.flutter_vals, sp, omega_tol)
    if isinstance(i, Crossing):
        return i, None
    a, b = float(sp[i]), float(sp[i + 1])
    cand = _candidates(march, i, omega_tol)
    if cand:
        j = cand[0][1]
        lam_a, lam_b = march.tracked[j, i], march.tracked[j, i + 1]
    else:  # the crossing eigenvalue is no tracked branch (a compensator mode): start at b
        lb = march.eigenvalues[i + 1]
        osc = np.where(lb.imag > omega_tol)[0]
        lam_b = complex(lb[osc[np.argmax(lb[osc].real)]])
        lam_a = lam_b
    u, lam, v, slope, (l_a, v_a) = _hopf(system, march, i, lam_a, lam_b, tol, omega_tol)
    branch = _branch_of(l_a, march.tracked[:, i])
    branch = (_confirmed(system, march, i, branch, l_a, v_a) if branch >= 0 and confirm
              else -1)
    _only_unstable(system, u, lam, omega_tol, "flutter")
    return Crossing(float(u), float(lam.imag / (2 * np.pi)), CONVERGED, (a, b),
                    re_slope_per_m=slope, branch=branch), v


def _only_unstable(system, u, lam, omega_tol, kind):
    """One dense eigen-solution at the crossing: ``lam`` is an eigenvalue of ``A(u)`` and no
    other eigenvalue of its kind has a positive real part (it is the indicator's zero)."""
    ev = np.linalg.eigvals(system.A(u))
    dist = np.minimum(np.abs(ev - lam), np.abs(ev - np.conj(lam)))
    scale = _scale(_A(system, u))
    if dist.min() > 1e-8 * scale:
        raise FastPathError(f"{kind}: the Newton eigenvalue is not in the spectrum")
    same = dist <= max(1e-8 * scale, 2 * dist.min())
    osc = np.abs(ev.imag) > omega_tol
    others = ev[(osc if kind == "flutter" else ~osc) & ~same]
    if others.size and others.real.max() > 1e-6 * omega_tol:
        raise FastPathError(f"{kind}: another eigenvalue is unstable at the crossing")


def _divergence(system, march, tol, omega_tol, name=True):
    """Verified divergence crossing: ``(Crossing, eigenvector or None)``.

    ``name=False`` (``critical_only``) skips the continuation to the coarse bracket's ends
    that finds the tracked branch (the static aerodynamic work names it in either case)."""
    sp, vals = march.speeds, march.div_vals
    i = _first_bracket(vals, sp, omega_tol)
    if isinstance(i, Crossing):
        return i, None
    a, b = float(sp[i]), float(sp[i + 1])
    u_g = _interp_zero(a, b, vals[i], vals[i + 1])
    def newton(v0, u0=u_g):
        u, v, _, _ = divergence_newton(system, u0, v0.real,
                                       bounds=(max(a - 4 * (b - a), 0.0), b + 4 * (b - a)))
        if not a - 1e-12 * b <= u <= b + 1e-12 * b:
            raise FastPathError(f"divergence: Newton converged outside the bracket ({u:.6g} m/s)")
        return u, v

    try:
        u, v = _with_retry(newton, system, u_g, 0.0, omega_tol, "divergence")
    except FastPathError:
        u, v = _static_seeded(newton, system, a, b)
    vc = v.astype(complex)
    dlam, _, cond = eigen_sensitivity(system, u, 0.0, vc)
    if cond < NEAR_DEFECTIVE:
        raise FastPathError(f"divergence: nearly defective eigenvalue (conditioning {cond:.2g})")
    if not dlam.real > 0:
        raise FastPathError("divergence: no transversal crossing")
    _check_bracket_sides(system, u, 0.0j, vc, tol, omega_tol, "divergence")
    _only_unstable(system, u, 0.0j, omega_tol, "divergence")
    if not name:
        return Crossing(float(u), 0.0, CONVERGED, (a, b), re_slope_per_m=float(dlam.real)), v
    l_a, _, ok_a = continue_eigenpair(system, u, 0.0, vc, a)
    branch = _branch_of(l_a, march.tracked[:, i]) if ok_a else -1
    if branch < 0:
        l_b, _, ok_b = continue_eigenpair(system, u, 0.0, vc, b)
        branch = _branch_of(l_b, march.tracked[:, i + 1]) if ok_b else -1
    return Crossing(float(u), 0.0, CONVERGED, (a, b), re_slope_per_m=float(dlam.real),
                    branch=branch), v


def _second(system, march, labels, flutter, tol, omega_tol):
    """The next tracked oscillatory branch to cross after the critical one (as
    :func:`bridgeflap.model.stability.sweeps._second_crossing`), by Newton from its coarse
    bracket."""
    if flutter.status != CONVERGED:
        return Crossing(float("nan"), float("nan"), NOT_EVALUATED)
    n = len(labels)
    br = march.tracked[:n]
    re, osc = br.real, np.abs(br.imag) > omega_tol
    best = None
    for j in range(n):
        if j == flutter.branch:
            continue
        idx = np.where((re[j, :-1] < 0) & (re[j, 1:] >= 0) & osc[j, :-1] & osc[j, 1:])[0]
        if idx.size:
            i = int(idx[0])
            uz = _interp_zero(march.speeds[i], march.speeds[i + 1], re[j, i], re[j, i + 1])
            if best is None or uz < best[0]:
                best = (uz, j, i)
    if best is None:
        return Crossing(float("nan"), float("nan"), NO_CROSSING)
    _, j, i = best
    la, lb = complex(br[j, i]), complex(br[j, i + 1])
    if la.imag < 0:
        la, lb = la.conjugate(), lb.conjugate()
    u, lam, _, slope, (l_a, v_a) = _hopf(system, march, i, la, lb, tol, omega_tol,
                                         "second flutter")
    if _branch_of(l_a, br[:, i]) != j or _confirmed(system, march, i, j, l_a, v_a) != j:
        raise FastPathError("second flutter: the continuation left the branch")
    return Crossing(float(u), float(lam.imag / (2 * np.pi)), CONVERGED,
                    (float(march.speeds[i]), float(march.speeds[i + 1])), re_slope_per_m=slope,
                    label=labels[j], branch=j, label_source="tracking")


# ------------------------------------------------------------------ the fast sweep

def _crossing(find, system, speeds, march, tol, omega_tol, kind, critical_only=False):
    try:
        if critical_only:  # no label confirmation (flutter), no branch naming (divergence)
            return find(system, march, tol, omega_tol, False)
        return find(system, march, tol, omega_tol)
    except FastPathError as exc:
        return _grid_crossing(system, speeds, march, tol, omega_tol, kind, str(exc),
                              accept=critical_only), None


def fast_sweep(system: CountedSystem, speeds, speed_tol, dense, critical_only=False,
               stop_after_rel=None):
    """:func:`bridgeflap.model.stability.sweeps.sweep` with ``method="fast"`` (module docstring).

    ``system`` counts its eigen-solutions; ``dense(reason)`` runs the dense sweep on the same
    counted system (the fallback). ``critical_only``: the flutter and divergence crossings
    alone -- no second-critical branch (``not_evaluated``), no confirmation of the flutter
    branch's label by continuation to ``U = 0`` (the participation names it), and a crossing
    Newton misses is kept from its grid bracket when converged there (:func:`_grid_crossing`)
    instead of running the whole dense sweep. The speeds, frequencies and statuses are those of
    the full fast path; what it saves are the labels' and the second branch's solutions.
    ``stop_after_rel`` (with ``critical_only``): the coarse march ends ``stop_after_rel``
    (relative) past the first speed where the spectrum is unstable, so the first crossing and
    any other within that span above it are found and verified as before; a crossing further
    up is reported absent from the shortened range (``speeds`` ends there).
    """
    omega_tol = oscillation_tolerance(system)
    labels, start = _structural_start(system)
    march = _March(system, speeds, start, omega_tol,
                   stop_after_rel if critical_only else None)
    if march.budget.forced:
        return dense(f"tracking unsure: a forced step at {march.speeds[-1]:.6g} m/s")
    bal = BalancedSystem(system, float(speeds[-1]))
    try:
        (flutter, v_f), (divergence, v_d) = (
            _crossing(find, bal, speeds, march, speed_tol, omega_tol, kind, critical_only)
            for find, kind in ((_flutter, "flutter"), (_divergence, "divergence")))
        v_f, v_d = bal.states(v_f), bal.states(v_d)
        if speeds[0] == 0.0 and _max_real_real(march.eigenvalues[0], omega_tol) > 1e-6 * omega_tol:
            divergence = Crossing(float("nan"), float("nan"), UNSTABLE_AT_FIRST, (0.0, 0.0))
        # a crossing kept from its grid bracket (critical_only) has no Newton eigenvector
        flutter, participation = _name_flutter(system, flutter, labels, lambda: (
            v_f if v_f is not None else _critical_vector(system, flutter.speed, omega_tol,
                                                         "flutter")))
        divergence, div_participation = _name_divergence(system, divergence, labels, lambda: (
            v_d if v_d is not None else _critical_vector(system, divergence.speed, omega_tol,
                                                         "divergence")))
        second = (Crossing(float("nan"), float("nan"), NOT_EVALUATED) if critical_only
                  else _second(bal, march, labels, flutter, speed_tol, omega_tol))
    except FastPathError as exc:
        return dense(str(exc))
    return StabilitySweep(
        speeds=march.speeds, eigenvalues=march.eigenvalues, branches=march.tracked[:len(labels)],
        branch_labels=labels, flutter=flutter, divergence=divergence,
        divergence_static_speed=divergence_speed_static(system), critical_branch=flutter.label,
        critical_participation=participation, divergence_participation=div_participation,
        second_flutter=second, tracking_substeps=march.budget.used,
        tracking_forced_steps=march.budget.forced, method="fast", eigen_solutions=system.count)

