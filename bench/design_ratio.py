"""Benchmark: the default design as a multiple of one erection analysis on the same machine
(``python -m bench.design_ratio [--pairs N] [--json]``).

A design's wall time depends on the machine; its ratio to a fixed piece of work run beside it,
in the same minute, depends much less on it. This runs ``bridgeflap erection --json`` (the
built-in Humber's erection sequence, flutter and divergence per stage) and ``bridgeflap optimise
--checks none --json`` (the default card's design without its acceptance checks) in turn,
``--pairs`` times (E D E D ...), each as a whole process with its output in a temporary folder,
and prints each wall and CPU time, the ratio design / erection per pair and its median, with
the CPU count, the BLAS threads and the load (``os.getloadavg``) before and after.
The target of the design core is a ratio of at most 6.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

TARGET_RATIO = 6.0


def _timed(cmd: list[str]) -> dict:
    """Wall and CPU seconds (the child's user + sys) of ``cmd``; its exit code."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                          check=False)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall_s": wall, "cpu_s": cpu, "exit": proc.returncode}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--pairs", type=int, default=2, help="erection/design pairs (default 2)")
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    exe = [sys.executable, "-m", "bridgeflap.design.cli.main"]
    blas = os.environ.get("OPENBLAS_NUM_THREADS", "1 (the CLI's default)")
    load0 = os.getloadavg()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(max(1, args.pairs)):
            e = _timed([*exe, "erection", "--json"])
            d = _timed([*exe, "optimise", "--checks", "none", "--json",
                        "--out", os.path.join(tmp, f"design_{k}")])
            rows.append({"erection": e, "design": d, "ratio": d["wall_s"] / e["wall_s"]})
    out = {"cpu_count": os.cpu_count(), "blas_threads": blas,
           "load_before": load0, "load_after": os.getloadavg(), "pairs": rows,
           "median_ratio": statistics.median(r["ratio"] for r in rows),
           "target_ratio": TARGET_RATIO}
    out["target_met"] = bool(out["median_ratio"] <= TARGET_RATIO)
    if args.json:
        print(json.dumps(out, indent=1))
    else:
        print(f"{out['cpu_count']} CPUs, BLAS threads {blas}, load {load0[0]:.2f} -> "
              f"{out['load_after'][0]:.2f}")
        for k, r in enumerate(rows):
            print(f"pair {k}: erection {r['erection']['wall_s']:.1f} s wall "
                  f"({r['erection']['cpu_s']:.1f} s CPU), design {r['design']['wall_s']:.1f} s "
                  f"wall ({r['design']['cpu_s']:.1f} s CPU), ratio {r['ratio']:.2f}")
        print(f"design / erection, median: {out['median_ratio']:.2f} (target <= "
              f"{TARGET_RATIO:g}: {'met' if out['target_met'] else 'not met'})")
    bad = [r for r in rows if r["erection"]["exit"] or r["design"]["exit"]]
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
