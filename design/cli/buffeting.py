"""``bridgeflap buffeting``: RMS deck response to vertical turbulence (the paper, §5, Fig. 4).

Prints one JSON object with ``--json`` (keys: ``speeds_m_s``, ``rms_vertical_m``,
``rms_torsion_rad``, ``rms_vertical_over_width``, ``status`` and the grid convergence and
inputs; maxima along the main span; NaN as null). Bad input gives one line on stderr and exit 2
with nothing written, including speeds at or beyond flutter unless ``--allow-unstable``.
"""

from __future__ import annotations

import numpy as np

from bridgeflap.design.cli.common import (
    add_common,
    check_plot_target,
    controller_from_args,
    controller_report,
    emit,
    log,
    save_plot,
    spec_from_args,
)
from bridgeflap.design.io.options import parse_range
from bridgeflap.design.studies.analyses import ANALYSES
from bridgeflap.model.aero.wind import ADMITTANCE_KINDS, SPECTRUM_KINDS
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.response.buffeting_inputs import LOADS

__all__ = ["arguments", "cmd_buffeting"]


def cmd_buffeting(args):
    """Run the buffeting analysis of a bridge over a speed grid."""
    from bridgeflap.model.response.buffeting import buffeting

    check_plot_target(args)
    speeds = parse_range(args.speeds, "speeds")
    if np.any(speeds <= 0):
        raise BridgeflapInputError("speeds", "mean wind speeds must be > 0 [m/s]")
    if args.turbulence_intensity is not None and not (
            np.isfinite(args.turbulence_intensity) and args.turbulence_intensity > 0):
        raise BridgeflapInputError("turbulence-intensity",
                                   f"must be > 0, got {args.turbulence_intensity}")
    if args.coherence_decay is not None and not (
            np.isfinite(args.coherence_decay) and args.coherence_decay >= 0):
        raise BridgeflapInputError("coherence-decay", f"must be >= 0, got {args.coherence_decay}")
    if args.modes < 1:
        raise BridgeflapInputError("modes", f"must be at least 1, got {args.modes}")
    spec = spec_from_args(args)
    controller = controller_from_args(args, spec)
    res = buffeting(spec, speeds, spectrum=args.spectrum, admittance=args.admittance,
                    coherence_decay=args.coherence_decay, n_modes=args.modes,
                    method=args.method, turbulence_intensity=args.turbulence_intensity,
                    controller=controller, allow_unstable=args.allow_unstable,
                    mc_records=args.records, mc_seed=args.seed, loads=args.loads)
    s = res.summary()
    s.update({"bridge": spec.name, "erected_fraction": spec.erected_fraction,
              "modes_retained": args.modes, **controller_report(controller)})
    inp = s["inputs"]
    lines = [f"{spec.name} (erected {spec.erected_fraction:.2f}, {args.modes} modes): "
             f"{inp['spectrum']} spectrum, sigma_w/U = {inp['turbulence_intensity']:g}, "
             f"{inp['admittance']} admittance, c = {inp['coherence_decay']:g}, "
             f"C_L' = {inp['lift_slope_buffeting']:g}, C_M' = {inp['moment_slope_buffeting']:.4g}, "
             f"method {res.method}",
             f"{'U [m/s]':>8s} {'max sz [m]':>11s} {'sz/2b':>10s} {'max sa [rad]':>12s} "
             f"{'conv':>9s}  status"]
    for i, u in enumerate(res.speeds):
        lines.append(f"{u:8.2f} {res.rms_vertical[i]:11.4e} {res.rms_vertical_over_width[i]:10.3e}"
                     f" {res.rms_torsion[i]:12.4e} {res.convergence[i]:9.2e}  {res.status[i]}")
    if args.plot:
        save_plot(res, args.plot)
    log(f"buffeting: {res.speeds.size} speeds in {res.elapsed_s:.2f} s")
    emit(args, s, "\n".join(lines))


def arguments(sp) -> None:
    """The options of ``bridgeflap buffeting`` (grid and modes defaults: the registry's)."""
    defaults = ANALYSES["buffeting"].defaults
    add_common(sp)
    sp.add_argument("--speeds", default=defaults["speeds"], help="start:stop:step or list [m/s]")
    sp.add_argument("--spectrum", choices=SPECTRUM_KINDS, default="busch-panofsky")
    sp.add_argument("--admittance", choices=ADMITTANCE_KINDS, default=None,
                    help="aerodynamic admittance of every gust component (default: liepmann "
                         "for thin-aerofoil loads, unit for quasi-steady loads)")
    sp.add_argument("--loads", choices=LOADS, default=None,
                    help="gust loads: thin-aerofoil (w only, the paper's Eq. 8; the default) or "
                         "quasi-steady from the bridge's [static_coefficients] (u and w; the "
                         "default and only choice on a flutter-derivative bridge)")
    sp.add_argument("--coherence-decay", type=float, default=None,
                    help="Davenport decay c [-] (default: the bridge file's, an estimate)")
    sp.add_argument("--turbulence-intensity", type=float, default=None,
                    help="sigma_w/U [-] (default: the bridge file's, 0.07 for Humber)")
    sp.add_argument("--controller", default=None, help="controller .toml (closed loop)")
    sp.add_argument("--method", choices=("spectral", "monte-carlo"), default="spectral")
    sp.add_argument("--records", type=int, default=16, help="Monte-Carlo records")
    sp.add_argument("--seed", type=int, default=0, help="Monte-Carlo random seed")
    sp.add_argument("--modes", type=int, default=defaults["modes"],
                    help="retained vertical+torsional modes")
    sp.add_argument("--allow-unstable", action="store_true",
                    help="report speeds at/after flutter as NaN with status 'unstable'")
    sp.add_argument("--plot", default=None, help="Fig. 4 style figure (.png/.pdf/.svg)")
