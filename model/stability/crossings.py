"""Locating, verifying and naming a stability crossing: the steps both sweeps share.

The dense sweep (:func:`bridgeflap.model.stability.sweeps.sweep`) and the fast one
(:func:`bridgeflap.model.stability.hopf.fast_sweep`) start their branches alike
(:func:`_structural_start`), locate a crossing on a grid the same way (:func:`_indicator`,
:func:`_locate`, :func:`_refine`,
:func:`_verify`: Brent's method on the indicator, then the verification described in
:mod:`bridgeflap.model.stability.sweeps`) and name it alike (:func:`_name_flutter`,
:func:`_name_divergence`, :func:`_critical_vector`). They live here, below both, so that
``sweeps -> hopf -> crossings`` and ``sweeps -> crossings`` with no cycle; the names stay
importable from :mod:`bridgeflap.model.stability.sweeps`.

May import: the foundation, bridgeflap.model.aeroelastic (the state space's static pieces) and
:mod:`bridgeflap.model.stability.tracking`; nothing else of bridgeflap.model.stability, nothing
above it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.optimize import brentq, linear_sum_assignment

from bridgeflap.model.aeroelastic.statespace import divergence_mechanism
from bridgeflap.model.stability.tracking import (
    BRACKET_FAILED,
    CONVERGED,
    NO_CROSSING,
    UNSTABLE_AT_FIRST,
    UNVERIFIED,
    Crossing,
    _bracket_half_width,
    _branch_of,
    _divergence_function,
    _eig,
    _follow,
    _max_real_real,
    _stable_start,
    flutter_function,
)


def _upper(lam, n):
    """Indices of the ``n`` eigenvalues of the upper half plane (real ones too) smallest in
    modulus."""
    return np.argsort(np.where(lam.imag >= 0, np.abs(lam), np.inf))[:n]


def _structural_start(system):
    """Branch labels and the branches' values at ``U = 0`` (upper half plane).

    The labels are the structural modes' (the dominant coordinate of each eigenvector of the
    structure alone,
    :meth:`~bridgeflap.model.aeroelastic.statespace.AeroelasticSystem.structural_matrix`). The
    values are the eigenvalues of the structural block of ``A(0)`` (rows and columns ``q, q'``: the
    structure with the still-air terms of the aerodynamic model, e.g. the apparent mass of a Roger
    fit, whose lag states do not act at ``U = 0``), each matched to the structural mode whose shape
    it has: linear assignment on the mass-weighted overlap ``|phi^H M psi|^2 / (phi^H M phi psi^H M
    psi)`` of the ``q`` parts. Matching by eigenvalue distance fails where the still-air terms move
    the spectrum more than the modes' spacing: IABSE 1.1c's fit raises heave from 0.63 to 1.73 rad/s
    and pitch from 1.75 to 2.78 rad/s, and the sweep's assignment at ``U = 0`` gave pitch's label to
    the shifted heave mode and heave a lag state's zero; close modes with different apparent masses
    swap too (IABSE 2a:bb3's TS1, 1.749 to 1.730 rad/s, and VA4, 1.769 to 1.747 rad/s, named its
    TS1-VS1 flutter VA4; several close pairs of Humber's 30 modes).
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


def _participation(system, vec, energy="kinetic") -> dict:
    """Share of each structural coordinate in the state vector ``vec`` (:func:`_shares`), by
    the basis's labels."""
    vq = _shares(system, vec, energy)
    return {system.basis.labels[j]: float(vq[j]) for j in range(system.basis.n)}


def _name_divergence(system, divergence, labels, vector):
    """Divergence crossing named by its mechanism, ``vector()`` its (real) eigenvector, and the
    participation of that eigenvector: the strain-energy shares ``K_jj |q_j|^2`` of the root
    that crosses at the refined crossing (a static mode has no kinetic energy; ``{}`` when the
    crossing did not converge).

    The label is the coordinate whose deflection does the largest share of the static
    aerodynamic work (:func:`divergence_mechanism`), not the largest strain-energy share: on a
    deck the twist's lift bends the deck, so the heave mode VS1 carries most of the strain
    energy of a torsional divergence (80 % on the built-in Humber) though it makes no static
    load. A branch tracked from U = 0 keeps its index; the tracked name (the mode the real
    eigenvalue's branch started from) is used only when the work cannot be split.
    """
    if divergence.status != CONVERGED:
        return divergence, {}
    n = system.basis.n
    vec = vector()
    participation = _participation(system, vec, "strain")
    try:
        mechanism, source = divergence_mechanism(system, vec)
    except (AttributeError, TypeError, ValueError, np.linalg.LinAlgError):
        mechanism, source = "", ""  # a system without the static pieces: left unnamed
    branch = divergence.branch % n if divergence.branch >= 0 else -1
    if source:  # the dense and the fast sweep name it alike, tracked or not
        return replace(divergence, branch=branch, label=source, label_source="static_aero_work",
                       mechanism=mechanism), participation
    if branch >= 0:
        return replace(divergence, branch=branch, label=labels[branch],
                       label_source="tracking"), participation
    vq = _shares(system, vec, "strain")
    return replace(divergence, label=system.basis.labels[int(np.argmax(vq))],
                   label_source="participation"), participation


def _critical_vector(system, u, omega_tol, kind):
    """Eigenvector of the flutter (largest real part, oscillatory) or divergence (real,
    nearest zero) eigenvalue of ``A(u)``: one dense eigen-solution with vectors."""
    lam, V = _eig(system.A(u))
    if kind == "flutter":
        sel = np.where(np.abs(lam.imag) > omega_tol)[0]
        return V[:, sel[np.argmax(lam[sel].real)]]
    sel = np.where(np.abs(lam.imag) <= omega_tol)[0]
    return V[:, sel[np.argmin(np.abs(lam[sel].real))]]


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
