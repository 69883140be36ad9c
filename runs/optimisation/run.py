"""Scripted flap-controller optimisation on the Humber case (seed Fig. 5).

Calls ``design.problem.optimise`` when that module exists; otherwise prints "unavailable" and
exits 0, so that CI can run this script before the optimiser lands.

    python runs/optimisation/run.py [--quick] [--out DIR]
"""

import argparse
import inspect
import json
import sys
from pathlib import Path


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one start, coarse mesh")
    ap.add_argument("--out", default=str(Path(__file__).parent / "output"))
    args = ap.parse_args()
    try:
        from design import problem
    except ImportError as exc:
        print(f"unavailable: design.problem not importable ({exc})")
        return 0
    optimise = getattr(problem, "optimise", None)
    if optimise is None:
        print("unavailable: design.problem has no optimise()")
        return 0
    from design.io import atomic_write_json, ensure_writable_dir
    from design.manifest import build_manifest
    from model.spec import load_bridge

    spec = load_bridge("humber")
    options = {"starts": 1} if args.quick else {"starts": 4}
    if args.quick:
        spec = spec.replace(**{"mesh.element_length_m": 47.0})
    accepted = inspect.signature(optimise).parameters
    options = {k: v for k, v in options.items() if k in accepted}
    result = optimise(spec, **options)
    out = ensure_writable_dir(args.out)
    summary = result.summary() if hasattr(result, "summary") else dict(result)
    atomic_write_json(out / "manifest.json", build_manifest({"quick": args.quick, **options}))
    atomic_write_json(out / "result.json", summary)
    print(json.dumps({"status": summary.get("status"), "out": str(out)}, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
