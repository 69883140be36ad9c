"""Benchmark of ``bridgeflap study``: wall time, and where it goes.

Runs the CLI (``python -m bridgeflap.design.cli.main study [--quick] --workers N``) in a fresh
process for each setting, best of ``--repeat``, and prints one table: the study's wall time, each
analysis' own time (``results/<analysis>.json`` ``elapsed_s``: with several workers they overlap, so
they sum to more than the wall time), the 1 -> N worker ratio, the CPU count, BLAS threads and the
load average before and after (the machine is often shared: a run under load is slower, and a
quiet run may not be possible -- the load says which it was). Targets: default at most 90 s,
``--quick`` at most 30 s on 2 cores.

    OPENBLAS_NUM_THREADS=1 python -m bench.study [--quick-only] [--workers 1,2] [--repeat 1]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _load() -> str:
    return "/".join(f"{x:.2f}" for x in os.getloadavg())


def run_once(quick: bool, workers: int, folder: Path) -> dict:
    """One ``bridgeflap study`` run: wall time [s], per-analysis times [s], statuses, load."""
    out = folder / f"{'quick' if quick else 'default'}-{workers}-{time.monotonic_ns()}"
    argv = [sys.executable, "-m", "bridgeflap.design.cli.main", "study", "--out", str(out),
            "--workers",
            str(workers), "--json", *(["--quick"] if quick else [])]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1"),
           "MPLBACKEND": "Agg"}
    before = _load()
    t = time.perf_counter()
    p = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if p.returncode != 0:
        raise SystemExit(f"study failed ({p.returncode}): {p.stderr[-2000:]}")
    s = json.loads(p.stdout)
    times = {kind: json.loads((out / "results" / f"{kind}.json").read_text()).get("elapsed_s")
             for kind in s["statuses"]}
    return {"wall_s": wall, "study_elapsed_s": s["elapsed_s"], "analyses_s": times,
            "statuses": s["statuses"], "load": f"{before} -> {_load()}"}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick-only", action="store_true", help="only the --quick study")
    ap.add_argument("--default-only", action="store_true", help="only the default study")
    ap.add_argument("--workers", default="1,2", help="comma list of worker counts")
    ap.add_argument("--repeat", type=int, default=1, help="best of this many runs")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    from bench.doe import blas_threads

    workers = [int(w) for w in args.workers.split(",")]
    modes = [q for q in (True, False)
             if not (args.quick_only and not q) and not (args.default_only and q)]
    res = {"cpu_count": os.cpu_count(), "blas": blas_threads(), "repeat": args.repeat,
           "load_start": _load(), "runs": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for quick in modes:
            for w in workers:
                runs = [run_once(quick, w, Path(tmp)) for _ in range(args.repeat)]
                res["runs"][f"{'quick' if quick else 'default'}_workers_{w}"] = min(
                    runs, key=lambda r: r["wall_s"])
    for quick in modes:
        name = "quick" if quick else "default"
        one, last = res["runs"].get(f"{name}_workers_1"), res["runs"].get(
            f"{name}_workers_{workers[-1]}")
        if one and last and workers[-1] != 1:
            res[f"{name}_ratio_1_to_{workers[-1]}_workers"] = one["wall_s"] / last["wall_s"]
    res["load_end"] = _load()
    if args.json:
        print(json.dumps(res, indent=1))
        return
    print(f"bridgeflap study benchmark: {res['cpu_count']} CPUs, BLAS {res['blas']}, best of "
          f"{args.repeat}; load {res['load_start']} -> {res['load_end']} (1/5/15 min)")
    kinds = list(next(iter(res["runs"].values()))["analyses_s"])
    head = f"  {'run':22s} {'wall [s]':>9s}" + "".join(f" {k[:10]:>10s}" for k in kinds)
    print(head + "  load")
    for name, r in res["runs"].items():
        print(f"  {name:22s} {r['wall_s']:9.1f}"
              + "".join(f" {r['analyses_s'].get(k) or float('nan'):10.1f}" for k in kinds)
              + f"  {r['load']}")
    for k, v in res.items():
        if k.endswith("_workers") and isinstance(v, float):
            print(f"  {k}: {v:.2f}")


if __name__ == "__main__":
    main()
