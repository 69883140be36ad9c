"""Mode-count convergence of flutter and divergence over the estimated-input ranges.

For the built-in Humber, the humber:box variant (b = 11 m) and every corner of the ranges of the
estimated inputs that enter flutter (design/studies/screening.py DEFAULT_UNCERTAIN_RANGES
without the buffeting-only coherence decay: 2^6 = 64 corners), solve the flutter/divergence sweep
with 8, 12, 16, 20, 24, 30 and 40 retained vertical + torsional modes
(model/stability/convergence.py), print the ladder, the converged count of each case (its own and
every later step below 0.05 %) and the count that is converged over all cases, with the truncation
error of 16 modes and of that count against 40.

    python runs/mode_convergence/run.py [--quick] [--json] [--out FILE.json]

``--quick``: two opposite corners, a coarse mesh and a coarse grid (CI).
"""

import argparse
import itertools
import json
import sys

import numpy as np

from bridgeflap.design.io.files import atomic_write_json, to_jsonable
from bridgeflap.design.io.options import parse_range
from bridgeflap.design.studies.screening import DEFAULT_UNCERTAIN_RANGES
from bridgeflap.model.stability.convergence import (
    DEFAULT_MODE_COUNTS,
    TOLERANCE_PCT,
    mode_convergence,
)
from bridgeflap.model.structure.loader import load_bridge

#: buffeting-only inputs do not enter flutter or divergence
BUFFETING_ONLY = ("aero.coherence_decay",)


def corners(ranges):
    """``(name, changes)`` for every corner of ``ranges`` (lo/hi per parameter)."""
    paths = [p for p in ranges if p not in BUFFETING_ONLY]
    for ends in itertools.product((0, 1), repeat=len(paths)):
        name = "corner " + "".join("LH"[e] for e in ends)
        yield name, {p: ranges[p][e] for p, e in zip(paths, ends, strict=True)}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--out", help="also write the JSON result to this file")
    args = ap.parse_args()
    # 120 m/s: the b = 11 m corners diverge beyond the 85 m/s headline grid
    speeds = parse_range("0:120:1.0" if args.quick else "0:120:0.5", "speeds", 0.0)
    counts = (8, 16, 24) if args.quick else DEFAULT_MODE_COUNTS
    mesh = {"mesh.element_length_m": 47.0} if args.quick else {}
    cases = [("humber", "humber", {}), ("humber:box", "humber:box", {})]
    all_corners = list(corners(DEFAULT_UNCERTAIN_RANGES))
    picked = [all_corners[0], all_corners[-1]] if args.quick else all_corners
    cases += [(name, "humber", ch) for name, ch in picked]
    results = []
    for name, bridge, changes in cases:
        spec = load_bridge(bridge).replace(**changes, **mesh)
        r = mode_convergence(spec, speeds, counts)
        s = r.summary()
        s.update(case=name, changes=changes)
        results.append(s)
        print(f"{name}: {r.status}, converged at {r.converged_modes} modes "
              f"(first small step {r.first_small_step_modes})", file=sys.stderr)
        if not args.json:
            print(f"\n{name} {changes or ''}\n{r.table()}")
    ok = [s for s in results if s["status"] == "converged"]
    # converged over every case, or None when a case does not converge within the ladder
    recommended = (max(s["converged_modes"] for s in ok) if ok and len(ok) == len(results)
                   else None)
    ref = counts[-1]

    def worst(n, mech):
        errs = [abs(row[f"{mech}_speed_m_s"] - s["rows"][-1][f"{mech}_speed_m_s"])
                / s["rows"][-1][f"{mech}_speed_m_s"] * 100
                for s in results for row in s["rows"] if row["n_modes"] == n
                and row[f"{mech}_status"] == s["rows"][-1][f"{mech}_status"] == "converged"]
        return max(errs) if errs else float("nan")

    by_count = [{"n_modes": n, "max_flutter_error_pct": worst(n, "flutter"),
                 "max_divergence_error_pct": worst(n, "divergence")} for n in counts[:-1]]
    out = {"tolerance_pct": TOLERANCE_PCT, "counts": list(counts), "reference_modes": ref,
           "speeds_m_s": [float(speeds[0]), float(speeds[-1]), float(speeds[1] - speeds[0])],
           "cases": len(results), "converged_cases": len(ok),
           "recommended_modes": recommended, "max_error_vs_reference": by_count,
           "results": results}
    if args.out:
        atomic_write_json(args.out, out)
    if args.json:
        print(json.dumps(to_jsonable(out), allow_nan=False))
        return
    print(f"\n{len(ok)}/{len(results)} cases converged (tolerance {TOLERANCE_PCT} %)")
    print(f"largest error against {ref} modes over all cases:")
    for b in by_count:
        print(f"  {b['n_modes']:3d} modes: flutter {b['max_flutter_error_pct']:.4f} %, "
              f"divergence {b['max_divergence_error_pct']:.4f} %")
    print(f"count converged over every case: {recommended}"
          + ("" if recommended else f" (not within {ref} modes)"))
    worst_case = max(results, key=lambda s: s["converged_modes"] or np.inf)
    print(f"(set by {worst_case['case']} {worst_case['changes']})")


if __name__ == "__main__":
    main()
