"""Flap demand and saturation in turbulent wind: the driver of ``bridgeflap actuators``.

At each wind speed (and near the closed-loop critical speed) :func:`actuator_study` runs
``records`` Monte-Carlo records of the saturated closed loop
(:mod:`bridgeflap.model.response.actuator_sim`) and reports RMS and peak flap angle and rate, the
fraction of time at the angle and rate limits and the deck RMS heave and twist, with the linear
closed loop's spectral RMS beside them (:func:`bridgeflap.model.response.buffeting.reduced_response`
on the same state space, no limits). Conventions:
:mod:`bridgeflap.model`; angles in the JSON in degrees, the deck twist in radians as in
``buffeting``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from bridgeflap.model.aeroelastic.actuator_limits import ActuatorLimits
from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["ActuatorStudyResult", "actuator_study", "CRITICAL_SEARCH_SPEEDS"]

#: closed-loop critical-speed search grid [m/s] (the project's fast tracked sweep)
CRITICAL_SEARCH_SPEEDS = np.arange(0.0, 200.0 + 1e-9, 0.5)

#: columns of the CSV table (one row per speed), units in the names
COLUMNS = ("speed_m_s", "status", "rms_flap_angle_deg", "peak_flap_angle_deg",
           "rms_flap_rate_deg_s", "peak_flap_rate_deg_s", "angle_saturated_fraction",
           "rate_saturated_fraction", "rms_heave_m", "rms_twist_rad",
           "standard_error_heave_m", "standard_error_twist_rad",
           "linear_rms_flap_angle_deg", "linear_rms_flap_rate_deg_s",
           "linear_rms_heave_m", "linear_rms_twist_rad", "dt_s", "transient_s")


@dataclass(frozen=True)
class ActuatorStudyResult:
    """Per-speed rows (:data:`COLUMNS`) and the inputs that made them.

    Row ``status``: ``"ok"``; ``"unstable"`` (the linear closed loop is unstable: at or above
    the critical speed; no simulation); ``"diverged"`` (a record of the saturated loop passed
    :data:`bridgeflap.model.response.actuator_sim.DIVERGED_RESPONSE`: the limits cannot hold the
    bridge; no statistics, ``diverged_after_s`` the earliest). Overall: ``"ok"``, ``"diverged"`` or
    ``"unstable_speed"``.
    """

    rows: list
    inputs: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """The ``bridgeflap actuators`` JSON contract (NaN becomes null in the CLI)."""
        st = {r["status"] for r in self.rows}
        status = "diverged" if "diverged" in st else "unstable_speed" if "unstable" in st \
            else "ok"
        holds = None      # the speeds checked in order: the last one before a failure
        for r in sorted(self.rows, key=lambda r: r["speed_m_s"]):
            if r["status"] != "ok":
                break
            holds = float(r["speed_m_s"])
        return {**self.inputs, "status": status,
                # the saturated loop's verdict beside the linear closed-loop critical speed
                "saturated_loop_holds_to_m_s": holds,
                "saturated_loop_checked_speeds_m_s": sorted(float(r["speed_m_s"])
                                                            for r in self.rows),
                "speeds": list(self.rows)}

    def csv_text(self) -> str:
        """The rows as CSV (header: :data:`COLUMNS`)."""
        lines = [",".join(COLUMNS)]
        for r in self.rows:
            lines.append(",".join("" if r[c] is None or (isinstance(r[c], float)
                                                         and not np.isfinite(r[c]))
                                  else str(r[c]) for c in COLUMNS))
        return "\n".join(lines) + "\n"


def critical_speed(spec, controller, n_modes: int) -> float:
    """Closed-loop critical speed [m/s] on ``n_modes`` (NaN if none below 200 m/s)."""
    from bridgeflap.model.analysis import closed_loop_flutter

    s = closed_loop_flutter(spec, controller, CRITICAL_SEARCH_SPEEDS, n_modes=n_modes,
                            sweep_method="fast").summary()
    u = s.get("critical_speed_m_s")
    return float("nan") if u is None else float(u)


def _linear_reference(loop, A, U, gust, wa):
    """Spectral RMS of strips (heave, pitch), flap angles and flap rates, no limits."""
    from bridgeflap.model.response.buffeting import reduced_response

    F, G, Rc, D, Bp = loop.matrices(U, wa)
    iq, ip, _, ib, _ = loop.slices()
    B = np.zeros((loop.n_states, Bp.shape[1]))
    B[ip] = Bp
    ns2 = loop.C_strip.shape[0]
    C = np.zeros((ns2 + 2 * loop.nF, loop.n_states))
    C[:ns2, iq] = loop.C_strip
    C[ns2 + np.arange(loop.nF), ib.start + np.arange(loop.nF)] = 1.0
    C[ns2 + loop.nF:] = np.linalg.solve(np.eye(loop.nF) - D, Rc)
    r = reduced_response(A, B, C, loop.strip_x, U, gust)
    return r.rms[:ns2], r.rms[ns2:ns2 + loop.nF], r.rms[ns2 + loop.nF:], r.status


#: most seconds of records at one speed (``records x duration_s``): the records are integrated
#: side by side, so their gust samples are in memory at once (at the 25 ms step of Humber's
#: loop, 1e5 s on 16 strips are 0.5 GB per array; 1e9 s asked for 4.7 TiB before the bound)
MAX_RECORD_SECONDS = 1e5


def actuator_study(spec, controller, speeds, limits: ActuatorLimits | None = None, *,
                   duration_s: float = 600.0, seed: int = 0, records: int = 4,
                   n_modes: int = 16, near_critical: float = 0.95, linear: bool = False,
                   progress=None) -> ActuatorStudyResult:
    """Saturated closed loop in turbulent wind at ``speeds`` and ``near_critical`` x U_cr.

    Parameters
    ----------
    spec : BridgeSpec
        A thin-aerofoil bridge (the closed loop's gust loads are the paper's Eq. (8)).
    controller : bridgeflap.model.aeroelastic.control.Controller
    speeds : array_like
        Mean wind speeds [m/s], > 0.
    limits : ActuatorLimits, optional
        Angle [deg], rate [deg/s] and servo bandwidth [rad/s] (defaults: estimates).
    duration_s : float
        Analysed length of each record after the transient [s] (600 s: the 10-minute
        averaging period of wind engineering).
    seed : int
        Seed of the random phases (every speed and record its own stream from it).
    records : int
        Independent records per speed (>= 2 gives a standard error).
    n_modes : int
        Retained modes.
    near_critical : float
        Adds ``near_critical`` times the closed-loop critical speed (0: not).
    linear : bool
        Ignore the limits (the linear closed loop, same integrator).
    """
    from bridgeflap.model.aero.gust import gust_field
    from bridgeflap.model.aeroelastic.flaps import closed_loop_model
    from bridgeflap.model.response.actuator_sim import SaturatedLoop, simulate_records

    t0 = time.perf_counter()
    limits = ActuatorLimits() if limits is None else limits
    if getattr(spec, "derivatives", None) is not None:
        raise BridgeflapInputError("bridge", "the closed loop needs thin-aerofoil deck loads; "
                                   "this bridge's are flutter-derivative tables")
    u = np.atleast_1d(np.asarray(speeds, dtype=float))
    if u.size == 0 or not np.all(np.isfinite(u)) or np.any(u <= 0):
        raise BridgeflapInputError("speeds", "need finite mean wind speeds > 0 [m/s]")
    if not (np.isfinite(duration_s) and 10.0 <= duration_s <= 1e5):
        raise BridgeflapInputError("duration-s", f"must be in [10, 1e5] s, got {duration_s!r}")
    if int(records) * float(duration_s) > MAX_RECORD_SECONDS:
        raise BridgeflapInputError("records", f"{records} records of {duration_s:g} s are more "
                                   f"than {MAX_RECORD_SECONDS:g} s of turbulence at one speed "
                                   "(the records are integrated together, held in memory)")
    if not (np.isfinite(near_critical) and 0.0 <= near_critical < 1.0):
        raise BridgeflapInputError("near-critical", "must be in [0, 1) (a fraction of the "
                                   f"closed-loop critical speed), got {near_critical!r}")
    c = controller
    model = closed_loop_model(spec, c.flap_strip_positions_m, c.flap_width_m, int(n_modes),
                              c.chord_m, c.leading_edge, c.trailing_edge)
    loop = SaturatedLoop(model, c.compensator)
    u_cr = critical_speed(spec, controller, int(n_modes)) if near_critical > 0 else np.nan
    labels = ["speed"] * u.size
    if near_critical > 0 and np.isfinite(u_cr):
        u = np.append(u, round(near_critical * u_cr, 2))
        labels.append(f"{near_critical:g} x critical")
    gust = gust_field(spec)
    main = _main_span(spec, loop.strip_x)
    ns = loop.strip_x.size
    wa = limits.bandwidth_rad_s
    streams = np.random.SeedSequence(int(seed)).spawn(u.size)
    rows = []
    for i, U in enumerate(u):
        A = loop.linear_matrix(U, wa)
        row = {k: None for k in COLUMNS} | {"speed_m_s": float(U), "speed_label": labels[i]}
        if np.max(np.linalg.eigvals(A).real) >= 0:
            rows.append(row | {"status": "unstable"})
            continue
        lin_strip, lin_beta, lin_rate, lin_status = _linear_reference(loop, A, U, gust, wa)
        ms_s, ms_b, ms_r, pk_b, pk_r, f_a, f_r, lost = [], [], [], [], [], [], [], []
        if progress is not None:
            progress(f"actuators: U = {U:g} m/s, {records} records")
        recs = simulate_records(loop, U, gust, limits, duration_s,
                                [np.random.default_rng(s) for s in streams[i].spawn(records)],
                                linear=linear)
        for rec in recs:
            if rec.diverged_at_s is not None:
                lost.append(rec.diverged_at_s)
                continue
            ms_s.append(rec.strip_rms ** 2)
            ms_b.append(np.mean(rec.beta ** 2, axis=1))
            ms_r.append(np.mean(rec.rate ** 2, axis=1))
            pk_b.append(np.max(np.abs(rec.beta)))
            pk_r.append(np.max(np.abs(rec.rate)))
            f_a.append(np.mean(rec.angle_saturated, axis=1))
            f_r.append(np.mean(rec.rate_saturated, axis=1))
        if lost:  # limits the linear loop needs but does not get: no stationary statistics
            rows.append(row | {"status": "diverged", "diverged_records": len(lost),
                               "diverged_after_s": float(min(lost)),
                               "linear_rms_flap_angle_deg": float(np.rad2deg(lin_beta.max())),
                               "linear_rms_flap_rate_deg_s": float(np.rad2deg(lin_rate.max())),
                               "linear_rms_heave_m": float(np.max(lin_strip[:ns][main])),
                               "linear_rms_twist_rad": float(np.max(lin_strip[ns:][main]))})
            continue
        ms_s = np.array(ms_s)
        strip = np.sqrt(ms_s.mean(axis=0))
        jh = int(np.argmax(np.where(main, strip[:ns], -np.inf)))
        jt = int(np.argmax(np.where(main, strip[ns:], -np.inf)))
        se = _standard_error(ms_s[:, [jh, ns + jt]])
        deg = np.rad2deg
        row |= {
            "status": "ok", "linear_reference_status": lin_status,
            "rms_flap_angle_deg": float(deg(np.sqrt(np.mean(ms_b, axis=0)).max())),
            "peak_flap_angle_deg": float(deg(max(pk_b))),
            "rms_flap_rate_deg_s": float(deg(np.sqrt(np.mean(ms_r, axis=0)).max())),
            "peak_flap_rate_deg_s": float(deg(max(pk_r))),
            "angle_saturated_fraction": float(np.mean(f_a, axis=0).max()),
            "rate_saturated_fraction": float(np.mean(f_r, axis=0).max()),
            "rms_heave_m": float(strip[jh]), "rms_twist_rad": float(strip[ns + jt]),
            "standard_error_heave_m": se[0], "standard_error_twist_rad": se[1],
            "linear_rms_flap_angle_deg": float(deg(lin_beta.max())),
            "linear_rms_flap_rate_deg_s": float(deg(lin_rate.max())),
            "linear_rms_heave_m": float(np.max(lin_strip[:ns][main])),
            "linear_rms_twist_rad": float(np.max(lin_strip[ns:][main])),
            "dt_s": rec.dt, "transient_s": rec.transient,
        }
        rows.append(row)
    inputs = {"bridge": spec.name, "modes_retained": int(n_modes), "states": loop.n_states,
              "flaps": loop.nF, **limits.summary(), "linear": bool(linear),
              "duration_s": float(duration_s), "records": int(records), "seed": int(seed),
              "closed_loop_critical_speed_m_s": u_cr, "near_critical_fraction": near_critical,
              "gust": gust.summary(),
              "integrator": "RK4, fixed step (bridgeflap.model.response.actuator_sim)",
              "turbulence": "spectral representation, Davenport coherence "
              "(bridgeflap.model.aero.turbulence)",
              "flap_statistics": "largest over the flaps; saturated fraction: of the time",
              "deck_statistics": "largest strip RMS over the main span",
              "elapsed_s": time.perf_counter() - t0}
    return ActuatorStudyResult(rows, inputs)


def _main_span(spec, strip_x):
    from bridgeflap.model.response.buffeting import _main_span_mask

    return _main_span_mask(spec, strip_x)


def _standard_error(ms) -> list:
    """Standard error of ``sqrt(mean ms)`` from the record scatter (delta method)."""
    ms = np.asarray(ms, dtype=float)
    if ms.shape[0] < 2:
        return [None] * ms.shape[1]
    rms = np.sqrt(ms.mean(axis=0))
    se = ms.std(axis=0, ddof=1) / np.sqrt(ms.shape[0]) / (2.0 * rms)
    return [float(v) for v in se]
