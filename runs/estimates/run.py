"""How much do the headline results depend on the estimated (unsourced) Humber inputs?

One-at-a-time: each estimated input of model/bridges/humber.toml is moved to the ends of a
defensible range (stated below with its reasoning) and flutter/divergence are recomputed with
everything else at nominal. For the deck inertia and the cable spacing, which set the measured
torsional frequencies together with GJ, a second row re-updates GJ to the measured torsional
frequencies (as runs/model_updating does), because the measured frequencies are data and would
be matched again in practice.

    python runs/estimates/run.py [--quick] [--json]
"""

import argparse
import json
import sys

import numpy as np
from scipy.optimize import minimize_scalar

from bridgeflap.design.io.options import parse_range
from bridgeflap.model.analysis import flutter, modal_model
from bridgeflap.model.cases.validation import log_misfit
from bridgeflap.model.structure.loader import load_bridge
from bridgeflap.model.structure.spec import get_path

RANGES = {
    # path: (low, high, reasoning)
    "deck.half_chord_m": (11.0, 14.25, "22 m box vs 28.5 m overall width"),
    "cable.main_sag_m": (110.0, 125.0, "docs/humber_data.md#cables derived range"),
    "deck.mass_inertia_kgm2_per_m": (5.1e5, 6.9e5, "lumped section 5.99e5 +-15 %"),
    "cable.spacing_m": (20.0, 24.0, "box width 22 m +- 2 m"),
    "cable.modulus_pa": (1.9e11, 2.05e11, "parallel-wire cables 190-205 GPa"),
    "deck.mass_kg_per_m": (9400.0, 11500.0, "lumped 10,445 kg/m: 16,500-17,360 t of steel, "
                           "surfacing 30-45 mm, non-structural items +-30 %"),
    "deck.hanger_length_midspan_m": (2.0, 4.0, "short mid-span hangers"),
}


def gj_updated(spec):
    def cost(x):
        return log_misfit(modal_model(spec.replace(**{"deck.gj_nm2": 10 ** x})), "torsional")

    res = minimize_scalar(cost, bounds=(10.0, 13.0), method="bounded", options={"xatol": 1e-4})
    return spec.replace(**{"deck.gj_nm2": 10 ** res.x})


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    speeds = parse_range("0:100:1.0" if args.quick else "0:110:0.5", "speeds", 0.0)
    base = load_bridge("humber")
    if args.quick:
        base = base.replace(**{"mesh.element_length_m": 47.0})
    nominal = flutter(base, speeds).summary()
    rows = [{"parameter": "nominal", "value": None,
             "flutter_speed_m_s": nominal["flutter_speed_m_s"],
             "divergence_speed_m_s": nominal["divergence_speed_m_s"],
             "flutter_status": nominal["flutter_status"],
             "divergence_status": nominal["divergence_status"], "note": ""}]
    items = list(RANGES.items())[:2] if args.quick else list(RANGES.items())
    for path, (lo, hi, why) in items:
        for v in (lo, hi):
            if np.isclose(v, get_path(base, path)):
                continue
            variants = [("", base.replace(**{path: v}))]
            if path in ("deck.mass_inertia_kgm2_per_m", "cable.spacing_m") and not args.quick:
                variants.append(("GJ re-updated to measured torsion",
                                 gj_updated(base.replace(**{path: v}))))
            for note, spec in variants:
                s = flutter(spec, speeds).summary()
                rows.append({"parameter": path, "value": v, "range_reason": why, "note": note,
                             "flutter_speed_m_s": s["flutter_speed_m_s"],
                             "flutter_status": s["flutter_status"],
                             "divergence_speed_m_s": s["divergence_speed_m_s"],
                             "divergence_status": s["divergence_status"]})
                print(f"{path} = {v:g} {note}: flutter {s['flutter_speed_m_s']:.2f} m/s, "
                      f"divergence {s['divergence_speed_m_s']:.2f} m/s", file=sys.stderr)
    if args.json:
        print(json.dumps({"rows": rows}, default=lambda o: None))
        return
    print("| input | value | flutter [m/s] | divergence [m/s] | note |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['parameter']} | {r['value'] if r['value'] is not None else ''} | "
              f"{r['flutter_speed_m_s']:.2f} | {r['divergence_speed_m_s']:.2f} | {r['note']} |")


if __name__ == "__main__":
    main()
