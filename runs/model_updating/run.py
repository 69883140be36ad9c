"""Model updating of the unsourced Humber deck stiffnesses to the measured frequencies.

Updates, one family at a time, EI_vertical (vertical modes), GJ (torsional modes) and
EI_lateral (lateral modes) so that the RMS log-misfit to seed Table 1 (Brownjohn et al. 1994)
is smallest, all other inputs as in the built-in file. Masses, sag and geometry are not
touched. Prints the updated values for humber.toml and the resulting Table 1 comparison.

    python runs/model_updating/run.py [--json]
"""

import argparse
import json

from model.modes import modal_model
from model.spec import load_bridge
from model.validation import compare_table1, update_stiffnesses


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    spec, out = update_stiffnesses(load_bridge("humber"))
    rows = compare_table1(modal_model(spec))
    if args.json:
        print(json.dumps({"updated": out, "table1": rows}, indent=1))
        return
    for path, r in out.items():
        print(f"{path:28s} = {r['value']:.4g}  rms log misfit {r['rms_log_misfit']:.4f}"
              f"  converged={r['success']} at_bound={r['at_bound']}")
    for r in rows:
        print(f"{r['family']:10s} {r['table1_label']:3s} exp {r['measured_hz']:.3f}  "
              f"seed {r['seed_model_hz']:.3f}  ours {r['bridgeflap_hz']:.3f} "
              f"({r['bridgeflap_label']:4s}) {r['difference_percent']:+6.1f} %")


if __name__ == "__main__":
    main()
