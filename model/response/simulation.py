"""Independent checks of the spectral response: white-noise covariance and Monte Carlo.

Same system and one-sided PSD convention as :mod:`bridgeflap.model.spectral` (see its docstring)::

    x' = A x + B w,    y = C x

:func:`lyapunov_rms` gives the exact stationary covariance for white noise of intensity ``Q``
(``A P + P A^T + B Q B^T = 0``); :func:`simulate_monte_carlo` synthesises correlated stationary
inputs by the spectral representation and integrates the system with a zero-order hold.

References
----------
Shinozuka, M., Deodatis, G. (1991). Simulation of stochastic processes by spectral
representation. Applied Mechanics Reviews 44(4), 191-204.
Deodatis, G. (1996). Simulation of ergodic multivariate stochastic processes. Journal of
Engineering Mechanics 122(8), 778-787.
Van Loan, C. F. (1978). Computing integrals involving the matrix exponential. IEEE Trans.
Automatic Control 23(3), 395-404 (augmented-matrix zero-order-hold discretisation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.spectral import MODAL_CONDITION_LIMIT, check_system

__all__ = ["CovarianceResult", "MonteCarloResult", "lyapunov_rms", "simulate_monte_carlo"]


@dataclass(frozen=True)
class CovarianceResult:
    """Exact stationary covariance for white-noise input (:func:`lyapunov_rms`).

    Attributes
    ----------
    rms : ndarray, shape (p,)
        Output standard deviations; NaN if unstable.
    output_covariance : ndarray, shape (p, p)
        ``C P C^T``.
    state_covariance : ndarray, shape (n, n)
        ``P`` solving ``A P + P A^T + B Q B^T = 0``.
    status : str
        ``"ok"`` or ``"unstable"``.
    """

    rms: np.ndarray
    output_covariance: np.ndarray
    state_covariance: np.ndarray
    status: str


@dataclass(frozen=True)
class MonteCarloResult:
    """Output RMS from time-domain simulation (:func:`simulate_monte_carlo`).

    Attributes
    ----------
    rms : ndarray, shape (p,)
        ``sqrt`` of the record-averaged output variance.
    standard_error : ndarray, shape (p,)
        Standard error of ``rms`` from the scatter of the per-record variances
        (``std(var_r, ddof=1) / sqrt(n_records) / (2 rms)``, delta method).
    record_variances : ndarray, shape (n_records, p)
        Per-record time-averaged mean squares of the (zero-mean) outputs.
    dt : float
        Time step [s].
    duration : float
        Length of each analysed record after the transient [s].
    transient : float
        Discarded start-up length [s].
    status : str
        ``"ok"`` or ``"unstable"`` (NaN numbers).
    """

    rms: np.ndarray
    standard_error: np.ndarray
    record_variances: np.ndarray
    dt: float
    duration: float
    transient: float
    status: str


# ----------------------------------------------------------------------------------------------
# exact white-noise covariance
# ----------------------------------------------------------------------------------------------
def lyapunov_rms(A, B, C, Q):
    """Exact stationary output RMS for white-noise input of intensity ``Q``.

    Parameters
    ----------
    A, B, C : array_like
        System matrices, see :func:`response_psd`.
    Q : array_like, shape (m, m) or scalar
        Intensity: ``E[w(t) w(t + tau)^T] = Q delta(tau)`` [input unit^2 s]. A flat one-sided
        PSD ``G0`` (this module's convention) has ``Q = pi * G0``
        (:func:`white_noise_intensity`); a flat two-sided PSD ``S0`` has ``Q = 2 pi S0``.

    Returns
    -------
    CovarianceResult

    Notes
    -----
    The state covariance solves ``A P + P A^T + B Q B^T = 0`` and the output covariance is
    ``C P C^T``; this equals ``int_0^inf G_yy d omega`` with ``G_yy = H (Q / pi) H^H``.
    """
    A, B, C = check_system(A, B, C)
    m, p, n = B.shape[1], C.shape[0], A.shape[0]
    Q = np.asarray(Q, dtype=float)
    if Q.ndim == 0:
        Q = Q * np.eye(m)
    if Q.shape != (m, m):
        raise BridgeflapInputError("Q", f"must be ({m}, {m}), got {Q.shape}")
    lam = np.linalg.eigvals(A)
    if lam.size and np.max(lam.real) >= 0.0:
        return CovarianceResult(
            np.full(p, np.nan), np.full((p, p), np.nan), np.full((n, n), np.nan), "unstable"
        )
    W = B @ Q @ B.T
    P = sla.solve_continuous_lyapunov(A, -0.5 * (W + W.T))
    P = 0.5 * (P + P.T)
    Y = C @ P @ C.T
    return CovarianceResult(np.sqrt(np.clip(np.diag(Y), 0.0, None)), Y, P, "ok")


# ----------------------------------------------------------------------------------------------
# Monte-Carlo simulation
# ----------------------------------------------------------------------------------------------
def _psd_factor(G):
    """Lower factor L with G = L L^H (Cholesky; eigen-factor for semi-definite G)."""
    try:
        return np.linalg.cholesky(G)
    except np.linalg.LinAlgError:
        vals, vecs = np.linalg.eigh(0.5 * (G + G.conj().T))
        tol = 1e-12 * max(float(np.max(np.abs(vals))), np.finfo(float).tiny)
        if np.min(vals) < -1e-8 * max(float(np.max(np.abs(vals))), 1e-300) - tol:
            raise BridgeflapInputError("input_csd", "cross-spectral matrix is not PSD") from None
        return vecs * np.sqrt(np.clip(vals, 0.0, None))


def _zoh(A, B, dt):
    """Exact zero-order-hold discretisation via the augmented exponential (Van Loan 1978)."""
    n, m = B.shape
    aug = np.zeros((n + m, n + m))
    aug[:n, :n] = A * dt
    aug[:n, n:] = B * dt
    E = sla.expm(aug)
    return E[:n, :n], E[:n, n:]


def simulate_monte_carlo(
    A,
    B,
    C,
    omegas,
    psd_scalar,
    coherence_fn,
    dt,
    duration,
    seed=None,
    n_records=20,
    *,
    transient_time_constants=8.0,
):
    """Output RMS by simulating the LTI with synthesised correlated Gaussian inputs.

    Inputs are synthesised by the spectral representation method (Shinozuka & Deodatis 1991;
    multivariate form of Deodatis 1996): at each synthesis frequency ``omega_k`` the one-sided
    CSD ``G_k = s(omega_k) R(omega_k)`` is factorised ``G_k = L_k L_k^H`` (Cholesky) and::

        w_j(t) = sum_k sum_l sqrt(2 d_omega) Re[L_k,jl exp(i (omega_k t + phi_lk))]

    with independent uniform random phases ``phi_lk``; the sum is evaluated with a chirp-z
    transform. The records are periodic with period ``2 pi / d_omega``. The state equation is
    integrated exactly for a piecewise-constant input (zero-order hold, augmented matrix
    exponential), the input on ``[t_n, t_n + dt)`` being the synthesised value at the interval
    midpoint (second-order accurate in ``dt``). The response starts from rest; the first
    ``transient_time_constants / min|Re lam|`` seconds are discarded.

    Parameters
    ----------
    A, B, C : array_like
        System matrices, see :func:`response_psd`.
    omegas : array_like, shape (n_omega,)
        Synthesis frequencies [rad/s], uniformly spaced with spacing ``d_omega`` and
        ``0 < omegas < pi / dt``; typically ``(k - 1/2) d_omega``. ``duration`` must not exceed
        the period ``2 pi / d_omega``.
    psd_scalar : callable or array_like
        One-sided PSD ``s(omega)`` of each input (admittance included) [input unit^2 per
        rad/s], callable or tabulated on ``omegas``.
    coherence_fn : callable
        ``omega -> R(omega)`` (m, m) coherence matrix.
    dt : float
        Time step [s].
    duration : float
        Analysed length of each record, after the transient [s].
    seed : int or numpy.random.Generator, optional
        Seed of the random phases.
    n_records : int, optional
        Independent records (>= 2) for the standard-error estimate.
    transient_time_constants : float, optional
        Discarded start-up length in slowest time constants ``1/min|Re lam|``.

    Returns
    -------
    MonteCarloResult
    """
    from scipy.signal import czt, lfilter  # lazily: scipy.signal costs ~1 s to import

    A, B, C = check_system(A, B, C)
    n, m = B.shape
    p = C.shape[0]
    omegas = np.asarray(omegas, dtype=float)
    if omegas.ndim != 1 or omegas.size < 2:
        raise BridgeflapInputError("omegas", "need >= 2 synthesis frequencies")
    d_omega = omegas[1] - omegas[0]
    if d_omega <= 0 or np.max(np.abs(np.diff(omegas) - d_omega)) > 1e-9 * omegas[-1]:
        raise BridgeflapInputError("omegas", "synthesis frequencies must be uniformly spaced")
    if omegas[0] < 0 or omegas[-1] >= np.pi / dt:
        raise BridgeflapInputError("omegas", "must lie in [0, pi/dt) (Nyquist of the time step)")
    if duration > 2.0 * np.pi / d_omega * (1 + 1e-9):
        raise BridgeflapInputError(
            "duration", "exceeds the period 2 pi / d_omega of the synthesised records"
        )
    if int(n_records) < 2:
        raise BridgeflapInputError("n_records", "must be >= 2 for a standard error")
    lam = np.linalg.eigvals(A)
    nan = np.full(p, np.nan)
    if np.max(lam.real) >= 0.0:
        return MonteCarloResult(
            nan, nan, np.full((int(n_records), p), np.nan), dt, duration, np.nan, "unstable"
        )
    transient = transient_time_constants / float(np.min(np.abs(lam.real)))
    n_skip = int(np.ceil(transient / dt))
    n_keep = int(round(duration / dt))
    n_total = n_skip + n_keep

    # factors of the one-sided CSD at the synthesis frequencies
    if callable(psd_scalar):
        s = np.array([float(psd_scalar(w)) for w in omegas])
    else:
        s = np.asarray(psd_scalar, dtype=float)
        if s.shape != omegas.shape:
            raise BridgeflapInputError("psd_scalar", "must be tabulated on omegas")
    if np.any(s < 0) or not np.all(np.isfinite(s)):
        raise BridgeflapInputError("psd_scalar", "must be finite and >= 0")
    L = np.stack([_psd_factor(s[k] * np.asarray(coherence_fn(w))) for k, w in enumerate(omegas)])
    L = L * np.sqrt(2.0 * d_omega)  # (n_omega, m, m)

    Ad, Bd = _zoh(A, B, dt)
    mu, V = sla.eig(Ad)
    modal = np.linalg.cond(V) < MODAL_CONDITION_LIMIT
    if modal:
        ViBd = sla.solve(V, Bd.astype(complex))
        CV = C @ V
    rng = np.random.default_rng(seed)
    t_mid = (np.arange(n_total) + 0.5) * dt
    w_step = np.exp(1j * d_omega * dt)  # czt ratio: X_n = sum_k x_k exp(i d_omega dt k n)
    start_phase = np.exp(1j * omegas[0] * t_mid)
    variances = np.empty((int(n_records), p))
    for r in range(int(n_records)):
        phases = np.exp(1j * rng.uniform(0.0, 2.0 * np.pi, size=(omegas.size, m)))
        coeff = np.einsum("kjl,kl->jk", L, phases)  # (m, n_omega)
        coeff = coeff * np.exp(1j * omegas * 0.5 * dt)[None, :]
        w = np.real(czt(coeff, n_total, w_step, 1.0, axis=-1) * start_phase[None, :])
        if modal:
            u = ViBd @ w  # (n, n_total)
            z = np.empty_like(u)
            for i in range(n):
                # z_{k+1} = mu z_k + u_k, z_0 = 0
                z[i, 0] = 0.0
                z[i, 1:] = lfilter([1.0], [1.0, -mu[i]], u[i, :-1])
            y = np.real(CV @ z[:, n_skip:])
        else:
            u = Bd @ w
            x = np.zeros(n)
            y = np.empty((p, n_keep))
            for k in range(n_total):
                if k >= n_skip:
                    y[:, k - n_skip] = C @ x
                x = Ad @ x + u[:, k]
        variances[r] = np.mean(y**2, axis=1)  # zero-mean process
    var_mean = variances.mean(axis=0)
    rms = np.sqrt(var_mean)
    se_var = variances.std(axis=0, ddof=1) / np.sqrt(variances.shape[0])
    with np.errstate(divide="ignore", invalid="ignore"):
        se = np.where(rms > 0, se_var / (2.0 * rms), 0.0)
    return MonteCarloResult(rms, se, variances, float(dt), float(n_keep * dt), n_skip * dt, "ok")
