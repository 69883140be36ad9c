"""The flap-loop plant and closed-loop eigenvalue checks as the design problem uses them.

The physics is the model's single assembly: ``G(s) = Pa X(s) diag(w)`` is
:meth:`bridgeflap.model.aeroelastic.flaps.ClosedLoopModel.plant` and the spectral abscissa of the
closed-loop matrix polynomial ``A0 + U A1 + U^2 A2`` is
:func:`bridgeflap.model.spectrum.polynomial_abscissa`. This module only adapts them to the NLP's
data layout (the CasADi parts ``(A0, A1, A2, keep0)``, the lag states dropped at ``U = 0``, where
they are decoupled).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from bridgeflap.design.control.formulation.eigen import damping_measure, fixed_pole_copies
from bridgeflap.model.spectrum import polynomial_abscissa


def plant_factors(model, U, s) -> tuple[np.ndarray, np.ndarray]:
    """``(Pa, X)`` of ``G(s) = Pa X(s) diag(w)`` [rad/rad] at ``U`` [m/s], unit weights.

    See :meth:`bridgeflap.model.aeroelastic.flaps.ClosedLoopModel.plant`.
    """
    return model.plant(U, s)


def plant_frequency_response(model, U, omega, weights=None) -> np.ndarray:
    """``G(jw)`` (n_omega, n_flaps, n_flaps) [rad/rad] (:func:`plant_factors`)."""
    Pa, X = plant_factors(model, U, 1j * np.asarray(omega, float))
    w = np.ones(Pa.shape[0]) if weights is None else np.asarray(weights, float)
    return np.einsum("fn,knj->kfj", Pa, X) * w[None, None, :]


def lag_free_indices(model) -> np.ndarray:
    """Closed-loop state indices without the aerodynamic lag states (kept at ``U = 0``)."""
    ol = model.open_loop
    nx = model.casadi_functions()["A_cl"].size1_out(0)
    keep = np.ones(nx, bool)
    keep[ol.index.aero_lag] = False
    return np.flatnonzero(keep)


#: Relative singular-value threshold of the flap pitch map ``Phi_a`` below which a direction
#: counts as absent (:func:`compensator_reduction`).
REDUCTION_RTOL = 1e-12


def compensator_reduction(model, nx):
    """``(T, T_left, keep0)`` reducing the closed loop's per-flap compensator copies, or None.

    Every flap has its own compensator driven by ``alpha_f = Phi_a[f] q``: with more flaps than
    independent pitch directions (``r = rank Phi_a < n_flaps``; 25 flaps on 16 modes) the
    compensator states stay in ``range(kron(L, I_nc))``, ``L`` the ``r`` left singular vectors
    of ``Phi_a`` -- an invariant subspace of ``A(U)`` for every ``U`` and ``theta`` (the
    compensator rows map it and ``q`` into it: ``kron(I, Ac) kron(L, I) = kron(L, I) kron(I_r,
    Ac)`` and ``kron(I, Bc) Phi_a = kron(L, Bc) (L^T Phi_a)``). With ``T = blockdiag(I,
    kron(L, I_nc))`` and ``T_left = T^T`` (orthonormal ``L``), ``T_left A T`` has exactly the
    eigenvalues of ``A`` on that subspace: all but ``(n_flaps - r) nc`` copies of the
    compensator poles, which the damping constraints exclude anyway. Derivatives carry over
    (``T`` is constant), and the weights ``w`` scale the flap forces, not ``Phi_a``, so the
    reduction holds for the placement design too. ``nx``: the closed loop's state count.
    ``keep0``: the reduced indices without the lag states (``U = 0``). None when nothing is
    removed.
    """
    import scipy.sparse as sp

    ol = model.open_loop
    pa = np.asarray(model.flaps.phi_a, float)
    nF = pa.shape[0]
    nc = (nx - ol.n_states) // max(nF, 1)
    if nF == 0 or nc == 0:
        return None
    U_, sv, _ = np.linalg.svd(pa, full_matrices=False)
    r = int(np.sum(sv > REDUCTION_RTOL * sv[0])) if sv.size and sv[0] > 0 else 0
    if r >= nF:
        return None
    k = ol.n_states
    T = sp.block_diag([sp.identity(k), sp.kron(sp.csr_matrix(U_[:, :r]), sp.identity(nc))],
                      format="csc")
    keep = np.ones(k + r * nc, bool)
    keep[ol.index.aero_lag] = False
    return T, T.T.tocsc(), np.flatnonzero(keep)


def closed_loop_abscissa(A_parts, U) -> np.ndarray:
    """Spectral abscissa [1/s] of ``A0 + U A1 + U^2 A2`` per speed (lag states dropped at 0)."""
    A0, A1, A2, keep0 = A_parts
    return polynomial_abscissa((A0, A1, A2), U, keep0)


def lag_rates(model) -> np.ndarray:
    """RFA lag-pole rates ``p_i / b`` [1/m]: the lag copies sit at ``-p_i U / b``."""
    ol = model.open_loop
    return np.asarray(ol.rfa.poles, float) / float(ol.aero.half_chord)


def movable_spectrum(A_parts, U, rates, theta) -> tuple[np.ndarray, np.ndarray]:
    """All eigenvalues [1/s] at ``U`` [m/s] and the movable ones (no fixed-pole copies,
    ``Im >= 0``; :func:`bridgeflap.design.control.formulation.eigen.fixed_pole_copies`)."""
    A0, A1, A2, keep0 = A_parts
    A = A0 + U * A1 + U * U * A2
    if U == 0:
        A = A[np.ix_(keep0, keep0)]
    lam = scipy.linalg.eigvals(A)
    mv = lam[~fixed_pole_copies(lam, rates, U, theta) & (lam.imag >= 0)]
    return lam, mv


def damping_check(A_parts, speeds, rates, theta, zeta_min) -> dict:
    """Dense damping check per speed: ``abscissa_1_s`` (all eigenvalues), ``measure_1_s``
    (largest ``Re lambda + zeta_min |lambda|`` of the movable branches, <= 0 meets the
    damping), ``zeta`` (their smallest damping ratio ``-Re lambda / |lambda|``, -1 for a
    real unstable root) and ``omega_rad_s`` (``|lambda|`` of that branch)."""
    out = {k: [] for k in ("abscissa_1_s", "measure_1_s", "zeta", "omega_rad_s")}
    for u in np.atleast_1d(np.asarray(speeds, float)):
        lam, mv = movable_spectrum(A_parts, float(u), rates, theta)
        g = damping_measure(mv, zeta_min)
        mag = np.abs(mv)
        z = np.where(mag > 0, -mv.real / np.where(mag > 0, mag, 1.0), 0.0)
        i = int(np.argmin(z))
        out["abscissa_1_s"].append(float(lam.real.max()))
        out["measure_1_s"].append(float(g.max()))
        out["zeta"].append(float(z[i]))
        out["omega_rad_s"].append(float(mag[i]))
    return {k: np.array(v) for k, v in out.items()}


#: Coarse stride of :func:`damping_check_refined` (every 8th speed of the dense grid: 2 m/s on
#: the 0.25 m/s check grid) and the safety factor on the local change of the checked measures.
REFINE_STRIDE = 8
REFINE_SAFETY = 2.0


def damping_check_refined(A_parts, speeds, rates, theta, zeta_min, tol,
                          stride=REFINE_STRIDE) -> dict:
    """:func:`damping_check` on a subset of the dense grid ``speeds`` that keeps its decisions.

    Every ``stride``-th speed (and the last) is checked first; then every dense speed between
    the coarse neighbours of a coarse point ``i`` whose damping measure ``m_i`` or abscissa
    ``a_i`` could reach its threshold in between -- ``m_i + REFINE_SAFETY d_i > tol`` or
    ``a_i + REFINE_SAFETY e_i > 0``, ``d_i``, ``e_i`` the larger change to a coarse neighbour --
    is checked too, repeatedly until no new point is flagged. The values are those of the
    dense check at the speeds checked (``speeds_m_s``, a subset of ``speeds``); its maximum
    violation, its first unstable speed and the speed before it equal the dense ones whenever
    the measures do not peak between coarse points by more than twice their change to a
    neighbour (tested against the dense check, ``tests/test_design_speed.py``).
    """
    U = np.atleast_1d(np.asarray(speeds, float))
    n = len(U)
    done = {}

    def run(idx):
        new = [i for i in idx if i not in done]
        if new:
            chk = damping_check(A_parts, U[new], rates, theta, zeta_min)
            for j, i in enumerate(new):
                done[i] = {k: v[j] for k, v in chk.items()}

    coarse = sorted(set(range(0, n, max(int(stride), 1))) | {n - 1})
    run(coarse)
    flagged = set()
    while True:
        idx = sorted(done)
        m = np.array([done[i]["measure_1_s"] for i in idx])
        a = np.array([done[i]["abscissa_1_s"] for i in idx])
        want = set()
        for j, i in enumerate(idx):
            lo, hi = max(j - 1, 0), min(j + 1, len(idx) - 1)
            d = max(abs(m[j] - m[lo]), abs(m[hi] - m[j]))
            e = max(abs(a[j] - a[lo]), abs(a[hi] - a[j]))
            if (m[j] + REFINE_SAFETY * d > tol or a[j] + REFINE_SAFETY * e > 0) \
                    and i not in flagged:
                flagged.add(i)
                want.update(range(idx[lo], idx[hi] + 1))
        want -= set(done)
        if not want:
            break
        run(sorted(want))
    idx = sorted(done)
    out = {k: np.array([done[i][k] for i in idx]) for k in done[idx[0]]}
    out["speeds_m_s"] = U[idx]
    return out


def top_real_parts_numeric(A_parts, U, m) -> np.ndarray:
    """The ``m`` largest real parts [1/s] at one speed (as the optimiser sees them)."""
    A0, A1, A2, keep0 = A_parts
    A = A0 + U * A1 + U * U * A2
    if U == 0:
        A = A[np.ix_(keep0, keep0)]
    lam = scipy.linalg.eigvals(A)
    return np.sort(lam.real)[::-1][:m]
