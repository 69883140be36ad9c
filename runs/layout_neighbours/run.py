"""The default design's flap layout against its neighbouring integer layouts.

The default card (``runs/humber_flaps.toml``) places its flaps by rounding relaxed weights
at 0.5 and re-optimises K(s) on the rounded layout. This script re-optimises and verifies
K(s) on every layout one mirror pair away from it (added or removed) and on the centred
contiguous blocks of about the same size
(:func:`bridgeflap.design.control.search.layout_search.compare_layouts`, the same fixed-layout
machinery as the design), every layout from the same start, and prints the table ranked by the dense
robust margin among verified layouts, with the gap of the best neighbour to the rounded layout.

The layout and start default to the default design as recorded in the README (18 flap pairs
at +-225.6..+-676.8 m, K = (-1.0520 s^2 + 0.7242 s - 4.9907)/(0.2457 s^2 + 0.1963 s + 1));
``--from-json`` takes them from a ``bridgeflap optimise`` result (``result.json``: its
``coefficients`` and ``flap_positions_m``; the relaxed weights of the chosen start when
present). The rounded layout is re-solved from that K like its neighbours.

    python runs/layout_neighbours/run.py [--quick] [--from-json result.json] [--out DIR]

``--quick`` (or ``BRIDGEFLAP_QUICK=1``): a small model (humber:box, 6 modes, 3 candidates,
short solves; CI) whose layout comes from one placement start of that model. Writes
``manifest.json``, ``layout_neighbours.json`` and ``layout_neighbours.csv`` to ``--out``.
"""

import argparse
import csv
import io
import json
import os
import sys
from pathlib import Path

from bridgeflap.design.control.search.layout_search import compare_layouts
from bridgeflap.design.control.settings import load_settings
from bridgeflap.design.io.files import atomic_write_json, atomic_write_text, ensure_writable_dir
from bridgeflap.design.io.manifest import build_manifest

DEFINITION = Path(__file__).resolve().parents[1] / "humber_flaps.toml"
#: The default design as recorded in the README: K (b2, b1, b0, a2, a1) and layout.
DEFAULT_THETA = (-1.0520, 0.7242, -4.9907, 0.2457, 0.1963)
DEFAULT_POSITIONS_M = tuple(s * 56.4 * k for k in range(4, 13) for s in (-1, 1))
#: The quick model (numerics only: the code paths of the full run, small matrices). The
#: re-optimisation of each layout gets 80 Ipopt iterations: with 20, the rounded layout ended
#: at Maximum_Iterations_Exceeded (not verified) on an AMD EPYC (OpenBLAS SkylakeX kernel),
#: though it had verified on the machines before; with 80 it ends Solve_Succeeded there.
QUICK = {"bridge": "humber:box", "n_modes": 6, "verification_modes": 6, "flap_count": 3,
         "flap_positions_m": (),
         "robust_design_speeds_m_s": (30.0, 60.0), "n_robust_omega": 8,
         "design_step_m_s": 10.0, "cutting_plane_rounds": 1, "placement_cut_rounds": 0,
         "max_iter": 20, "resolve_max_iter": 80, "robust_speeds_m_s": (30.0, 60.0),
         "check_step_m_s": 1.0, "starts": 1, "parallel": False}
CSV_KEYS = ("rank", "kind", "flap_count", "changed_radius_m", "weight_relaxed", "status",
            "verified", "robust_margin", "gap_to_rounded_pct", "stable_to_m_s",
            "verification_stable_to_m_s", "max_gain", "nlp_objective", "iterations", "time_s")


def main(argv=None) -> int:
    """Run the comparison; 0 when the rounded layout verified (its neighbours are rows
    whatever their status), 1 otherwise."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small model (or BRIDGEFLAP_QUICK=1)")
    ap.add_argument("--from-json", help="a bridgeflap optimise result.json (K and layout)")
    ap.add_argument("--blocks", type=int, default=1,
                    help="centred blocks of g-B..g+B groups (-1: none)")
    ap.add_argument("--out", default=str(Path(__file__).parent / "output"))
    args = ap.parse_args(argv)
    quick = args.quick or os.environ.get("BRIDGEFLAP_QUICK", "") not in ("", "0")
    settings = load_settings(DEFINITION, **(QUICK if quick else {"parallel": False}))
    weights, theta, positions, source = None, DEFAULT_THETA, DEFAULT_POSITIONS_M, "README"
    if quick:
        from bridgeflap.design.control.search.driver import NOMINAL_START, run_start

        rec = run_start(settings, NOMINAL_START, 0)
        theta, positions, weights = rec.theta, rec.flap_positions_m, rec.weights_continuous
        source = "quick placement start"
    elif args.from_json:
        res = json.loads(Path(args.from_json).read_text(encoding="utf-8"))
        theta = tuple(res["coefficients"][k] for k in ("b2", "b1", "b0", "a2", "a1"))
        positions = tuple(res["flap_positions_m"])
        chosen = [s for s in res.get("starts", []) if s.get("start") == res.get("chosen_start")]
        weights = chosen[0].get("weights_continuous") if chosen else None
        source = str(args.from_json)
    out = ensure_writable_dir(args.out)
    atomic_write_json(out / "manifest.json", build_manifest(
        {"quick": quick, "definition": str(DEFINITION), "source": source,
         "theta0": list(theta), "positions_m": list(positions), "blocks": args.blocks}))
    comp = compare_layouts(settings, positions, theta, weights=weights, blocks=args.blocks,
                           log=lambda msg: print(msg, file=sys.stderr, flush=True))
    data = comp.to_dict()
    atomic_write_json(out / "layout_neighbours.json", data)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_KEYS)
    for row in data["rows"]:
        w.writerow(["" if row[k] is None else row[k] for k in CSV_KEYS])
    atomic_write_text(out / "layout_neighbours.csv", buf.getvalue())
    print(comp.table())
    print(f"status {comp.status}; best layout is the rounded one: {comp.best_layout_is_rounded}"
          f"; best neighbour's margin {comp.best_neighbour_gap_pct:+.2f} % against the rounded "
          f"layout's")
    return 0 if comp.status in ("ok", "no_neighbour_verified") else 1


if __name__ == "__main__":
    sys.exit(main())
