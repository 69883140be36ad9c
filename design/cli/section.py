"""CLI command ``section``: the rigid 2-DOF deck section (listed in
:data:`bridgeflap.design.cli.main.COMMANDS`).

``bridgeflap section --mass M --inertia I --f-heave FH --f-torsion FT --half-chord B
[--aero exact|rfa4|jones|rfa4-band] [--json]`` -> flutter and divergence speeds [m/s] of the
section, with Selberg's estimate as a sanity check.
"""

from __future__ import annotations

import numpy as np

from bridgeflap.design.cli.common import add_common, emit, speed_text
from bridgeflap.design.io.options import parse_range
from bridgeflap.model.aero.rfa import RFA_NAMES
from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["arguments", "cmd_section"]


def cmd_section(args):
    from bridgeflap.model.aeroelastic import statespace
    from bridgeflap.model.cases.section import section_basis
    from bridgeflap.model.stability import sweeps as stability

    basis = section_basis(args.mass, args.inertia, args.f_heave, args.f_torsion, args.half_chord,
                          args.damping_ratio)
    if not (np.isfinite(args.air_density) and args.air_density > 0):
        raise BridgeflapInputError("air-density", "must be positive")
    speeds = _speeds_for_section(args)
    rfa = "rfa4" if args.aero == "exact" else args.aero
    system = statespace.build(basis, args.half_chord, args.air_density, rfa=rfa,
                              added_inertia=not args.no_added_inertia)
    sw = stability.sweep(system, speeds)
    out = sw.summary()
    if args.aero == "exact":
        pk = stability.pk_sweep(system, speeds)
        out.update(pk.summary())  # flutter speed, status, slope, onset and label of the p-k
        out["divergence_speed_m_s"] = out["divergence_static_speed_m_s"]  # null off the grid
        out["divergence_status"] = out["divergence_static_status"]
    out["aero"] = args.aero
    out["selberg_flutter_speed_m_s"] = _selberg(args)
    fhz = out.get("flutter_frequency_hz")
    text = (f"section ({args.aero}): flutter {speed_text(out['flutter_speed_m_s'], 3)} "
            f"[{out['flutter_status']}]"
            + (f" at {fhz:.4f} Hz" if fhz is not None and fhz == fhz else "")
            + f"; divergence {speed_text(out['divergence_speed_m_s'], 3)} "
            f"[{out['divergence_status']}]; "
            f"Selberg estimate {speed_text(out['selberg_flutter_speed_m_s'], 3)}")
    emit(args, out, text)


def _selberg(args) -> float:
    """Selberg's flutter formula (docs/humber_data.md#selberg-formula) as an
    engineer's sanity check."""
    b, m, inertia = args.half_chord, args.mass, args.inertia
    gamma = args.f_heave / args.f_torsion
    if gamma >= 1:
        return float("nan")
    nu = 2 * inertia / (m * b * b)
    mu = 2 * np.pi * args.air_density * b * b / m
    return float(0.44 * 2 * np.pi * args.f_torsion * 2 * b
                 * np.sqrt((1 - gamma ** 2) * np.sqrt(nu) / mu))


def _speeds_for_section(args):
    if args.speeds:
        return parse_range(args.speeds, "speeds", 0.0)
    # default grid: up to 3x Selberg's estimate or 20 b omega_theta, 400 points
    top = 20 * args.half_chord * 2 * np.pi * args.f_torsion
    return np.linspace(0.0, top, 801)


def arguments(sp):
    add_common(sp, bridge=False, erection=False)
    sp.add_argument("--mass", type=float, required=True, help="[kg/m]")
    sp.add_argument("--inertia", type=float, required=True, help="about mid-chord [kg m2/m]")
    sp.add_argument("--f-heave", type=float, required=True, help="[Hz]")
    sp.add_argument("--f-torsion", type=float, required=True, help="[Hz]")
    sp.add_argument("--half-chord", type=float, required=True, help="[m]")
    sp.add_argument("--air-density", type=float, default=1.225, help="[kg/m3]")
    sp.add_argument("--damping-ratio", type=float, default=0.0)
    sp.add_argument("--no-added-inertia", action="store_true")
    sp.add_argument("--aero", choices=("exact", *RFA_NAMES), default="rfa4")
    sp.add_argument("--speeds", default=None, help="start:stop:step [m/s]")
