"""Random (spectral) response of a stable LTI system to correlated stationary inputs.

Bridge-independent engine used by the buffeting analysis (docs/methods.md#buffeting; the paper §3,
Eqs. (9)-(17)). The system is::

    x' = A x + B w,    y = C x

with ``A`` (n, n) real, ``B`` (n, m) real mapping ``m`` input processes ``w`` (e.g. spanwise strip
gust velocities [m/s]) to the state derivative, and ``C`` (p, n) real output selection.
Units and sign conventions of the bridge quantities are those of :mod:`bridgeflap.model` (see its
docstring); this module is unit-agnostic beyond what is stated below.

PSD convention (used by every function in this module)
------------------------------------------------------
All spectra are **one-sided in circular frequency**: ``G(omega)`` is defined for
``omega >= 0`` [rad/s] and the variance is ``sigma^2 = int_0^inf G(omega) d omega``.
For an input in [m/s] the unit of ``G`` is [m^2/s^2 per rad/s]; an output PSD has the output
unit squared per rad/s. The paper uses the two-sided ``S(omega)`` on ``(-inf, inf)``
(its Eqs. (15) and (17)); the two are related by ``G(omega) = 2 S(omega)``.

The cross-spectral density (CSD) matrix of the inputs is ``G_ww(omega)`` (m, m), Hermitian
positive semi-definite; for the buffeting case it is ``s(omega) * chi2(omega) * R(omega)``
with ``R`` the coherence matrix of Eq. (16) of the paper, see :func:`exponential_coherence`
and :func:`separable_csd`. The output CSD is (the paper's Eqs. (10)-(12))::

    G_yy(omega) = H(i omega) G_ww(omega) H(i omega)^H,   H(s) = C (s I - A)^{-1} B.

White noise: an input with correlation ``E[w(t) w(t + tau)^T] = Q delta(tau)`` (``Q`` the
*intensity*, as in the Lyapunov equation) has the two-sided PSD ``Q / (2 pi)`` and the one-sided
PSD ``G0 = Q / pi``; :func:`white_noise_intensity` converts ``G0`` to ``Q``.

References
----------
The independent checks (Lyapunov covariance, Monte-Carlo simulation) are in
:mod:`bridgeflap.model.response.simulation`.

Place and imports
-----------------
A foundation module (it was ``model/response/spectral.py``): it is pure LTI random-response
math, with no bridge, no aerodynamics and no state space of its own, and two layers use it --
the numeric buffeting analysis (:mod:`bridgeflap.model.response.buffeting`) and the CasADi form of
the same integral (:mod:`bridgeflap.model.aeroelastic.symbolic`, which sits below the response layer
and may alone hold CasADi beside :mod:`bridgeflap.model.aeroelastic.backend`). The integration limit
(:data:`OMEGA_MAX_FACTOR`) and the row-space factor of an input or output matrix
(:func:`row_factor`) are part of the same engine, shared by both, so they are here too
(:mod:`bridgeflap.model.response.buffeting` keeps both importable).

May import: numpy, scipy and :mod:`bridgeflap.model.errors` only.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from bridgeflap.model.errors import BridgeflapInputError

__all__ = [
    "OMEGA_MAX_FACTOR",
    "SpectralResult",
    "exponential_coherence",
    "separable_csd",
    "white_noise_intensity",
    "trapezoid_weights",
    "response_psd",
    "adaptive_frequency_grid",
    "rms_from_psd",
    "spectral_rms",
    "row_factor",
]

#: Upper integration limit as a multiple of the highest damped frequency of ``A(U)`` (the
#: buffeting analysis's and the symbolic integral's default).
OMEGA_MAX_FACTOR = 3.0

#: Largest eigenvector-matrix condition number for which the modal (diagonal) evaluation of
#: ``(i omega I - A)^{-1}`` is used; above it the backward-stable Schur path is taken. The modal
#: path loses about ``cond(V) * eps`` relative accuracy, i.e. ~1e-10 at this threshold.
MODAL_CONDITION_LIMIT = 1e6

CsdInput = Callable[[float], np.ndarray] | np.ndarray


# ----------------------------------------------------------------------------------------------
# result records
# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SpectralResult:
    """RMS of the outputs by frequency-domain quadrature (:func:`spectral_rms`).

    Attributes
    ----------
    rms : ndarray, shape (p,)
        Output standard deviations [output unit]; NaN when ``status == "unstable"``.
    omegas : ndarray, shape (n_omega,)
        Quadrature grid [rad/s] (the refined grid when refinement was done).
    psd : ndarray, shape (n_omega, p)
        One-sided output auto-PSDs on ``omegas`` [output unit^2 per rad/s].
    grid_points : int
        ``len(omegas)``.
    convergence : float
        ``max_j |rms_fine_j - rms_coarse_j| / rms_fine_j`` between the grid and its refinement
        (midpoints inserted) or, for tabulated input CSDs, its coarsening (every other point);
        an estimate of the quadrature error of the *coarser* grid. NaN if unstable.
    status : str
        ``"ok"``, ``"unconverged"`` (``convergence`` above the requested tolerance; the numbers
        are still reported, with this flag) or ``"unstable"`` (``max Re eig(A) >= 0``).
    max_real_eig : float
        Spectral abscissa of ``A`` [1/s].
    method : str
        ``"modal"`` or ``"schur"``: how the transfer matrix was evaluated.
    """

    rms: np.ndarray
    omegas: np.ndarray
    psd: np.ndarray
    grid_points: int
    convergence: float
    status: str
    max_real_eig: float
    method: str = field(default="modal")

    def plot(self, ax=None, labels=None):
        """Plot the output PSDs on a log scale (matplotlib imported lazily).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw in; a new figure is made when omitted.
        labels : sequence of str, optional
            One label per output.

        Returns
        -------
        matplotlib.axes.Axes
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        for j in range(self.psd.shape[1]):
            label = labels[j] if labels is not None else f"y{j}"
            ax.semilogy(self.omegas, self.psd[:, j], label=label)
        ax.set_xlabel("omega [rad/s]")
        ax.set_ylabel("one-sided PSD [unit^2 s/rad]")
        ax.legend()
        return ax


