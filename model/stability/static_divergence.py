"""Verified static divergence of an open or closed loop.

The static equilibrium of a system ``A(U) = A0 + U A1 + U^2 A2`` is ``K_ae(U) q = f`` with
``K_ae(U) = K - U^2 Q`` (:func:`bridgeflap.model.aeroelastic.statespace.static_aero_stiffness`:
``C(0) = 1`` for the RFA; with flaps driven by a compensator the static gain ``K(0) = D - C A^{-1}
B`` turns the flap loads of ``beta = K(0) alpha_f`` into stiffness, ``Q = P G0 + K(0) (H0 + g0 PF)
Phi_a``). The static divergence speed is the smallest ``U > 0`` with ``det K_ae(U) = 0``: ``1 /
U^2`` is a real positive eigenvalue of ``K^{-1} Q`` (exact, no grid).

:func:`static_divergence` locates that root and **verifies** it:

1. *root*: the smallest singular value of ``K_ae(U_s)`` is round-off small against ``||K||``
   (:data:`ROOT_RTOL`);
2. *simple*: ``det K_ae`` changes sign across ``U_s (1 -+ STATIC_BRACKET_REL)`` (a root that only
   grazes zero, a double root, is no divergence of the static stiffness);
3. *dynamic crossing*: a real eigenvalue of the state matrix ``A(U)`` passes through zero there
   (the same model seen dynamically): the eigenvalue of ``A(U_s)`` nearest zero is real, stays
   real continued to ``U_s -+ d`` (:data:`DYNAMIC_BRACKET_REL`), changes sign there, and
   Brent's root of its real part lies within :data:`DYNAMIC_MATCH_TOL_M_S` of ``U_s``.

A root that fails one of these is ``unverified_crossing`` with the reason. The record also says
in which direction the real eigenvalue crosses (``stable_to_unstable``: a new aperiodic
instability; ``unstable_to_stable``: a real eigenvalue already in the right half-plane returns,
so the static singularity is no stability limit) and how many eigenvalues are unstable just
below ``U_s``: the static speed is the stability limit only when that count is zero.

Why the eigenvalue sweep can miss it (the default design, ``humber:box``): its closed-loop
flutter pair (unstable from 102.28 m/s) reaches the real axis at ~114.6 m/s as two real
eigenvalues with *positive* real parts; the sweep's divergence indicator (the largest real
eigenvalue) jumps from -0.07 to +0.22 1/s there -- a coalescence, not a zero crossing -- so its
refined point is ``unverified_crossing`` (bracket 114.5..115 m/s), and the real zero crossing at
115.59 m/s (one of the two returning to the left half-plane) lies past the indicator's first
sign change. docs/methods.md#verified-static-divergence.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from bridgeflap.model.aeroelastic.statespace import static_aero_stiffness
from bridgeflap.model.stability.tracking import (
    CONVERGED,
    NO_CROSSING,
    UNVERIFIED,
    _follow,
    oscillation_tolerance,
)

__all__ = ["DYNAMIC_MATCH_TOL_M_S", "StaticDivergence", "static_divergence",
           "static_response", "static_stiffness"]

#: a static root: ``sigma_min(K_ae(U_s)) <= ROOT_RTOL sigma_max(K)`` (eigenvalues of
#: ``K^{-1} Q`` are accurate to ~1e-13 relative; 1e-8 leaves room for conditioning)
ROOT_RTOL = 1e-8
#: relative half-width of the bracket on which ``det K_ae`` must change sign
STATIC_BRACKET_REL = 1e-6
#: relative half-widths of the bracket on which the real eigenvalue of ``A(U)`` at the root,
#: continued either side (:func:`model.stability.tracking._follow`), must stay real and change sign:
# the
#: first that continues unambiguously (a complex pair that splits on the real axis just before
#: the root needs a narrow one: the default design on ``humber:box`` with its pair at -282 m
#: failed splits within 0.005 m/s before it)
DYNAMIC_BRACKET_REL = (1e-4, 1e-5, 1e-6, 1e-7)
#: the dynamic zero crossing (Brent, xtol 1e-9 m/s) must lie this close to the static root [m/s]
DYNAMIC_MATCH_TOL_M_S = 1e-3


def static_stiffness(system, speed_m_s: float) -> np.ndarray:
    """``K_ae(U) = K - U^2 Q`` [modal stiffness] of ``system`` at ``speed_m_s``."""
    u = float(speed_m_s)
    return np.asarray(system.basis.K, float) - u * u * static_aero_stiffness(system)


def static_response(system, speed_m_s: float, load_per_u2) -> np.ndarray:
    """Modal deflection ``q`` of ``K_ae(U) q = U^2 f`` (``load_per_u2``: ``f``, the static load
    per ``U^2`` [N per m^2/s^2 per unit input], one column per input)."""
    u = float(speed_m_s)
    f = np.asarray(load_per_u2, float)
    return np.linalg.solve(static_stiffness(system, u), u * u * f)


@dataclass(frozen=True)
class StaticDivergence:
    """The verified static divergence of one system (module docstring).

    ``speed_m_s``: the smallest static root [m/s] (NaN when none or beyond ``speed_max_m_s``;
    set also when not verified, ``status`` says so); ``dynamic_speed_m_s``: the zero crossing
    of the real eigenvalue of ``A(U)`` found there (NaN when none); ``direction``:
    ``stable_to_unstable`` or ``unstable_to_stable`` (``""`` when none); ``unstable_below``:
    the *other* eigenvalues with positive real part just below the root (the crossing one not
    counted; -1 when not evaluated).
    """

    speed_m_s: float
    status: str
    reason: str
    dynamic_speed_m_s: float = float("nan")
    direction: str = ""
    unstable_below: int = -1
    root_residual: float = float("nan")
    speed_max_m_s: float = float("inf")

    @property
    def is_stability_limit(self) -> bool:
        """Verified, stable below and a real eigenvalue going unstable."""
        return (self.status == CONVERGED and self.unstable_below == 0
                and self.direction == "stable_to_unstable")

    def summary(self, prefix: str = "divergence_static_verified") -> dict:
        """JSON-ready keys (NaN for missing numbers; strict JSON: the caller maps NaN to null)."""
        ok = self.status == CONVERGED
        return {f"{prefix}_speed_m_s": self.speed_m_s if ok else float("nan"),
                f"{prefix}_status": self.status, f"{prefix}_reason": self.reason,
                f"{prefix}_root_m_s": self.speed_m_s,
                f"{prefix}_dynamic_crossing_m_s": self.dynamic_speed_m_s,
                f"{prefix}_dynamic_minus_static_m_s": (self.dynamic_speed_m_s - self.speed_m_s),
                f"{prefix}_direction": self.direction,
                f"{prefix}_unstable_eigenvalues_below": self.unstable_below,
                f"{prefix}_is_stability_limit": self.is_stability_limit}


def _roots(system) -> np.ndarray:
    """Positive real static roots [m/s], ascending."""
    K = np.asarray(system.basis.K, float)
    mu = np.linalg.eigvals(np.linalg.solve(K, static_aero_stiffness(system)))
    scale = float(np.abs(mu).max()) if mu.size else 0.0
    real = mu[(np.abs(mu.imag) <= 1e-9 * scale) & (mu.real > 0)].real
    return np.sort(1.0 / np.sqrt(real))


def _det_sign(system, u) -> float:
    return float(np.linalg.slogdet(static_stiffness(system, u))[0])


def static_divergence(system, speed_max_m_s: float = float("inf")) -> StaticDivergence:
    """Smallest static divergence root of ``system`` below ``speed_max_m_s`` [m/s], verified
    (module docstring). ``no_crossing_in_range`` when there is none."""
    umax = float(speed_max_m_s)
    roots = _roots(system)
    if roots.size == 0 or roots[0] > umax:
        why = ("no positive real root of det(K - U^2 Q)" if roots.size == 0 else
               f"first root {roots[0]:.6g} m/s above {umax:g} m/s")
        return StaticDivergence(float("nan"), NO_CROSSING, why, speed_max_m_s=umax)
    us = float(roots[0])
    K = np.asarray(system.basis.K, float)
    sv = np.linalg.svd(static_stiffness(system, us), compute_uv=False)
    res = float(sv[-1] / np.linalg.svd(K, compute_uv=False)[0])
    base = dict(speed_m_s=us, root_residual=res, speed_max_m_s=umax)
    if res > ROOT_RTOL:
        return StaticDivergence(status=UNVERIFIED, reason=f"not a root: sigma_min/sigma_max "
                                f"{res:.3g} > {ROOT_RTOL:g}", **base)
    d = STATIC_BRACKET_REL * us
    if _det_sign(system, us - d) * _det_sign(system, us + d) >= 0:
        return StaticDivergence(status=UNVERIFIED, reason="det(K - U^2 Q) does not change sign "
                                "across the root (a double root that grazes zero)", **base)
    tol = oscillation_tolerance(system)
    lam = np.linalg.eigvals(system.A(us))
    k = int(np.argmin(np.abs(lam)))
    lam0 = complex(lam[k])
    if abs(lam0.imag) > tol:
        return StaticDivergence(status=UNVERIFIED, reason=f"the eigenvalue of A(U) nearest 0 "
                                f"at the root is oscillatory ({lam0:.3g} 1/s)", **base)
    found = None
    for rel in DYNAMIC_BRACKET_REL:   # the real eigenvalue continued either side of the root
        lo, hi = us * (1.0 - rel), us * (1.0 + rel)
        l_lo, ok_lo = _follow(system, us, lam0, lo, tol)
        l_hi, ok_hi = _follow(system, us, lam0, hi, tol)
        if ok_lo and ok_hi and max(abs(l_lo.imag), abs(l_hi.imag)) <= tol:
            found = (lo, hi, l_lo.real, l_hi.real)
            break
    if found is None:
        return StaticDivergence(status=UNVERIFIED, reason="the real eigenvalue of A(U) at the "
                                "root does not stay real (or cannot be continued) within "
                                f"{DYNAMIC_BRACKET_REL[-1]:g} of the root", **base)
    lo, hi, glo, ghi = found
    lam_lo = np.linalg.eigvals(system.A(lo))
    below = int(np.sum(lam_lo.real > 1e-6 * tol)) - int(glo > 1e-6 * tol)
    if not glo * ghi < 0:
        return StaticDivergence(status=UNVERIFIED, unstable_below=below,
                                reason="the real eigenvalue of A(U) at the static root does not "
                                f"change sign ({glo:.3g} / {ghi:.3g} 1/s at {lo:.6g} / "
                                f"{hi:.6g} m/s)", **base)

    def g(u):
        return _follow(system, us, lam0, u, tol)[0].real if u != us else lam0.real

    ud = float(brentq(g, lo, hi, xtol=1e-9, rtol=1e-14, maxiter=200))
    direction = "stable_to_unstable" if glo < 0 else "unstable_to_stable"
    if abs(ud - us) > DYNAMIC_MATCH_TOL_M_S:
        return StaticDivergence(status=UNVERIFIED, dynamic_speed_m_s=ud, direction=direction,
                                unstable_below=below,
                                reason=f"the dynamic zero crossing {ud:.6g} m/s is "
                                f"{abs(ud - us):.3g} m/s from the static root", **base)
    if below == 0 and direction == "stable_to_unstable":
        why = "stability limit: stable below, a real eigenvalue goes unstable"
    elif direction == "unstable_to_stable":
        why = (f"a real eigenvalue returns from the right half-plane ({below} other unstable "
               "eigenvalue(s) below): a static singularity past an earlier instability, not "
               "the stability limit")
    else:
        why = f"{below} eigenvalue(s) already unstable below: not the stability limit"
    return StaticDivergence(status=CONVERGED, reason=why, dynamic_speed_m_s=ud,
                            direction=direction, unstable_below=below, **base)
