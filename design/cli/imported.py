"""``bridgeflap modes`` on an imported modal model (docs/modal_import.md).

The file's modes (label, family, frequency, damping ratio, generalised mass with its unit:
kg for a shape in metres, kg m^2 for one in radians), without the cable statics of the FE path.
"""

from __future__ import annotations

from bridgeflap.design.cli.common import emit, save_plot

__all__ = ["imported_modes"]


def imported_modes(args, spec, modal, modes):
    """``modes`` of an imported modal model: the file's modes with their generalised masses."""
    gm = modal.structure.spec.structure.data.generalised_mass
    for m, j in zip(modes, modal.order, strict=False):
        m["generalised_mass"] = float(gm[j])
        m["generalised_mass_unit"] = "kg m^2" if m["family"] == "torsional" else "kg"
    lines = [f"{spec.name}: imported modal model ({len(modes)} modes)",
             f"{'mode':8s} {'family':10s} {'f [Hz]':>8s} {'zeta [%]':>8s} {'gen. mass':>10s}"]
    lines += [f"{m['label']:8s} {m['family']:10s} {m['frequency_hz']:8.4f} "
              f"{100 * m['damping_ratio']:8.3f} {m['generalised_mass']:10.4g} "
              f"{m['generalised_mass_unit']}" for m in modes]
    if args.plot:
        save_plot(modal, args.plot)
    emit(args, {"bridge": spec.name, "structure": "modal", "modes": modes}, "\n".join(lines))