# ----------------------------------------------------------------------------------------------
# input spectra helpers
# ----------------------------------------------------------------------------------------------
def exponential_coherence(positions, decay_coefficient, wind_speed):
    """Coherence matrix of Eq. (16) of the paper as a function of frequency.

    Parameters
    ----------
    positions : array_like, shape (m,)
        Spanwise coordinates of the strips [m].
    decay_coefficient : float
        Decay coefficient ``c`` [-].
    wind_speed : float
        Mean wind speed ``U`` [m/s], > 0.

    Returns
    -------
    callable
        ``omega [rad/s] -> R (m, m)`` with ``R_ij = exp(-c * omega / (2 pi U) * |y_i - y_j|)``.
    """
    y = np.asarray(positions, dtype=float).ravel()
    if wind_speed <= 0:
        raise BridgeflapInputError("wind_speed", "must be > 0 for the coherence model")
    if decay_coefficient < 0:
        raise BridgeflapInputError("decay_coefficient", "must be >= 0")
    distance = np.abs(y[:, None] - y[None, :])
    scale = decay_coefficient / (2.0 * np.pi * wind_speed)

    def coherence(omega: float) -> np.ndarray:
        # Eq. (16) of the flutter/buffeting paper
        return np.exp(-scale * abs(omega) * distance)

    return coherence


def separable_csd(psd_scalar, coherence_fn, admittance_squared=None):
    """Input CSD ``G_ww(omega) = s(omega) * chi2(omega) * R(omega)`` as a callable.

    Parameters
    ----------
    psd_scalar : callable
        ``omega -> s(omega)``, one-sided PSD of one input [input unit^2 per rad/s].
    coherence_fn : callable
        ``omega -> R(omega)`` (m, m).
    admittance_squared : callable, optional
        ``omega -> chi2(omega)`` [-]; 1 when omitted.

    Returns
    -------
    callable
        ``omega -> G_ww(omega)`` (m, m).
    """

    def csd(omega: float) -> np.ndarray:
        factor = float(psd_scalar(omega))
        if admittance_squared is not None:
            factor *= float(admittance_squared(omega))
        return factor * np.asarray(coherence_fn(omega))

    return csd


