"""Where the Humber headline numbers move with each correction of the built-in inputs.

For each combination of the deck mass/inertia reading (the first version's steel-only 7,660 kg/m
with m r^2 = 3.75e5 kg m^2/m, or the lumped section of humber.toml) and the half-chord reading
(the box 11 m, the overall width 14.25 m, the flap-deck-flap 14 m), the unsourced stiffnesses
(EI vertical, GJ) are re-updated to Table 1 (model updating, as for the built-in file) and
flutter and divergence are computed on the default grid. The cable mass along the cable and the
Hessle cable area are in every row (they are code, not inputs). No row is tuned.

    python runs/humber_inputs/run.py [--json]
"""

import argparse
import json

from bridgeflap.design.io.files import to_jsonable
from bridgeflap.design.io.options import parse_range
from bridgeflap.design.studies.analyses import DEFAULT_SPEEDS
from bridgeflap.model.analysis import flutter
from bridgeflap.model.cases.validation import update_stiffnesses
from bridgeflap.model.structure.loader import load_bridge

FIRST_VERSION_MASS = {"deck.mass_kg_per_m": 7660.0, "deck.mass_inertia_kgm2_per_m": 3.75e5}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    base = load_bridge("humber")
    lumped = {"deck.mass_kg_per_m": base.deck.mass_kg_per_m,
              "deck.mass_inertia_kgm2_per_m": base.deck.mass_inertia_kgm2_per_m}
    rows = []
    for mass_name, mass in (("steel only, m r^2", FIRST_VERSION_MASS),
                            ("lumped section", lumped)):
        for b in (11.0, 14.0, 14.25):
            spec, rep = update_stiffnesses(base.replace(**mass, **{"deck.half_chord_m": b}),
                                           families=("vertical", "torsional"))
            sw = flutter(spec, parse_range(DEFAULT_SPEEDS, "speeds", 0.0)).sweep
            rows.append({
                "mass_reading": mass_name, "half_chord_m": b,
                "deck_mass_kg_per_m": mass["deck.mass_kg_per_m"],
                "inertia_kgm2_per_m": mass["deck.mass_inertia_kgm2_per_m"],
                "ei_vertical_nm2": rep["deck.ei_vertical_nm2"]["value"],
                "gj_nm2": rep["deck.gj_nm2"]["value"],
                "flutter_speed_m_s": sw.flutter.speed, "flutter_status": sw.flutter.status,
                "divergence_speed_m_s": sw.divergence.speed,
                "divergence_status": sw.divergence.status,
                "critical_branch": sw.critical_branch})
    if args.json:
        print(json.dumps(to_jsonable({"rows": rows}), indent=1, allow_nan=False))
        return
    print("| deck mass / inertia | b [m] | EI_v [N m2] | GJ [N m2] | flutter [m/s] | "
          "divergence [m/s] | branch |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        def speed(v, status):
            return f"{v:.2f}" if status == "converged" else status
        print(f"| {r['mass_reading']} ({r['deck_mass_kg_per_m']:.0f} kg/m, "
              f"{r['inertia_kgm2_per_m']:.3g}) | {r['half_chord_m']} | "
              f"{r['ei_vertical_nm2']:.4g} | {r['gj_nm2']:.4g} | "
              f"{speed(r['flutter_speed_m_s'], r['flutter_status'])} | "
              f"{speed(r['divergence_speed_m_s'], r['divergence_status'])} | "
              f"{r['critical_branch']} |")


if __name__ == "__main__":
    main()
