"""Model updating of the unsourced Humber deck stiffnesses to the measured frequencies.

Updates, one family at a time, EI_vertical (vertical modes), GJ (torsional modes) and
EI_lateral (lateral modes) to the paper's Table 1 (Brownjohn et al. 1994), all other inputs as in
the built-in file. The objective (bridgeflap.model.cases.validation.log_misfit) weights the
flutter-critical modes VS1 and TS1 (bridgeflap.model.cases.validation.CRITICAL_WEIGHT, default
infinity: fitted exactly, the other modes of the family validate); the lateral family is an
unweighted RMS fit. Masses, sag and geometry are not touched. Prints the updated values for
humber.toml and the resulting Table 1 comparison.

    python runs/model_updating/run.py [--json]
    python runs/model_updating/run.py --weights 1,10,inf [--json]

``--weights`` repeats the vertical and torsional updating for each critical-mode weight and
prints the updated EI and GJ, VS1 and TS1 and the open-loop flutter and divergence speeds of
`bridgeflap flutter` (30 modes, 0-85 m/s) that follow: how far the headline moves with the
weight (docs/methods.md#model-updating). The weight is chosen on modal grounds, not from this.
"""

import argparse
import json

from bridgeflap.model.cases.validation import compare_table1, update_stiffnesses
from bridgeflap.model.structure.loader import load_bridge
from bridgeflap.model.structure.modes import modal_model


def weight_table(weights):
    """One row per critical-mode weight: updated EI, GJ, VS1, TS1, flutter and divergence."""
    from bridgeflap.design.io.options import parse_range
    from bridgeflap.design.studies.analyses import DEFAULT_SPEEDS
    from bridgeflap.model.analysis import flutter

    rows = []
    for w in weights:
        spec, rep = update_stiffnesses(load_bridge("humber"), families=("vertical", "torsional"),
                                       critical_weight=w)
        mm = modal_model(spec)
        sw = flutter(spec, parse_range(DEFAULT_SPEEDS, "speeds", 0.0)).sweep
        rows.append({"critical_weight": "inf" if w == float("inf") else w,
                     "ei_vertical_nm2": rep["deck.ei_vertical_nm2"]["value"],
                     "gj_nm2": rep["deck.gj_nm2"]["value"],
                     "vs1_hz": mm.find("VS1").frequency_hz, "ts1_hz": mm.find("TS1").frequency_hz,
                     "flutter_speed_m_s": sw.flutter.speed, "flutter_status": sw.flutter.status,
                     "divergence_speed_m_s": sw.divergence.speed,
                     "divergence_status": sw.divergence.status,
                     "governs": min(
                         (v, k) for k, v in (("flutter", sw.flutter.speed),
                                             ("divergence", sw.divergence.speed))
                         if v is not None and v == v)[1]})
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--weights", help="comma-separated critical-mode weights, e.g. 1,10,inf")
    args = ap.parse_args()
    if args.weights:
        rows = weight_table([float(x) for x in args.weights.split(",")])
        if args.json:
            print(json.dumps({"weights": rows}, indent=1, allow_nan=False))
            return
        print("| weight | EI_v [N m2] | GJ [N m2] | VS1 [Hz] | TS1 [Hz] | flutter [m/s] | "
              "divergence [m/s] | governs |")
        print("|---|---|---|---|---|---|---|---|")
        for r in rows:
            print(f"| {r['critical_weight']} | {r['ei_vertical_nm2']:.4g} | {r['gj_nm2']:.4g} | "
                  f"{r['vs1_hz']:.4f} | {r['ts1_hz']:.4f} | {r['flutter_speed_m_s']:.2f} "
                  f"({r['flutter_status']}) | {r['divergence_speed_m_s']:.2f} "
                  f"({r['divergence_status']}) | {r['governs']} |")
        return
    spec, out = update_stiffnesses(load_bridge("humber"))
    rows = compare_table1(modal_model(spec))
    if args.json:
        print(json.dumps({"updated": out, "table1": rows}, indent=1))
        return
    for path, r in out.items():
        print(f"{path:28s} = {r['value']:.4g}  objective {r['rms_log_misfit']:.2e}  "
              f"rms log misfit (all modes) {r['rms_log_misfit_unweighted']:.4f}"
              f"  converged={r['success']} at_bound={r['at_bound']}")
    for r in rows:
        print(f"{r['family']:10s} {r['table1_label']:3s} exp {r['measured_hz']:.3f}  "
              f"seed {r['seed_model_hz']:.3f}  ours {r['bridgeflap_hz']:.3f} "
              f"({r['bridgeflap_label']:4s}) {r['difference_percent']:+6.1f} %  "
              f"{r['updating_role']}")


if __name__ == "__main__":
    main()