def white_noise_intensity(one_sided_psd):
    """Intensity ``Q`` of white noise with flat one-sided PSD ``G0``: ``Q = pi * G0``.

    Parameters
    ----------
    one_sided_psd : array_like
        ``G0`` [unit^2 per rad/s], scalar or (m, m).

    Returns
    -------
    ndarray
        ``Q`` [unit^2 s], with ``E[w(t) w(t+tau)^T] = Q delta(tau)``.
    """
    return np.pi * np.asarray(one_sided_psd, dtype=float)


def trapezoid_weights(omegas):
    """Trapezoid-rule weights on a sorted, possibly non-uniform grid.

    Parameters
    ----------
    omegas : array_like, shape (n_omega,)
        Strictly increasing grid [rad/s].

    Returns
    -------
    ndarray, shape (n_omega,)
        Weights ``w_k`` [rad/s] with ``int f d omega ~ sum_k w_k f(omega_k)``.
    """
    w = np.asarray(omegas, dtype=float)
    if w.ndim != 1 or w.size < 2 or np.any(np.diff(w) <= 0):
        raise BridgeflapInputError("omegas", "need a strictly increasing 1-D grid of >= 2 points")
    h = np.diff(w)
    weights = np.zeros_like(w)
    weights[:-1] += 0.5 * h
    weights[1:] += 0.5 * h
    return weights


# ----------------------------------------------------------------------------------------------
# validation and transfer-matrix evaluation
# ----------------------------------------------------------------------------------------------
def check_system(A, B, C):
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    C = np.asarray(C, dtype=float)
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise BridgeflapInputError("A", f"must be square, got shape {A.shape}")
    n = A.shape[0]
    if B.ndim == 1:
        B = B[:, None]
    if C.ndim == 1:
        C = C[None, :]
    if B.ndim != 2 or B.shape[0] != n:
        raise BridgeflapInputError("B", f"must have {n} rows, got shape {B.shape}")
    if C.ndim != 2 or C.shape[1] != n:
        raise BridgeflapInputError("C", f"must have {n} columns, got shape {C.shape}")
    for name, mat in (("A", A), ("B", B), ("C", C)):
        if not np.all(np.isfinite(mat)):
            raise BridgeflapInputError(name, "contains non-finite entries")
    return A, B, C


def _csd_stack(input_csd, omegas, m):
    """Evaluate/validate the input CSD on ``omegas`` -> (n_omega, m, m) complex or real."""
    if callable(input_csd):
        S = np.stack([np.asarray(input_csd(float(w))) for w in omegas])
    else:
        S = np.asarray(input_csd)
        if S.ndim == 2 and len(omegas) == 1:
            S = S[None]
    if S.shape != (len(omegas), m, m):
        raise BridgeflapInputError(
            "input_csd", f"must give ({len(omegas)}, {m}, {m}) values, got shape {S.shape}"
        )
    if not np.all(np.isfinite(S)):
        raise BridgeflapInputError("input_csd", "contains non-finite values")
    if np.iscomplexobj(S) and np.max(np.abs(S.imag)) == 0.0:
        S = S.real
    return S


class _TransferEvaluator:
    """Evaluate ``C (i omega I - A)^{-1} B`` for many frequencies, A factorised once.

    ``modal``: A = V diag(lam) V^{-1}, so the transfer matrix is (C V) diag(1/(i w - lam))
    (V^{-1} B), vectorised over frequencies. ``schur``: A = Z T Z^H (complex Schur, backward
    stable), one triangular solve per frequency; used when cond(V) is large (near-defective A).
    """

    def __init__(self, A, B, C, method="auto"):
        if method not in ("auto", "modal", "schur"):
            raise BridgeflapInputError("method", "must be 'auto', 'modal' or 'schur'")
        self.n = A.shape[0]
        if method in ("auto", "modal"):
            lam, V = sla.eig(A)
            cond = np.linalg.cond(V)
            if method == "modal" or cond < MODAL_CONDITION_LIMIT:
                self.method = "modal"
                self.lam = lam
                self.CV = C @ V
                self.ViB = sla.solve(V, B.astype(complex))
                return
        self.method = "schur"
        T, Z = sla.schur(A, output="complex")
        self.T = T
        self.CZ = C @ Z
        self.ZhB = Z.conj().T @ B

    def transfer(self, omegas):
        """Return ``H(i omega_k)`` stacked, shape (len(omegas), p, m)."""
        omegas = np.asarray(omegas, dtype=float)
        if self.method == "modal":
            d = 1.0 / (1j * omegas[:, None] - self.lam[None, :])  # (k, n)
            scaled = self.CV[None, :, :] * d[:, None, :]  # (k, p, n)
            k, p, n = scaled.shape
            return (scaled.reshape(k * p, n) @ self.ViB).reshape(k, p, -1)
        out = np.empty((omegas.size, self.CZ.shape[0], self.ZhB.shape[1]), dtype=complex)
        eye = np.eye(self.n)
        for i, w in enumerate(omegas):
            Y = sla.solve_triangular(1j * w * eye - self.T, self.ZhB, check_finite=False)
            out[i] = self.CZ @ Y
        return out


