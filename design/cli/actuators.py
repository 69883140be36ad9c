"""``bridgeflap actuators``: flap demand and saturation in turbulent wind.

``bridgeflap actuators --controller controller.toml [--speeds 10,20,25] [--near-critical 0.95]
[--duration-s 600] [--records 4] [--seed 0] [--modes 16] [--card FILE]
[--flap-angle-limit-deg 20] [--flap-rate-limit-deg-s 40] [--actuator-bandwidth-rad-s 10]
[--linear] [--out table.csv] [--json]`` simulates the controller's closed loop in Monte-Carlo
turbulence with the flap angle and rate limits (:mod:`bridgeflap.model.response.actuator_sim`) and
prints, per speed, RMS and peak flap angle and rate, the fraction of time at each limit, and the
deck RMS heave and twist beside the linear closed loop's spectral RMS. The limits come from the
design card's ``flap_angle_limit_deg`` / ``flap_rate_limit_deg_s`` (``--card``, default the built-in
card's values), overridden by the options; all are engineering estimates
(:mod:`bridgeflap.model.aeroelastic.actuator_limits`). Exit status 0 when every speed is ``ok``; 1
when a speed is at or above the closed-loop critical speed (``unstable``) or the saturated loop
diverged there (``diverged``: the limits cannot hold the bridge).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bridgeflap.design.cli.common import (
    add_common,
    controller_from_args,
    controller_report,
    emit,
    log,
)
from bridgeflap.model.aeroelastic.actuator_limits import ACTUATOR_DEFAULTS
from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["arguments", "cmd_actuators"]


def _limits(args):
    from bridgeflap.model.aeroelastic.actuator_limits import ActuatorLimits, check_actuator_value

    values = dict(ACTUATOR_DEFAULTS)
    source = "defaults (engineering estimates)"
    if args.card:
        from bridgeflap.design.control.settings import load_settings

        s = load_settings(args.card)
        values.update(flap_angle_limit_deg=s.flap_angle_limit_deg,
                      flap_rate_limit_deg_s=s.flap_rate_limit_deg_s)
        source = f"card {args.card}"
    for name in values:
        given = getattr(args, name)
        if given is not None:
            values[name] = check_actuator_value(name, given)
            source += f"; --{name.replace('_', '-')}"
    return ActuatorLimits(values["flap_angle_limit_deg"], values["flap_rate_limit_deg_s"],
                          values["actuator_bandwidth_rad_s"]), source


def cmd_actuators(args):
    """Run the saturated closed loop in turbulence and report it."""
    from bridgeflap.design.assessment.actuator_study import actuator_study
    from bridgeflap.design.cli.common import check_writable_parent, spec_from_args
    from bridgeflap.design.io.options import parse_range

    if not args.controller:
        raise BridgeflapInputError("controller", "a controller .toml is required")
    speeds = parse_range(args.speeds, "speeds")
    if np.any(speeds <= 0):
        raise BridgeflapInputError("speeds", "mean wind speeds must be > 0 [m/s]")
    if not (np.isfinite(args.duration_s) and 10.0 <= args.duration_s <= 1e5):
        raise BridgeflapInputError("duration-s", f"must be in [10, 1e5] s, got {args.duration_s}")
    if not (np.isfinite(args.near_critical) and 0.0 <= args.near_critical < 1.0):
        raise BridgeflapInputError("near-critical", f"must be in [0, 1), got {args.near_critical}")
    limits, source = _limits(args)
    if args.out:
        if not str(args.out).lower().endswith(".csv"):
            raise BridgeflapInputError("out", f"expected a .csv file, got {args.out}")
        check_writable_parent("out", Path(args.out))
    spec = spec_from_args(args)
    controller = controller_from_args(args, spec)
    res = actuator_study(spec, controller, speeds, limits, duration_s=args.duration_s,
                         seed=args.seed, records=args.records, n_modes=args.modes,
                         near_critical=args.near_critical, linear=args.linear, progress=log)
    s = {**res.summary(), "limits_from": source, **controller_report(controller)}
    if args.out:
        from bridgeflap.design.io.files import atomic_write_text

        atomic_write_text(args.out, res.csv_text())
        s["table"] = str(args.out)
    lines = [f"{spec.name}: {s['modes_retained']} modes, {s['flaps']} flaps, limits "
             f"{limits.angle_deg:g} deg / {limits.rate_deg_s:g} deg/s ({source}), "
             f"{s['records']} x {s['duration_s']:g} s records, seed {s['seed']}; closed-loop "
             f"critical speed {_g(s['closed_loop_critical_speed_m_s'], '.2f')}",
             f"{'U [m/s]':>8s} {'rms beta':>9s} {'peak':>7s} {'rms rate':>9s} {'peak':>7s} "
             f"{'sat ang':>8s} {'sat rate':>8s} {'rms z [m]':>10s} {'lin':>10s} "
             f"{'rms a [rad]':>11s} {'lin':>10s}  [deg, deg/s]"]
    for r in s["speeds"]:
        if r["status"] == "unstable":
            lines.append(f"{r['speed_m_s']:8.2f}  unstable (at or above the critical speed)")
            continue
        if r["status"] == "diverged":
            lines.append(f"{r['speed_m_s']:8.2f}  diverged after {r['diverged_after_s']:.0f} s "
                         f"in {r['diverged_records']} record(s): the limits cannot hold the "
                         f"loop (linear loop: rms beta {r['linear_rms_flap_angle_deg']:.2f} "
                         f"deg, rms rate {r['linear_rms_flap_rate_deg_s']:.2f} deg/s)")
            continue
        lines.append(
            f"{r['speed_m_s']:8.2f} {r['rms_flap_angle_deg']:9.3f} {r['peak_flap_angle_deg']:7.2f}"
            f" {r['rms_flap_rate_deg_s']:9.3f} {r['peak_flap_rate_deg_s']:7.2f}"
            f" {r['angle_saturated_fraction']:8.4f} {r['rate_saturated_fraction']:8.4f}"
            f" {r['rms_heave_m']:10.4e} {r['linear_rms_heave_m']:10.4e}"
            f" {r['rms_twist_rad']:11.4e} {r['linear_rms_twist_rad']:10.4e}")
    log(f"actuators: {len(s['speeds'])} speeds in {s['elapsed_s']:.1f} s")
    emit(args, s, "\n".join(lines))
    return 0 if s["status"] == "ok" else 1


def _g(value, spec):
    if value is None or not np.isfinite(value):
        return "not computed (--near-critical 0) or none below 200 m/s"
    return format(value, spec) + " m/s"


def arguments(sp) -> None:
    """The options of ``bridgeflap actuators``."""
    add_common(sp)
    sp.add_argument("--controller", default=None, help="controller .toml (its flap layout)")
    sp.add_argument("--speeds", default="10,20,25", help="list or start:stop:step [m/s]")
    sp.add_argument("--near-critical", type=float, default=0.95,
                    help="also this fraction of the closed-loop critical speed (0: not)")
    sp.add_argument("--duration-s", type=float, default=600.0,
                    help="analysed length of each record after the transient [s]")
    sp.add_argument("--records", type=int, default=4, help="Monte-Carlo records per speed")
    sp.add_argument("--seed", type=int, default=0, help="seed of the random phases")
    sp.add_argument("--modes", type=int, default=16, help="retained vertical+torsional modes")
    sp.add_argument("--card", default=None,
                    help="design card whose flap_angle_limit_deg / flap_rate_limit_deg_s to use")
    for name, unit in (("flap_angle_limit_deg", "deg"), ("flap_rate_limit_deg_s", "deg/s"),
                       ("actuator_bandwidth_rad_s", "rad/s")):
        sp.add_argument("--" + name.replace("_", "-"), type=float, default=None,
                        help=f"[{unit}] (default {ACTUATOR_DEFAULTS[name]:g}, an engineering "
                             "estimate; overrides --card)")
    sp.add_argument("--linear", action="store_true", help="ignore the limits (linear loop)")
    sp.add_argument("--out", default=None, help="per-speed table (.csv)")
