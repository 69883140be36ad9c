"""Time-domain closed loop in turbulent wind with flap angle and rate limits.

Conventions: :mod:`bridgeflap.model` (SI units, radians inside; degrees only in the limits' names).

Actuator model
--------------
The linear closed loop of :mod:`bridgeflap.model.aeroelastic.flaps` imposes ``beta = K(s) alpha``
exactly, with ``beta'`` and ``beta''`` in the flap loads. A real actuator cannot follow it
everywhere: its angle is bounded (``|beta| <= beta_max``) and so is its rate (``|beta'| <= r_max``).
Here each flap is a rate-commanded servo tracking the compensator output ``beta_c = K alpha``::

    beta' = r = sat_rmax( beta_c' + omega_a (beta_c - beta) ),   held at 0 on the angle stop

(``beta_c'`` is the compensator's own derivative, feed-forward; ``omega_a`` the servo's
tracking bandwidth). Within the limits the tracking error ``e = beta_c - beta`` obeys
``e' = -omega_a e`` from ``e = 0``: the flap follows ``K alpha`` exactly and the simulation is
the linear closed loop of :func:`bridgeflap.model.aeroelastic.flaps.closed_loop_system` (the
spectral buffeting RMS of
:mod:`bridgeflap.model.response.buffeting` is its reference, tests/test_actuators.py). In saturation
the servo recovers with time constant ``1/omega_a``.

State and equations. The flap angle's second derivative enters the loads only through the
non-circulatory flap force ``H2 beta''`` (:mod:`bridgeflap.model.aeroelastic.assembly`); with the
momentum-like coordinate ``p = M_t q' - H2 beta'`` it disappears, so a flap rate with jumps (the
rate limit) needs no impulse::

    z = (q, p, lag states, beta, compensator states),   z' = F(U) z + G(U) beta' + B(U) w~

with ``q' = M_t^{-1} (p + H2 beta')`` and the lag states of the rational approximation
(:mod:`bridgeflap.model.aero.rfa`) driven by the deck and flap downwash as in the linear closed
loop. The compensator sees ``alpha_f`` at its flap; ``beta_c'`` contains ``Dc alpha_f'`` and so
``beta'`` itself (``r = c(z) + D beta'``, ``D = Dc Phi_a M_t^{-1} H2``, ``|D|`` ~1e-3 on Humber):
solved exactly when unsaturated, by fixed-point iteration through the saturation otherwise.

Integrator: classical fixed-step Runge-Kutta 4 on the nonlinear right-hand side (the
saturation is continuous, its derivative is not: RK4 is then first-order accurate at the
switching instants only), the gust input sampled at the half steps (no interpolation), the
angle clipped back onto its stop after each step. The step is at most ``RK4_STEP_FACTOR /
max|eig|`` of the linear closed loop and a quarter of the synthesis Nyquist period.

Turbulence: :func:`bridgeflap.model.aero.turbulence.span_turbulence` with the buffeting spectrum,
admittance and coherence of :func:`bridgeflap.model.aero.gust.gust_field` (the effective gust after
the admittance, as the buffeting module's own Monte-Carlo path does; the thin-aerofoil gust loads of
the closed loop are vertical, so only ``w`` is simulated).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bridgeflap.model.aeroelastic.actuator_limits import ActuatorLimits
from bridgeflap.model.aeroelastic.assembly import rfa_parts
from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["ActuatorLimits", "SaturatedLoop", "SimulationRecord", "simulate", "simulate_records"]

#: deck heave or twist magnitude [m or rad] at which a record counts as diverged: the saturated
#: loop has lost the stability the linear loop has (flaps at their limits, the bridge beyond
#: its open-loop critical speed); far beyond any structural meaning, so never a false alarm
DIVERGED_RESPONSE = 100.0
#: cap of the synthesis length in half steps (memory ~ 8 strips x this x 16 bytes)
MAX_SYNTHESIS_SAMPLES = 2 ** 21
#: largest RK4 step in units of 1 / max|eig| of the linear closed loop (stability limit 2.78)
RK4_STEP_FACTOR = 0.5


class SaturatedLoop:
    """The closed loop of a :class:`~bridgeflap.model.aeroelastic.flaps.ClosedLoopModel` with an
    actuator per flap.

    Parameters
    ----------
    model : bridgeflap.model.aeroelastic.flaps.ClosedLoopModel
    compensator : bridgeflap.model.aeroelastic.control.Compensator
    """

    def __init__(self, model, compensator):
        op = model.pieces()
        ol = model.open_loop
        self.model, self.compensator = model, compensator
        self.n, self.nF = op.n, op.n_flaps
        # flap drives as "compensator" states (beta, beta') with beta'' = 0: rfa_parts gives
        # every column but the H2 beta'' one, which the momentum coordinate removes
        act = (np.array([[0.0, 1.0], [0.0, 0.0]]), np.zeros((2, 1)), np.array([[1.0, 0.0]]), 0.0)
        self._parts = rfa_parts(op, ol.rfa, act)[:3]
        self.M = np.asarray(op.M, float)
        self.H2 = np.asarray(op.H[0], float)
        self.PhA = np.asarray(op.phi_a_flaps, float)
        self.P_gust = np.asarray(ol.aero.P_gust, float)
        self.n_lag = self._parts[0].shape[0] - 2 * self.n - 2 * self.nF
        Ac, Bc, Cc, Dc = (np.asarray(a, float) for a in compensator.state_space())
        self.comp = (Ac, Bc, Cc, float(Dc[0, 0]))
        self.C_strip = np.asarray(ol.C_out, float)[:, :self.n]
        self.strip_x = np.asarray(ol.basis.strip_x, float)

    # --------------------------------------------------------------------------- matrices
    @property
    def n_states(self) -> int:
        """``2 n + lags + nF + nc nF``."""
        return 2 * self.n + self.n_lag + self.nF + self.comp[0].shape[0] * self.nF

    def slices(self):
        """Index slices ``(q, p, lag, beta, compensator)`` of the state."""
        n, nl, nF = self.n, self.n_lag, self.nF
        b0 = 2 * n + nl
        return (slice(0, n), slice(n, 2 * n), slice(2 * n, b0), slice(b0, b0 + nF),
                slice(b0 + nF, self.n_states))

    def matrices(self, wind_speed: float, bandwidth: float):
        """``(F, G, Rc, D, Bp)`` at ``U``: ``z' = F z + G r + (rows p) Bp w``, ``r = sat(Rc z +
        D r)`` (module docstring); ``Bp = U P_gust`` (n, strips) on the ``p`` rows."""
        U = float(wind_speed)
        A0, A1, A2 = self._parts
        AX = A0 + U * A1 + U * U * A2  # on X = (q, v, lags, (beta_f, beta'_f) per flap)
        n, nF, nl = self.n, self.nF, self.n_lag
        Ac, Bc, Cc, Dc = self.comp
        iq, ip, il, ib, ic = self.slices()
        nz, nX = self.n_states, AX.shape[0]
        Minv = np.linalg.inv(self.M)
        # X = Tz z + Tb r
        Tz, Tb = np.zeros((nX, nz)), np.zeros((nX, nF))
        Tz[:n, iq] = np.eye(n)
        Tz[n:2 * n, ip] = Minv
        Tb[n:2 * n] = Minv @ self.H2
        Tz[2 * n:2 * n + nl, il] = np.eye(nl)
        ia = 2 * n + nl + 2 * np.arange(nF)
        Tz[ia, ib.start + np.arange(nF)] = 1.0
        Tb[ia + 1, np.arange(nF)] = 1.0
        F, G = np.zeros((nz, nz)), np.zeros((nz, nF))
        F[iq] = Tz[n:2 * n]
        G[iq] = Tb[n:2 * n]
        F[ip] = self.M @ (AX[n:2 * n] @ Tz)
        G[ip] = self.M @ (AX[n:2 * n] @ Tb)
        F[il] = AX[2 * n:2 * n + nl] @ Tz
        G[il] = AX[2 * n:2 * n + nl] @ Tb
        G[ib] = np.eye(nF)
        eye = np.eye(nF)
        Ak, Bk, Ck = np.kron(eye, Ac), np.kron(eye, Bc), np.kron(eye, Cc)
        F[ic, ic] = Ak
        F[ic, iq] = Bk @ self.PhA
        # r = beta_c' + w_a (beta_c - beta), beta_c = Ck xc + Dc alpha_f
        Rc = np.zeros((nF, nz))
        Rc[:, ic] = Ck @ Ak + bandwidth * Ck
        Rc[:, iq] = Ck @ Bk @ self.PhA + bandwidth * Dc * self.PhA
        Rc[:, ip] = Dc * self.PhA @ Minv
        Rc[:, ib] = -bandwidth * eye
        D = Dc * self.PhA @ Minv @ self.H2
        return F, G, Rc, D, U * self.P_gust

    def linear_matrix(self, wind_speed: float, bandwidth: float) -> np.ndarray:
        """The unsaturated closed loop ``F + G (I - D)^{-1} Rc``: the eigenvalues of
        :func:`bridgeflap.model.aeroelastic.flaps.closed_loop_system` plus ``-bandwidth`` once per
        flap."""
        F, G, Rc, D, _ = self.matrices(wind_speed, bandwidth)
        return F + G @ np.linalg.solve(np.eye(self.nF) - D, Rc)


@dataclass(frozen=True)
class SimulationRecord:
    """One record at one speed: time histories at the steps after the transient."""

    beta: np.ndarray          # (nF, n_t) flap angle [rad]
    rate: np.ndarray          # (nF, n_t) flap rate [rad/s]
    angle_saturated: np.ndarray   # (nF, n_t) bool
    rate_saturated: np.ndarray    # (nF, n_t) bool
    strip_rms: np.ndarray     # (2 ns,) heave [m] then pitch [rad] RMS
    dt: float
    transient: float
    diverged_at_s: float | None = None   # the saturated loop lost stability (no statistics)


def _rhs(z, fp, FR, G, D, IDinv, rmax, amax, ib, ip, nz):
    """``(z', r, r_cmd)`` for the records in the columns of ``z``; ``FR = [F; Rc]`` stacked
    (one product for both), ``fp`` the gust forces on the ``p`` rows."""
    fc = FR @ z
    c = fc[nz:]
    # one fixed-point step: exact when unsaturated (IDinv = I + D IDinv), O(|D|^2) otherwise
    r = np.minimum(np.maximum(c + D @ np.minimum(np.maximum(IDinv @ c, -rmax), rmax), -rmax),
                   rmax)
    beta = z[ib]
    r[((beta >= amax) & (r > 0)) | ((beta <= -amax) & (r < 0))] = 0.0
    dz = fc[:nz] + G @ r
    dz[ip] += fp
    return dz, r, c + D @ r


def simulate(loop: SaturatedLoop, wind_speed, gust, limits: ActuatorLimits, duration_s,
             seed=None, *, dt=None, transient_s=None, linear=False, omega_max=None):
    """One Monte-Carlo record of the saturated closed loop (:func:`simulate_records`)."""
    out = simulate_records(loop, wind_speed, gust, limits, duration_s, [seed], dt=dt,
                           transient_s=transient_s, linear=linear, omega_max=omega_max)
    return None if out is None else out[0]


def simulate_records(loop: SaturatedLoop, wind_speed, gust, limits: ActuatorLimits, duration_s,
                     seeds, *, dt=None, transient_s=None, linear=False, omega_max=None):
    """Monte-Carlo records of the saturated closed loop at ``wind_speed``, side by side.

    Parameters
    ----------
    loop : SaturatedLoop
    wind_speed : float
        ``U`` [m/s].
    gust : bridgeflap.model.aero.gust.GustField
        Spectrum, admittance and coherence (:func:`bridgeflap.model.aero.gust.gust_field`).
    limits : ActuatorLimits
    duration_s : float
        Analysed length after the transient [s].
    seeds : sequence of (int, numpy.random.Generator or None)
        One per record (the records are integrated together, one matrix product per stage).
    dt : float, optional
        Step [s] (default: the RK4 and synthesis limits of the module docstring).
    transient_s : float, optional
        Discarded start-up [s]; default ``min(8 / min|Re eig|, duration_s)``.
    linear : bool, optional
        Ignore the limits (the linear closed loop, same integrator).
    omega_max : float, optional
        Highest synthesised gust frequency [rad/s]; default 3 x the highest damped frequency.

    Returns
    -------
    list of SimulationRecord, or ``None`` when the linear closed loop is unstable at ``U``. A
    record whose deck response passes :data:`DIVERGED_RESPONSE` stops there
    (``diverged_at_s``, no statistics).
    """
    from bridgeflap.model.aero.turbulence import span_turbulence

    U = float(wind_speed)
    wa = limits.bandwidth_rad_s
    F, G, Rc, D, Bp = loop.matrices(U, wa)
    IDinv = np.linalg.inv(np.eye(loop.nF) - D)
    lam = np.linalg.eigvals(F + G @ IDinv @ Rc)
    if np.max(lam.real) >= 0:
        return None
    if omega_max is None:
        omega_max = 3.0 * float(np.max(np.abs(lam.imag)))
    h_max = min(RK4_STEP_FACTOR / float(np.max(np.abs(lam))), 0.25 * np.pi / omega_max)
    h = h_max if dt is None else float(dt)
    if h > 2.0 * h_max:
        raise BridgeflapInputError("dt", f"{h:g} s is above the stable RK4 step {2 * h_max:g} s")
    if transient_s is None:
        transient_s = min(8.0 / float(np.min(np.abs(lam.real))), float(duration_s))
    n_skip, n_keep = int(np.ceil(transient_s / h)), int(round(float(duration_s) / h))
    n_steps = n_skip + n_keep
    # gust forces at the half steps; the synthesis period resolves the narrowest resonance
    # (frequency spacing <= a quarter of the smallest half-power half-bandwidth, as
    # model.response.buffeting's Monte Carlo), the record is a window of it
    under = (lam.imag > 0) & (np.abs(lam.real) < lam.imag)
    sigma = float(np.min(np.abs(lam.real[under]))) if np.any(under) else float(
        np.min(np.abs(lam.real)))
    n_syn = int(min(max(2 * n_steps + 1, np.ceil(8.0 * np.pi / sigma / (0.5 * h))),
                    MAX_SYNTHESIS_SAMPLES))
    n_syn = max(n_syn, 2 * n_steps + 1)
    g = lambda w: gust.psd(w, U) * gust.admittance_sq(w, U)  # noqa: E731
    n, nF, nz, R = loop.n, loop.nF, loop.n_states, len(seeds)
    iq, ip, _, ib, _ = loop.slices()
    force = np.empty((2 * n_steps + 1, n, R))
    for j, seed in enumerate(seeds):
        force[:, :, j] = span_turbulence(
            loop.strip_x, g, U, gust.coherence_decay, n_syn, 0.5 * h,
            min(omega_max, 0.9 * np.pi / (0.5 * h)), seed, n_keep=2 * n_steps + 1,
            project=Bp).T
    amax = np.deg2rad(limits.angle_deg)
    rmax = np.deg2rad(limits.rate_deg_s)
    if linear:
        amax = rmax = np.inf
    z = np.zeros((nz, R))
    beta = np.empty((n_keep, nF, R))
    rate = np.empty((n_keep, nF, R))
    rsat = np.empty((n_keep, nF, R), dtype=bool)
    q = np.empty((n_keep, n, R))
    lost = np.full(R, np.nan)
    args = (np.vstack([F, Rc]), G, D, IDinv, rmax, amax, ib, ip, nz)
    for k in range(n_steps):
        f0, f1, f2 = force[2 * k], force[2 * k + 1], force[2 * k + 2]
        k1, r, rcmd = _rhs(z, f0, *args)
        if k >= n_skip:
            j = k - n_skip
            beta[j], rate[j], q[j] = z[ib], r, z[iq]
            rsat[j] = np.abs(rcmd) > rmax
        k2 = _rhs(z + 0.5 * h * k1, f1, *args)[0]
        k3 = _rhs(z + 0.5 * h * k2, f1, *args)[0]
        k4 = _rhs(z + h * k3, f2, *args)[0]
        z = z + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        if not linear:
            z[ib] = np.minimum(np.maximum(z[ib], -amax), amax)
        if k % 50 == 0:  # a record whose saturated loop lost stability: stopped, said so
            big = ~(np.max(np.abs(loop.C_strip @ z[iq]), axis=0) < DIVERGED_RESPONSE)
            new = big & np.isnan(lost)
            lost[new] = k * h
            z[:, big] = 0.0
            if np.all(np.isfinite(lost)):
                break
    out = []
    for j in range(R):
        if np.isfinite(lost[j]):
            out.append(SimulationRecord(
                beta=np.zeros((nF, 0)), rate=np.zeros((nF, 0)),
                angle_saturated=np.zeros((nF, 0), bool), rate_saturated=np.zeros((nF, 0), bool),
                strip_rms=np.full(loop.C_strip.shape[0], np.nan), dt=h, transient=n_skip * h,
                diverged_at_s=float(lost[j])))
            continue
        y = loop.C_strip @ q[:, :, j].T
        b = beta[:, :, j].T
        out.append(SimulationRecord(beta=b, rate=rate[:, :, j].T,
                                    angle_saturated=np.abs(b) >= amax * (1.0 - 1e-9),
                                    rate_saturated=rsat[:, :, j].T,
                                    strip_rms=np.sqrt(np.mean(y * y, axis=1)), dt=h,
                                    transient=n_skip * h))
    return out