def _output_psd(evaluator, omegas, S, full, chunk):
    """Core of :func:`response_psd` on an already factorised system."""
    n_omega = omegas.size
    p = evaluator.CV.shape[0] if evaluator.method == "modal" else evaluator.CZ.shape[0]
    out = np.empty((n_omega, p, p), dtype=complex) if full else np.empty((n_omega, p))
    for start in range(0, n_omega, chunk):
        sl = slice(start, min(start + chunk, n_omega))
        H = evaluator.transfer(omegas[sl])  # (k, p, m)
        if not full and not np.iscomplexobj(S):
            # real CSD (e.g. real coherence): diag(H S H^H) = rowsum((Hr S) Hr + (Hi S) Hi),
            # half the flops of the complex product
            Hr, Hi = np.ascontiguousarray(H.real), np.ascontiguousarray(H.imag)
            out[sl] = np.einsum("kpm,kpm->kp", Hr @ S[sl], Hr) + np.einsum(
                "kpm,kpm->kp", Hi @ S[sl], Hi
            )
            continue
        HS = H @ S[sl]  # (k, p, m)
        if full:
            out[sl] = HS @ np.conj(np.swapaxes(H, 1, 2))
        else:
            # diag(H S H^H) without forming the p x p product
            out[sl] = np.einsum("kpm,kpm->kp", HS, np.conj(H)).real
    return out


def response_psd(A, B, C, omegas, input_csd, *, full=False, method="auto", chunk=64):
    """One-sided output PSDs ``G_yy = H G_ww H^H`` on a frequency grid (the paper's Eqs. (10)-(12)).

    Parameters
    ----------
    A : array_like, shape (n, n)
        State matrix [1/s]. Not checked for stability here (see :func:`spectral_rms`).
    B : array_like, shape (n, m)
        Input matrix [state unit / (s * input unit)].
    C : array_like, shape (p, n)
        Output matrix [output unit / state unit].
    omegas : array_like, shape (n_omega,)
        Circular frequencies [rad/s], >= 0.
    input_csd : callable or array_like
        ``omega -> G_ww(omega)`` (m, m) Hermitian, or the values stacked as (n_omega, m, m);
        one-sided [input unit^2 per rad/s] (see the module docstring).
    full : bool, optional
        Return the full (n_omega, p, p) complex output CSD instead of the auto-PSDs.
    method : {"auto", "modal", "schur"}, optional
        Transfer evaluation: diagonalise ``A`` once (``modal``, used by ``auto`` when the
        eigenvector condition number is below :data:`MODAL_CONDITION_LIMIT`) or complex Schur
        form with a triangular solve per frequency (``schur``).
    chunk : int, optional
        Frequencies processed per vectorised block (memory ~ chunk * p * n complex).

    Returns
    -------
    ndarray
        (n_omega, p) real auto-PSDs [output unit^2 per rad/s], or (n_omega, p, p) complex.
    """
    A, B, C = check_system(A, B, C)
    omegas = np.atleast_1d(np.asarray(omegas, dtype=float))
    S = _csd_stack(input_csd, omegas, B.shape[1])
    evaluator = _TransferEvaluator(A, B, C, method)
    return _output_psd(evaluator, omegas, S, full, max(1, int(chunk)))


