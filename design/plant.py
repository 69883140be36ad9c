"""Plant numerics of the flap loop used by the design problem (to be replaced by model/).

The flap-loop plant ``G(s)`` of the RFA state space (:func:`plant_factors`), and eigenvalue
checks of the closed-loop matrix polynomial ``A0 + U A1 + U^2 A2`` (lag states dropped at
``U = 0``, where they are decoupled). Kept together, unchanged, so that a single assembly in
model/ can replace them by one re-import.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg


def plant_factors(model, U, s) -> tuple[np.ndarray, np.ndarray]:
    """Factors of the flap-loop plant ``G(s) = Phi_a X(s) diag(w)`` (RFA aerodynamics).

    ``G`` maps the flap drive angles [rad] to the deck pitch at the flaps [rad]: the open-loop
    generalised equation ``D(s) q = F(s) beta`` with the flap loads as inputs, ``C(k)`` from the
    same RFA as the state space (``s`` complex, so ``G`` is the exact transfer function of the
    RFA state space), ``X = D^{-1} F`` for unit weights.

    Parameters
    ----------
    model : model.flaps.ClosedLoopModel
    U : float
        Wind speed [m/s].
    s : array_like
        Complex frequencies [1/s] (``1j * omega`` for a frequency response).

    Returns
    -------
    Pa : ndarray (n_flaps, n_modes)
        Pitch at the flap strips per unit modal coordinate [rad].
    X : ndarray (len(s), n_modes, n_flaps) complex
    """
    ol, fl = model.open_loop, model.flaps
    B, a, rfa = ol.basis, ol.aero, ol.rfa
    b, rho = a.half_chord, a.air_density
    sc = fl.width_m
    ld = fl.loads
    Hk = [(fl.phi_h.T * e[0] + fl.phi_a.T * e[1]) * sc for e in (ld.e0, ld.e1, ld.e2)]
    PF = (-2 * np.pi * rho * b * fl.phi_h.T + np.pi * rho * b * b * fl.phi_a.T) * sc
    s = np.atleast_1d(np.asarray(s, complex))
    X = np.zeros((len(s), B.n, fl.n_flaps), complex)
    Mt = B.M + a.M_nc
    for i, p in enumerate(s):
        sbar = p * b / U if U > 0 else 0.0
        C = 1.0 - np.sum(rfa.gains * sbar / (sbar + rfa.poles)) if U > 0 else 1.0
        D = p * p * Mt + p * (B.C + U * a.D_nc) + B.K - U * C * a.P @ (p * a.G1 + U * a.G0)
        F = p * p * Hk[2] + U * p * Hk[1] + U * U * Hk[0] + U * C * PF * (U * ld.g0
                                                                          + b * ld.g1 * p)
        X[i] = np.linalg.solve(D, F)
    return np.asarray(fl.phi_a, float), X


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


def closed_loop_abscissa(A_parts, U) -> np.ndarray:
    """Spectral abscissa [1/s] of ``A0 + U A1 + U^2 A2`` per speed (lag states dropped at 0)."""
    A0, A1, A2, keep0 = A_parts
    out = []
    for u in np.atleast_1d(U):
        A = A0 + u * A1 + u * u * A2
        if u == 0:
            A = A[np.ix_(keep0, keep0)]
        out.append(np.max(scipy.linalg.eigvals(A).real))
    return np.array(out)


def top_real_parts_numeric(A_parts, U, m) -> np.ndarray:
    """The ``m`` largest real parts [1/s] at one speed (as the optimiser sees them)."""
    A0, A1, A2, keep0 = A_parts
    A = A0 + U * A1 + U * U * A2
    if U == 0:
        A = A[np.ix_(keep0, keep0)]
    lam = scipy.linalg.eigvals(A)
    return np.sort(lam.real)[::-1][:m]
