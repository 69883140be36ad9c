"""Buffeting: RMS deck response to span-wise correlated vertical turbulence (the paper, §3 and §5).

Conventions of :mod:`bridgeflap.model` apply (SI units; heave ``h`` down, pitch ``alpha`` nose-up
about mid-chord; ``k = omega b / U``). Spectra are **one-sided in circular frequency** as in
:mod:`bridgeflap.model.spectral` (``sigma^2 = int_0^inf G d omega``); the paper's Eqs. (15) and (17)
are the same quantities written two-sided (``G = 2 S``).

Model (the paper's Eqs. (7)-(8), (10)-(17), thin aerofoil with ``C_L = C_M = C_D = 0``)::

    x' = A(U) x + B_gust(U) w_tilde,    y = C_out x      (self-excited forces inside A(U))
    G_ww(omega) = s_w(omega) chi^2(k) R(omega),   R_ij = exp(-c n |y_i - y_j| / U),  n = omega/2pi

with ``w_tilde`` the strip gust velocities after the admittance ``chi`` (``chi_Lw = chi_Mw``),
``s_w`` a vertical-turbulence spectrum (:func:`bridgeflap.model.aero.wind.vertical_spectrum`,
converted to ``omega``: ``G(omega) = S(n) / (2 pi)``) and ``c`` the Davenport decay constant (an
estimate, docs/humber_data.md#turbulence-spectrum-and-coherence).

Cost (the load CSD is separable and ``B_gust`` has rank ``r <= n_modes``): ``B_gust = B_l V^T``
and ``C_out = C_l C_r`` are factorised once per speed (SVD), the load CSD is projected,
``V^T R(omega) V`` (r x r), with an O(m) recursion instead of the m x m coherence matrix
(the exponential coherence on a line is the covariance of a Markov process, so ``R v`` is a
forward plus a backward first-order scan), and the transfer matrix ``C_r (i omega - A)^{-1} B_l``
(r_c x r) is evaluated in the diagonalised (modal) form of
:func:`bridgeflap.model.spectral.response_psd`. The strip variances are ``diag(C_l P C_l^T)`` with
``P
= int G_qq d omega`` of the reduced outputs, so the strip outputs never enter the frequency loop.

References
----------
Davenport (1962) Proc. ICE 23; Sears (1941) J. Aero. Sci. 8; Liepmann (1952) J. Aero. Sci. 19;
Busch & Panofsky (1968) QJRMS 94; Massaro, Limebeer et al. (the paper) Eqs. (7)-(17), Fig. 4.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bridgeflap.model.aero.gust import GustField, coherence_projection, gust_field
from bridgeflap.model.aeroelastic.controller_file import as_controller
from bridgeflap.model.arguments import count, flag, number, optional
from bridgeflap.model.errors import BridgeflapError, BridgeflapInputError
from bridgeflap.model.grid import speed_grid
from bridgeflap.model.response.buffeting_inputs import LOADS, resolve_system
from bridgeflap.model.response.simulation import simulate_monte_carlo
from bridgeflap.model.results import ResultData, finite_extreme
from bridgeflap.model.spectral import (
    OMEGA_MAX_FACTOR,
    adaptive_frequency_grid,
    exponential_coherence,
    response_psd,
    row_factor,
    trapezoid_weights,
)
from bridgeflap.model.spectrum import spectral_abscissa
from bridgeflap.model.structure.bridge_arg import takes_bridge
from bridgeflap.model.vocabulary import DEFAULT_MODES

__all__ = ["LOADS", "BuffetingResult", "buffeting", "reduced_response", "row_factor"]

METHODS = ("spectral", "monte-carlo")
#: Relative grid-convergence estimate above which a speed is flagged ``"unconverged"``.
CONVERGENCE_TOL = 5e-3


@dataclass(frozen=True)
class _SpeedResponse:
    rms: np.ndarray            # (p,) strip outputs (heave then pitch)
    convergence: float
    grid_points: int
    omegas: np.ndarray
    psd_reduced: np.ndarray    # (n_omega, rc, rc) complex, reduced-output CSD
    C_left: np.ndarray         # (p, rc)
    status: str
    abscissa: float


def reduced_response(A, B, C, positions, wind_speed, gust: GustField, *, omega_max=None,
                     omegas=None, n_base=120, peaks_per_mode=41, half_widths=30.0,
                     convergence_tol=CONVERGENCE_TOL, extra_inputs=()) -> _SpeedResponse:
    """Spectral RMS of ``y = C x`` for the buffeting CSD at one speed (rank-reduced).

    Parameters
    ----------
    A : array_like, shape (n, n)
        ``A(U)`` [1/s].
    B : array_like, shape (n, m)
        ``B_gust(U)``: strip gust velocities [m/s] to ``x'``.
    C : array_like, shape (p, n)
        Output map.
    extra_inputs : sequence of (B, GustField), optional
        Further gust components, uncorrelated with the first and with each other (the
        along-wind ``u`` of the quasi-steady loads, :mod:`bridgeflap.model.aero.quasi_steady`):
        their response spectra are added on the same grid.
    positions : array_like, shape (m,)
        Strip coordinates [m].
    wind_speed : float
        ``U`` [m/s], > 0.
    gust : GustField
        Spectrum, admittance, coherence.
    omega_max : float, optional
        Upper limit [rad/s]; ``OMEGA_MAX_FACTOR`` times the highest damped frequency of ``A``.
    omegas : array_like, optional
        Fixed grid [rad/s] (overrides the adaptive grid).
    n_base, peaks_per_mode, half_widths : optional
        :func:`bridgeflap.model.spectral.adaptive_frequency_grid` settings.
    convergence_tol : float, optional
        Relative difference between the grid and its every-other-point coarsening above which
        the adaptive grid is refined (``n_base`` and ``peaks_per_mode`` doubled, at most twice)
        and, if still above, the status is ``"unconverged"`` (numbers kept, flagged).

    Returns
    -------
    _SpeedResponse
        RMS [output unit], NaN with status ``"unstable"`` when ``max Re eig(A) >= 0``.
    """
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    C = np.asarray(C, dtype=float)
    U = float(wind_speed)
    lam = np.linalg.eigvals(A)
    abscissa = float(np.max(lam.real))
    Cl, Cr = row_factor(C)
    if abscissa >= 0.0:  # at or beyond flutter/divergence: report, never clip
        grid = np.zeros(1) if omegas is None else np.asarray(omegas, dtype=float)
        return _SpeedResponse(np.full(C.shape[0], np.nan), float("nan"), int(grid.size), grid,
                              np.full((grid.size, Cr.shape[0], Cr.shape[0]), np.nan + 0j), Cl,
                              "unstable", abscissa)
    if omega_max is None:
        omega_max = OMEGA_MAX_FACTOR * float(np.abs(lam.imag).max())
        if omega_max <= 0:  # no oscillatory root: scale on the fastest real root
            omega_max = 10.0 * float(np.abs(lam).max())
    comps = [(row_factor(B), gust)] + [(row_factor(np.asarray(Bx, float)), gx)
                                       for Bx, gx in extra_inputs]
    # near flutter the peaks narrow: refine the adaptive grid (twice at most) until converged
    for attempt in range(3 if omegas is None else 1):
        if omegas is None:
            grid = adaptive_frequency_grid(A, omega_max, n_base * 2 ** attempt,
                                           peaks_per_mode * 2 ** attempt, half_widths)
        else:
            grid = np.asarray(omegas, dtype=float)
        Gqq = 0.0
        for (Bl, Vt), g in comps:  # uncorrelated components: their response PSDs add
            scale = g.psd(grid, U) * g.admittance_sq(grid, U)  # s_w chi^2, one-sided
            S = scale[:, None, None] * coherence_projection(positions, Vt.T, grid, U,
                                                            g.coherence_decay)
            Gqq = Gqq + response_psd(A, Bl, Cr, grid, S, full=True)  # (n_omega, rc, rc)
        rms = _strip_rms(grid, Gqq, Cl)
        idx = np.arange(0, grid.size, 2)
        if idx[-1] != grid.size - 1:
            idx = np.append(idx, grid.size - 1)
        rms_coarse = _strip_rms(grid[idx], Gqq[idx], Cl)
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.where(rms > 1e-300, np.abs(rms - rms_coarse) / rms, 0.0)
        conv = float(np.max(rel))
        if conv <= convergence_tol:
            break
    status = "ok" if conv <= convergence_tol else "unconverged"
    return _SpeedResponse(rms, conv, int(grid.size), grid, Gqq, Cl, status, abscissa)


def _strip_rms(grid, Gqq, Cl):
    P = np.tensordot(trapezoid_weights(grid), Gqq, axes=(0, 0)).real
    P = 0.5 * (P + P.T)
    return np.sqrt(np.clip(np.einsum("pi,ij,pj->p", Cl, P, Cl), 0.0, None))


# -------------------------------------------------------------------------------- result
@dataclass(frozen=True)
class BuffetingResult(ResultData):
    """Buffeting response against wind speed.

    Attributes
    ----------
    speeds : ndarray, shape (n_U,)
        Mean wind speeds [m/s].
    strip_x : ndarray, shape (n_strip,)
        Strip positions from the north anchorage [m].
    main_span : ndarray of bool, shape (n_strip,)
        Strips on the main span.
    rms_heave : ndarray, shape (n_U, n_strip)
        RMS deck heave per strip [m].
    rms_pitch : ndarray, shape (n_U, n_strip)
        RMS deck pitch per strip [rad].
    rms_vertical : ndarray, shape (n_U,)
        Maximum of ``rms_heave`` over the main span [m] (the paper's Fig. 4 ordinate times 2b).
    rms_torsion : ndarray, shape (n_U,)
        Maximum of ``rms_pitch`` over the main span [rad].
    deck_width_m : float
        ``2 b`` [m].
    status : tuple of str
        Per speed: ``"ok"``, ``"unconverged"`` (numbers kept and flagged) or ``"unstable"``
        (at or beyond flutter/divergence: NaN, never clipped).
    convergence : ndarray, shape (n_U,)
        Spectral: relative change of the strip RMS between the grid and its every-other-point
        coarsening (an estimate of the coarse grid's quadrature error, so conservative).
        Monte-Carlo: relative standard error of ``rms_vertical``.
    grid_points : ndarray of int
        Frequencies used per speed.
    spectral_abscissa : ndarray
        ``max Re eig A(U)`` [1/s].
    method : str
        ``"spectral"`` or ``"monte-carlo"``.
    inputs : dict
        Inputs used (gust field, modes, bridge).
    standard_error_vertical : ndarray
        Monte-Carlo standard error of ``rms_vertical`` [m] (NaN for the spectral method).
    psd_omegas, psd_vertical, psd_torsion : tuple of ndarray
        Per speed: grid [rad/s] and one-sided PSDs [m^2 s/rad], [rad^2 s/rad] at the main-span
        strip of largest RMS (spectral method only; empty arrays otherwise).
    """

    speeds: np.ndarray
    strip_x: np.ndarray
    main_span: np.ndarray
    rms_heave: np.ndarray
    rms_pitch: np.ndarray
    rms_vertical: np.ndarray
    rms_torsion: np.ndarray
    deck_width_m: float
    status: tuple
    convergence: np.ndarray
    grid_points: np.ndarray
    spectral_abscissa: np.ndarray
    method: str
    inputs: dict = field(default_factory=dict)
    standard_error_vertical: np.ndarray | None = None
    psd_omegas: tuple = ()
    psd_vertical: tuple = ()
    psd_torsion: tuple = ()
    elapsed_s: float = float("nan")

    @property
    def rms_vertical_over_width(self) -> np.ndarray:
        """``max sigma_z / (2 b)`` on the main span [-] (the paper's Fig. 4)."""
        return self.rms_vertical / self.deck_width_m

    def summary(self) -> dict:
        """The ``bridgeflap buffeting`` JSON contract (NaN becomes null in the CLI).

        Returns
        -------
        dict
            Lists per speed ``speeds_m_s`` [m/s]: ``rms_vertical_m`` [m], ``rms_torsion_rad``
            [rad], ``rms_vertical_over_width`` [-], status, convergence, ...; ``inputs``.
        """
        se = (self.standard_error_vertical if self.standard_error_vertical is not None
              else np.full(self.speeds.size, np.nan))
        return {
            "speeds_m_s": self.speeds.tolist(),
            "rms_vertical_m": self.rms_vertical.tolist(),
            "rms_torsion_rad": self.rms_torsion.tolist(),
            "rms_vertical_over_width": self.rms_vertical_over_width.tolist(),
            "status": list(self.status),
            "convergence": self.convergence.tolist(),
            "grid_points": [int(g) for g in self.grid_points],
            "spectral_abscissa_1_s": self.spectral_abscissa.tolist(),
            "standard_error_vertical_m": np.asarray(se, dtype=float).tolist(),
            "x_max_vertical_m": [self._argmax_x(self.rms_heave[i]) for i in
                                 range(self.speeds.size)],
            "method": self.method,
            "deck_width_m": self.deck_width_m,
            "elapsed_s": self.elapsed_s,
            "inputs": dict(self.inputs),
        }

    def _headline(self) -> dict:
        """Bridge, method, the speed range and the largest RMS responses over it."""
        st = list(self.status)
        return {"bridge": self.inputs.get("bridge", ""), "method": self.method,
                "speeds": self.speeds.size, "speed_min_m_s": float(self.speeds.min()),
                "speed_max_m_s": float(self.speeds.max()),
                "max_rms_vertical_m": finite_extreme(self.rms_vertical),
                "max_rms_torsion_rad": finite_extreme(self.rms_torsion),
                "status": ", ".join(f"{st.count(k)} {k}" for k in dict.fromkeys(st))}

    def _rows(self) -> list[dict]:
        """One row per speed (units in the column names)."""
        s = self.summary()
        keys = {"speed_m_s": "speeds_m_s", "rms_vertical_m": "rms_vertical_m",
                "rms_torsion_rad": "rms_torsion_rad",
                "rms_vertical_over_width": "rms_vertical_over_width", "status": "status",
                "convergence_rel": "convergence", "grid_points": "grid_points",
                "spectral_abscissa_1_s": "spectral_abscissa_1_s",
                "standard_error_vertical_m": "standard_error_vertical_m",
                "x_max_vertical_m": "x_max_vertical_m"}
        return [{k: s[v][i] for k, v in keys.items()} for i in range(self.speeds.size)]

    def _argmax_x(self, row) -> float:
        vals = np.where(self.main_span, row, -np.inf)
        if not np.any(np.isfinite(row[self.main_span])):
            return float("nan")
        return float(self.strip_x[int(np.nanargmax(vals))])

    def plot(self, axes=None, label=None, log: bool = False):
        """Vertical ``max sigma_z`` [mm] (``/ 2b`` on a right-hand axis) and torsional
        ``max sigma_alpha`` [deg] on the main span against ``U`` (the paper's Fig. 4 style, two
        panels; :func:`bridgeflap.model.response.plots.buffeting_panels`). Unstable speeds are
        NaN and leave a gap; nothing is clipped.

        Parameters
        ----------
        axes : sequence of two matplotlib.axes.Axes, optional
            Vertical and torsional axes (default: a new figure).
        label : str, optional
            Legend label of this curve (default: none).
        log : bool, default False
            Logarithmic response axes.

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        from bridgeflap.model.response.plots import buffeting_panels

        return buffeting_panels({label: self}, axes, log=log,
                                title=f"{self.inputs.get('bridge', '')} buffeting "
                                      f"({self.method})")

    def plot_psd(self, ax=None, speeds=None):
        """One-sided PSDs of heave and pitch at the main-span strip of largest RMS.

        Parameters
        ----------
        ax : sequence of two matplotlib Axes, optional
            Heave and pitch axes (default: a new figure).
        speeds : sequence of float, optional
            Speeds to show [m/s] (nearest computed); all when omitted.

        Returns
        -------
        sequence of two matplotlib.axes.Axes
            The heave and pitch axes drawn on.

        Raises
        ------
        BridgeflapError
            The result holds no PSDs (the Monte-Carlo method stores none).
        """
        import matplotlib.pyplot as plt

        if not self.psd_omegas:
            raise BridgeflapError("PSDs are stored by the spectral method only")
        if ax is None:
            _, ax = plt.subplots(1, 2, figsize=(10, 4))
        idx = (range(self.speeds.size) if speeds is None else
               sorted({int(np.argmin(np.abs(self.speeds - u))) for u in speeds}))
        for i in idx:
            if self.status[i] == "unstable":
                continue
            f = self.psd_omegas[i] / (2 * np.pi)
            ax[0].loglog(f[1:], self.psd_vertical[i][1:], label=f"U = {self.speeds[i]:g} m/s")
            ax[1].loglog(f[1:], self.psd_torsion[i][1:], label=f"U = {self.speeds[i]:g} m/s")
        ax[0].set_ylabel("heave PSD, one-sided in omega [m^2 s/rad]")
        ax[1].set_ylabel("pitch PSD, one-sided in omega [rad^2 s/rad]")
        for a in ax:
            a.set_xlabel("frequency [Hz]")
            a.grid(alpha=0.3, which="both")
            a.legend(fontsize=7)
        return ax


# -------------------------------------------------------------------------------- driver
def _main_span_mask(spec, strip_x):
    if spec is None:
        return np.ones(strip_x.size, dtype=bool)
    starts = np.concatenate([[0.0], np.cumsum([s.length_m for s in spec.spans])])
    x0, x1 = starts[spec.main_span_index], starts[spec.main_span_index + 1]
    return (strip_x >= x0) & (strip_x <= x1)


def _check_speeds(speeds) -> np.ndarray:
    """``speeds`` [m/s] in any form of :func:`bridgeflap.model.grid.speed_grid`, each > 0."""
    return speed_grid(speeds, positive=True)


@takes_bridge(controller=optional(as_controller), allow_unstable=flag,
              turbulence_intensity=optional(number(0.0, 1.0, strict=True)),
              deck_height_m=optional(number(0.0, 1.0e4, strict=True)),
              length_scale_m=optional(number(0.0, 1.0e5, strict=True)),
              half_chord_m=optional(number(0.0, 1.0e3, strict=True)),
              coherence_decay=optional(number(0.0, 1.0e3)),
              omega_max=optional(number(0.0, 1.0e6, strict=True)),
              n_base=count(1, 100000), peaks_per_mode=count(1, 10001),
              half_widths=number(0.0, 1.0e3, strict=True),
              convergence_tol=number(0.0, 1.0, strict=True), mc_records=count(1, 10000),
              mc_seed=count(0, 2**32 - 1), mc_points=optional(count(2, 1000000)))
def buffeting(bridge, speeds, spectrum="busch-panofsky", admittance=None,
              coherence_decay=None, n_modes=DEFAULT_MODES, method="spectral", *, spec=None,
              turbulence_intensity=None, deck_height_m=None, length_scale_m=None,
              half_chord_m=None, controller=None, allow_unstable=True, omega_max=None,
              n_base=120, peaks_per_mode=41, half_widths=30.0,
              convergence_tol=CONVERGENCE_TOL, mc_records=16, mc_seed=0,
              mc_points=None, loads=None) -> BuffetingResult:
    """RMS deck response to vertical turbulence over a range of wind speeds (the paper, §5, Fig. 4).

    Parameters
    ----------
    bridge : str, os.PathLike, BridgeSpec or AeroelasticSystem
        Bridge name, file or definition (the modal state space is built with ``n_modes``), or a
        built system
        with ``A(U)``, ``B_gust(U)``, ``C_out`` and ``basis`` (then ``spec`` gives the wind
        defaults and the main span; without it every strip counts as main span).
    speeds : str or array_like
        Mean wind speeds at deck height [m/s], > 0: ``"lo:hi:step"`` or ``"10,20"`` text or
        numbers (:func:`bridgeflap.model.grid.speed_grid`).
    spectrum : {"busch-panofsky", "von-karman", "kaimal"} or callable
        Vertical turbulence spectrum (the paper's Eq. (15) is Busch-Panofsky).
    admittance : {"liepmann", "sears", "unit"} or callable, optional
        ``|chi(k)|^2`` with ``k = omega b / U``, for every gust component (default: Liepmann,
        as the paper, for thin-aerofoil loads; ``"unit"``, i.e. quasi-steady, for quasi-steady).
    coherence_decay : float, optional
        Davenport ``c`` [-] (the paper's Eq. (16)); ``spec.aero.coherence_decay`` when omitted.
    n_modes : int, optional
        Retained vertical + torsional modes (default :data:`bridgeflap.model.DEFAULT_MODES`).
    method : {"spectral", "monte-carlo"}
        Frequency-domain quadrature, or time-domain simulation
        (:func:`bridgeflap.model.response.simulation.simulate_monte_carlo`) as an independent check.
    spec : BridgeSpec, optional
        Wind defaults and main span when ``bridge`` is a system.
    turbulence_intensity, deck_height_m, length_scale_m, half_chord_m : float, optional
        Overrides of ``sigma_w/U`` [-], ``z`` [m], von Karman ``L_w`` [m] and ``b`` [m].
    controller : object, optional
        Passed to ``model.aeroelastic.flaps.closed_loop_system(spec, controller, n_modes)``.
    allow_unstable : bool, optional
        If False, raise :class:`BridgeflapInputError` when any requested speed has
        ``max Re eig A(U) >= 0`` (checked before any response is computed); if True (default)
        such speeds are reported as NaN with status ``"unstable"``.
    omega_max : float, optional
        Integration limit [rad/s] (default 3x the highest damped frequency of ``A(U)``).
    n_base, peaks_per_mode, half_widths, convergence_tol : optional
        Quadrature grid settings (:func:`bridgeflap.model.spectral.adaptive_frequency_grid`).
    mc_records, mc_seed, mc_points : optional
        Monte-Carlo records, seed and number of synthesis frequencies (default: spacing a
        quarter of the smallest half-power half-bandwidth, at most 8000 points).
    loads : {"thin-aerofoil", "quasi-steady"}, optional
        Gust loads: the paper's Eq. (8) from ``aero.lift_slope_buffeting`` and
        ``aero.moment_slope_buffeting`` (default for thin-aerofoil bridges), or the
        quasi-steady ``u`` and ``w`` loads of the bridge's ``[static_coefficients]``
        (:mod:`bridgeflap.model.aero.quasi_steady`; default, and the only choice, for a bridge with
        flutter-derivative self-excited loads, whose ``A(U)`` is the Roger state space).

    Returns
    -------
    BuffetingResult

    Examples
    --------
    >>> from bridgeflap import model
    >>> res = model.buffeting("humber", [10.0, 20.0], n_modes=6)
    >>> res.status, bool(res.rms_vertical[1] > res.rms_vertical[0])
    (('ok', 'ok'), True)
    """
    import time

    t0 = time.perf_counter()
    if method not in METHODS:
        raise BridgeflapInputError("method", f"must be one of {METHODS}, got {method!r}")
    if not (isinstance(n_modes, int | np.integer) and n_modes >= 1):
        raise BridgeflapInputError("modes", f"must be an integer >= 1, got {n_modes!r}")
    u = _check_speeds(speeds)
    spec, system, basis, loads = resolve_system(bridge, int(n_modes), controller,
                                                 spec, loads)
    if admittance is None:
        admittance = "unit" if loads == "quasi-steady" else "liepmann"
    gust = gust_field(spec, spectrum=spectrum, admittance=admittance,
                      coherence_decay=coherence_decay, turbulence_intensity=turbulence_intensity,
                      deck_height_m=deck_height_m, length_scale_m=length_scale_m,
                      half_chord_m=half_chord_m if half_chord_m is not None else (
                          None if spec is not None else getattr(getattr(system, "aero", None),
                                                                "half_chord", None)))
    extra, static = (), None
    if loads == "quasi-steady":
        from bridgeflap.model.aero.gust import GustField
        from bridgeflap.model.aero.quasi_steady import von_karman_u

        static = spec.static_coefficients
        if system.extras.get("Bw1_u") is not None:
            gust_u = GustField(
                spectrum=von_karman_u(static.turbulence_intensity_u, static.length_scale_u_m),
                admittance=gust.admittance, turbulence_intensity=static.turbulence_intensity_u,
                deck_height_m=gust.deck_height_m, coherence_decay=gust.coherence_decay,
                half_chord_m=gust.half_chord_m)
            extra = ((system.extras["Bw1_u"], gust_u),)
        if method != "spectral" and extra:
            raise BridgeflapInputError("method", "monte-carlo simulates the vertical gust "
                                       "only; the quasi-steady u loads need 'spectral'")
    strip_x = np.asarray(basis.strip_x, dtype=float)
    main = _main_span_mask(spec, strip_x)
    ns = strip_x.size
    A_list = [np.asarray(system.A(U), dtype=float) for U in u]
    absc = np.array([spectral_abscissa(A) for A in A_list])
    if not allow_unstable and np.any(absc >= 0):
        bad = ", ".join(f"{U:g}" for U in u[absc >= 0])
        raise BridgeflapInputError(
            "speeds", f"at or beyond the flutter/divergence limit (max Re eig A(U) >= 0) at "
                      f"U = {bad} m/s; pass --allow-unstable to report them as NaN")
    C = np.asarray(system.C_out, dtype=float)
    rms = np.full((u.size, C.shape[0]), np.nan)
    status, conv = [], np.full(u.size, np.nan)
    grid_pts = np.zeros(u.size, dtype=int)
    se_v = np.full(u.size, np.nan)
    psd_w, psd_v, psd_t = [], [], []
    for i, (U, A) in enumerate(zip(u, A_list, strict=True)):
        B = np.asarray(system.B_gust(U), dtype=float)
        if method == "spectral":
            r = reduced_response(A, B, C, strip_x, U, gust, omega_max=omega_max, n_base=n_base,
                                 peaks_per_mode=peaks_per_mode, half_widths=half_widths,
                                 convergence_tol=convergence_tol,
                                 extra_inputs=[(U * Bx, g) for Bx, g in extra])
            rms[i], conv[i], grid_pts[i] = r.rms, r.convergence, r.grid_points
            status.append(r.status)
            if r.status != "unstable":
                jv = int(np.argmax(np.where(main, r.rms[:ns], -np.inf)))
                jt = int(np.argmax(np.where(main, r.rms[ns:2 * ns], -np.inf)))
                rows = r.C_left[[jv, ns + jt]]
                G = np.einsum("pi,kij,pj->kp", rows, r.psd_reduced, rows).real
                psd_w.append(r.omegas)
                psd_v.append(G[:, 0])
                psd_t.append(G[:, 1])
            else:
                psd_w.append(r.omegas)
                psd_v.append(np.full(r.omegas.size, np.nan))
                psd_t.append(np.full(r.omegas.size, np.nan))
        else:
            mc = _monte_carlo(A, B, C, strip_x, U, gust, main, ns, mc_records, mc_seed,
                              mc_points, omega_max)
            rms[i], se_v[i], grid_pts[i] = mc["rms"], mc["se_vertical"], mc["points"]
            conv[i] = mc["rel_se"]
            status.append(mc["status"])
    heave, pitch = rms[:, :ns], rms[:, ns:2 * ns]
    with np.errstate(invalid="ignore"):
        vmax = np.array([np.max(h[main]) if np.all(np.isfinite(h[main])) else np.nan
                         for h in heave])
        tmax = np.array([np.max(p[main]) if np.all(np.isfinite(p[main])) else np.nan
                         for p in pitch])
    inputs = gust.summary()
    inputs.update({"modes_retained": int(n_modes), "states": int(A_list[0].shape[0]),
                   "strips": int(ns), "main_span_strips": int(main.sum()),
                   "lift_slope_buffeting": _aero_attr(system, spec, "lift_slope_buffeting"),
                   "moment_slope_buffeting": _aero_attr(system, spec, "moment_slope_buffeting"),
                   "controller": controller is not None,
                   "convergence_tol": float(convergence_tol)})
    if spec is not None:
        inputs.update({"bridge": spec.name, "erected_fraction": spec.erected_fraction})
    if static is not None:  # keys only on the quasi-steady path (the thin-aerofoil's unchanged)
        c = static.on_width(2.0 * spec.deck.half_chord_m)
        inputs.update({"loads": loads, "lift_slope_buffeting": float(c["dC_L"]),
                       "moment_slope_buffeting": float(c["dC_M"]),
                       "turbulence_components": ["w", "u"] if extra else ["w"],
                       "self_excited_loads": "flutter derivatives" if getattr(
                           spec, "derivatives", None) is not None else "thin aerofoil",
                       **static.summary(2.0 * spec.deck.half_chord_m)})
    return BuffetingResult(
        speeds=u, strip_x=strip_x, main_span=main, rms_heave=heave, rms_pitch=pitch,
        rms_vertical=vmax, rms_torsion=tmax, deck_width_m=2.0 * gust.half_chord_m,
        status=tuple(status), convergence=conv, grid_points=grid_pts, spectral_abscissa=absc,
        method=method, inputs=inputs, standard_error_vertical=se_v, psd_omegas=tuple(psd_w),
        psd_vertical=tuple(psd_v), psd_torsion=tuple(psd_t),
        elapsed_s=time.perf_counter() - t0)


def _aero_attr(system, spec, name):
    if spec is not None:
        return float(getattr(spec.aero, name))
    return float("nan")


def _monte_carlo(A, B, C, strip_x, U, gust, main, ns, n_records, seed, n_points, omega_max):
    """One speed by :func:`bridgeflap.model.response.simulation.simulate_monte_carlo` with the full
    strip inputs."""
    lam = np.linalg.eigvals(A)
    p = C.shape[0]
    if np.max(lam.real) >= 0:
        return {"rms": np.full(p, np.nan), "se_vertical": np.nan, "points": 0,
                "rel_se": np.nan, "status": "unstable"}
    wd = np.abs(lam.imag)
    under = (lam.imag > 0) & (np.abs(lam.real) < lam.imag)
    wmax = OMEGA_MAX_FACTOR * float(wd.max()) if omega_max is None else float(omega_max)
    sigma_min = float(np.min(np.abs(lam.real[under]))) if np.any(under) else float(
        np.min(np.abs(lam.real)))
    if n_points is None:
        n_points = int(min(8000, np.ceil(wmax / (0.25 * sigma_min))))
    d_omega = wmax / n_points
    omegas = (np.arange(n_points) + 0.5) * d_omega
    dt = 0.5 * np.pi / wmax  # Nyquist at 2 omega_max: ZOH midpoint error O((omega dt)^2)
    duration = 2 * np.pi / d_omega
    s = gust.psd(omegas, U) * gust.admittance_sq(omegas, U)
    coh = exponential_coherence(strip_x, gust.coherence_decay, U)
    res = simulate_monte_carlo(A, B, C, omegas, s, coh, dt, duration, seed=seed,
                               n_records=n_records)
    j = int(np.argmax(np.where(main, res.rms[:ns], -np.inf)))
    return {"rms": res.rms, "se_vertical": float(res.standard_error[j]), "points": n_points,
            "rel_se": float(res.standard_error[j] / res.rms[j]), "status": res.status}