# ----------------------------------------------------------------------------------------------
# frequency grid and quadrature
def adaptive_frequency_grid(
    A, omega_max, n_base=200, peaks_per_mode=41, half_widths=30.0, omega_min=None
):
    """Frequency grid resolving the lightly damped peaks of ``A``.

    Union of a linear grid on ``[0, omega_max]``, a log grid on ``[omega_min, omega_max]`` and,
    for every under-damped eigenvalue ``lam`` (``|Im lam| > |Re lam|``, each conjugate pair
    once), a cluster ``|Im lam| + |Re lam| * sinh(u)`` with ``u`` uniform in
    ``[-asinh(half_widths), asinh(half_widths)]``: linear spacing ``~ |Re lam| du`` at the peak
    (``|Re lam|`` is the half-power half-bandwidth of the resonance) and logarithmic spacing on
    the flanks.

    Parameters
    ----------
    A : array_like, shape (n, n)
        State matrix [1/s].
    omega_max : float
        Upper end of the grid [rad/s].
    n_base : int, optional
        Points of each base grid (linear and log).
    peaks_per_mode : int, optional
        Points per resonance cluster.
    half_widths : float, optional
        Half-extent of a cluster in half-power half-bandwidths.
    omega_min : float, optional
        Lower end of the log base grid [rad/s]; ``1e-4 * omega_max`` when omitted.

    Returns
    -------
    ndarray
        Sorted unique grid [rad/s], starting at 0 and ending at ``omega_max``.
    """
    if not omega_max > 0:
        raise BridgeflapInputError("omega_max", "must be > 0")
    lam = np.linalg.eigvals(np.asarray(A, dtype=float))
    lo = 1e-4 * omega_max if omega_min is None else float(omega_min)
    parts = [np.linspace(0.0, omega_max, int(n_base)), np.geomspace(lo, omega_max, int(n_base))]
    u_max = np.arcsinh(half_widths)
    u = np.linspace(-u_max, u_max, int(peaks_per_mode))
    for ev in lam:
        omega_d, sigma = ev.imag, abs(ev.real)
        if omega_d <= 0 or sigma >= omega_d:  # one of each pair; skip over-damped roots
            continue
        if sigma == 0.0:  # marginal: no finite bandwidth; spectral_rms reports "unstable"
            sigma = 1e-9 * omega_d
        parts.append(omega_d + sigma * np.sinh(u))
    grid = np.concatenate(parts)
    grid = grid[(grid >= 0.0) & (grid <= omega_max)]
    grid = np.unique(grid)
    # merge points closer than a relative 1e-12 (would give ill-scaled trapezoid panels)
    keep = np.concatenate([[True], np.diff(grid) > 1e-12 * omega_max])
    return grid[keep]


def rms_from_psd(omegas, psd):
    """RMS from one-sided PSDs by the trapezoid rule: ``sqrt(int_0^omega_max G d omega)``.

    Parameters
    ----------
    omegas : array_like, shape (n_omega,)
        Strictly increasing grid [rad/s].
    psd : array_like, shape (n_omega,) or (n_omega, p)
        One-sided PSDs [unit^2 per rad/s].

    Returns
    -------
    ndarray or float
        RMS [unit], shape (p,) or scalar.
    """
    weights = trapezoid_weights(omegas)
    psd = np.asarray(psd, dtype=float)
    return np.sqrt(np.tensordot(weights, psd, axes=(0, 0)))


def _midpoints(omegas):
    mid = 0.5 * (omegas[1:] + omegas[:-1])
    return np.sort(np.concatenate([omegas, mid]))


