"""Monte-Carlo turbulence along the span: the buffeting spectra and coherence as time series.

Spectral representation (Shinozuka & Deodatis 1991; the multivariate, ergodic form of Deodatis
1996), with the spectra of :mod:`bridgeflap.model.response.buffeting`
(:class:`bridgeflap.model.aero.gust.GustField`: one-sided in circular frequency, ``sigma^2 =
int_0^inf G d omega``) and its Davenport coherence ``R_ij(omega) = exp(-c omega |y_i - y_j| / (2 pi
U))`` (the paper's Eq. (16))::

    w_j(t) = Re sum_k sqrt(2 G(omega_k) d_omega) (L_k e^{i phi_k})_j e^{i omega_k t}

with ``L_k L_k^T = R(omega_k)``, ``phi_lk`` independent uniform phases and ``omega_k = (k + 1/2)
d_omega``, ``d_omega = 2 pi / T`` (the records are periodic with period ``T``).

The factor ``L_k`` costs O(m) per frequency, not the O(m^3) of a Cholesky factorisation: along
the sorted strips the exponential coherence is the correlation of a first-order Markov
(AR(1)) chain, so ``(L e)_1 = e_1`` and ``(L e)_i = a_i (L e)_{i-1} + sqrt(1 - a_i^2) e_i`` with
``a_i = exp(-c omega (y_i - y_{i-1}) / (2 pi U))`` is exactly ``L e`` of the Cholesky factor
(the same structure as :func:`bridgeflap.model.aero.gust.coherence_projection`). The sum over
frequencies is one inverse FFT per strip.

References
----------
Shinozuka, M., Deodatis, G. (1991). Appl. Mech. Rev. 44(4), 191-204. Deodatis, G. (1996).
J. Eng. Mech. 122(8), 778-787. Davenport (1962) Proc. ICE 23 (coherence).
"""

from __future__ import annotations

import numpy as np

from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["ar1_coherent_phasors", "span_turbulence", "synthesis_grid"]


def synthesis_grid(n_samples: int, h: float, omega_max: float) -> np.ndarray:
    """Frequencies ``(k + 1/2) d_omega < omega_max`` with ``d_omega = 2 pi / (n_samples h)``.

    ``omega_max`` must lie below the Nyquist frequency ``pi / h`` of the sample spacing ``h``.
    """
    if not (np.isfinite(h) and h > 0):
        raise BridgeflapInputError("dt", f"must be finite and > 0, got {h!r}")
    if omega_max >= np.pi / h:
        raise BridgeflapInputError("dt", f"omega_max {omega_max:.4g} rad/s is above the Nyquist "
                                         f"frequency pi/h = {np.pi / h:.4g} rad/s")
    d_omega = 2.0 * np.pi / (int(n_samples) * h)
    k = np.arange(int(np.floor(omega_max / d_omega - 0.5)) + 1)
    return (k + 0.5) * d_omega


def ar1_coherent_phasors(positions, omegas, wind_speed, decay, rng) -> np.ndarray:
    """``L_k e^{i phi_k}`` for every frequency: unit-variance phasors with the exponential
    coherence between strips (module docstring), shape ``(n_omega, m)``, in input order."""
    y = np.asarray(positions, dtype=float).ravel()
    order = np.argsort(y, kind="stable")
    dy = np.diff(y[order])
    omegas = np.asarray(omegas, dtype=float)
    phases = np.exp(1j * rng.uniform(0.0, 2.0 * np.pi, size=(omegas.size, y.size)))
    a = np.exp(-float(decay) * omegas[:, None] * dy[None, :] / (2.0 * np.pi * float(wind_speed)))
    s = np.sqrt(np.clip(1.0 - a * a, 0.0, None))
    z = np.empty_like(phases)
    z[:, 0] = phases[:, 0]
    for i in range(1, y.size):
        z[:, i] = a[:, i - 1] * z[:, i - 1] + s[:, i - 1] * phases[:, i]
    out = np.empty_like(z)
    out[:, order] = z
    return out


def span_turbulence(positions, psd, wind_speed, decay, n_samples, h, omega_max, seed=None, *,
                    n_keep=None, project=None, chunk=8):
    """Correlated Gaussian gust velocities at the strips, sampled every ``h`` seconds.

    Parameters
    ----------
    positions : array_like, shape (m,)
        Strip coordinates along the span [m].
    psd : callable
        ``omega [rad/s] -> G(omega)`` one-sided in circular frequency [m^2/s^2 per rad/s]
        (e.g. ``GustField.psd(omega, U) * GustField.admittance_sq(omega, U)``: the effective
        gust after the admittance, as :mod:`bridgeflap.model.response.buffeting` uses it).
    wind_speed : float
        ``U`` [m/s] (coherence scale).
    decay : float
        Davenport ``c`` [-].
    n_samples : int
        Samples; the record is periodic with period ``n_samples h``.
    h : float
        Sample spacing [s].
    omega_max : float
        Highest synthesised frequency [rad/s] (below ``pi / h``).
    seed : int or numpy.random.Generator, optional
        Seed of the random phases.
    n_keep : int, optional
        Return only the first ``n_keep`` samples (a window of the periodic record: its
        frequency spacing ``2 pi / (n_samples h)`` finer than the window alone gives).
    project : array_like, shape (r, m), optional
        Return ``project @ w`` (e.g. the generalised gust forces) instead of ``w``; the strips
        are then synthesised ``chunk`` at a time (memory ``chunk * n_samples``).

    Returns
    -------
    ndarray, shape (m, n_keep) or (r, n_keep)
        ``w_j(t_n)`` [m/s] at ``t_n = n h``; ``var = int_0^omega_max G d omega`` (to the
        midpoint rule) at every strip.
    """
    U = float(wind_speed)
    if not (np.isfinite(U) and U > 0):
        raise BridgeflapInputError("speeds", f"need a wind speed > 0, got {wind_speed!r}")
    rng = np.random.default_rng(seed)
    n = int(n_samples)
    omegas = synthesis_grid(n, h, omega_max)
    d_omega = 2.0 * np.pi / (n * h)
    g = np.asarray(psd(omegas), dtype=float) * np.ones_like(omegas)
    if np.any(g < 0) or not np.all(np.isfinite(g)):
        raise BridgeflapInputError("spectrum", "must be finite and >= 0")
    coeff = np.sqrt(2.0 * g * d_omega)[:, None] * ar1_coherent_phasors(positions, omegas, U,
                                                                       decay, rng)
    # sum_k c_k exp(i (k + 1/2) d_omega n h) = exp(i pi n / N) * N * ifft(c)_n
    keep = n if n_keep is None else int(n_keep)
    shift = (np.exp(1j * np.pi * np.arange(n) / n) * n)[:keep]
    m = coeff.shape[1]
    P = None if project is None else np.asarray(project, dtype=float)
    out = np.zeros((m if P is None else P.shape[0], keep))
    for j0 in range(0, m, int(chunk)):
        j1 = min(m, j0 + int(chunk))
        spectrum = np.zeros((j1 - j0, n), dtype=complex)
        spectrum[:, :omegas.size] = coeff[:, j0:j1].T
        w = np.real(np.fft.ifft(spectrum, axis=1)[:, :keep] * shift[None, :])
        if P is None:
            out[j0:j1] = w
        else:
            out += P[:, j0:j1] @ w
    return out