def spectral_rms(
    A,
    B,
    C,
    input_csd,
    omega_max=None,
    *,
    omegas=None,
    n_base=200,
    peaks_per_mode=41,
    half_widths=30.0,
    refine=True,
    convergence_tol=1e-2,
    method="auto",
):
    """Output RMS by quadrature of the one-sided output PSD (the paper's Eq. (17), one-sided form).

    ``sigma_j^2 = int_0^omega_max G_yy,jj(omega) d omega`` by the trapezoid rule on
    :func:`adaptive_frequency_grid` (or on ``omegas``); the tail above ``omega_max`` is not
    included, choose ``omega_max`` well above the highest relevant mode.

    Parameters
    ----------
    A, B, C : array_like
        System matrices, see :func:`response_psd`.
    input_csd : callable or array_like
        One-sided input CSD, see :func:`response_psd`. An array must be tabulated on
        ``omegas``.
    omega_max : float, optional
        Upper integration limit [rad/s]; required unless ``omegas`` is given.
    omegas : array_like, optional
        Fixed quadrature grid [rad/s] (overrides the adaptive grid).
    n_base, peaks_per_mode, half_widths : optional
        Passed to :func:`adaptive_frequency_grid`.
    refine : bool, optional
        If True and ``input_csd`` is callable, evaluate also at the midpoints and return the
        refined (doubled) grid's RMS; ``convergence`` compares it with the unrefined grid.
        Otherwise ``convergence`` compares the grid with its every-other-point coarsening.
    convergence_tol : float, optional
        Relative ``convergence`` above which ``status = "unconverged"``.
    method : {"auto", "modal", "schur"}, optional
        See :func:`response_psd`.

    Returns
    -------
    SpectralResult
        ``status == "unstable"`` with NaN numbers when ``max Re eig(A) >= 0`` (never clipped:
        the RMS grows without bound as the flutter speed is approached).
    """
    A, B, C = check_system(A, B, C)
    p = C.shape[0]
    lam = np.linalg.eigvals(A)
    abscissa = float(np.max(lam.real)) if lam.size else -np.inf
    if omegas is None:
        if omega_max is None:
            raise BridgeflapInputError("omega_max", "give omega_max or a fixed grid omegas")
        grid = adaptive_frequency_grid(A, omega_max, n_base, peaks_per_mode, half_widths)
    else:
        grid = np.asarray(omegas, dtype=float)
        trapezoid_weights(grid)  # validates
    if abscissa >= 0.0:
        nan = np.full(p, np.nan)
        return SpectralResult(
            rms=nan,
            omegas=grid,
            psd=np.full((grid.size, p), np.nan),
            grid_points=int(grid.size),
            convergence=float("nan"),
            status="unstable",
            max_real_eig=abscissa,
            method="none",
        )
    evaluator = _TransferEvaluator(A, B, C, method)
    m = B.shape[1]
    S = _csd_stack(input_csd, grid, m)
    psd = _output_psd(evaluator, grid, S, False, 64)
    rms = rms_from_psd(grid, psd)
    if refine and callable(input_csd) and grid.size >= 2:
        mid = 0.5 * (grid[1:] + grid[:-1])
        psd_mid = _output_psd(evaluator, mid, _csd_stack(input_csd, mid, m), False, 64)
        fine = np.empty(2 * grid.size - 1)
        fine[0::2], fine[1::2] = grid, mid
        psd_fine = np.empty((fine.size, p))
        psd_fine[0::2], psd_fine[1::2] = psd, psd_mid
        rms_fine = rms_from_psd(fine, psd_fine)
        rms_coarse, grid, psd, rms = rms, fine, psd_fine, rms_fine
    else:
        idx = np.arange(0, grid.size, 2)
        if idx[-1] != grid.size - 1:
            idx = np.append(idx, grid.size - 1)
        rms_coarse = rms_from_psd(grid[idx], psd[idx]) if idx.size >= 2 else rms
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(rms > 0, np.abs(rms - rms_coarse) / rms, 0.0)
    convergence = float(np.max(rel)) if rel.size else 0.0
    status = "ok" if convergence <= convergence_tol else "unconverged"
    return SpectralResult(
        rms=rms,
        omegas=grid,
        psd=psd,
        grid_points=int(grid.size),
        convergence=convergence,
        status=status,
        max_real_eig=abscissa,
        method=evaluator.method,
    )


def row_factor(M, rtol=1e-12):
    """``M = L R`` with ``R`` orthonormal rows spanning the row space of ``M`` (SVD)."""
    U_, s, Vt = np.linalg.svd(M, full_matrices=False)
    r = int(np.sum(s > rtol * (s[0] if s.size else 0.0))) if s.size and s[0] > 0 else 0
    r = max(r, 1)
    return U_[:, :r] * s[:r], Vt[:r]
