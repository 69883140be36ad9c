"""Benchmark: the same design on every machine (``python -m bench.reproducible [--quick]``).

Runs ``bridgeflap optimise [CARD] --checks none --json`` (the default card, or its ``--quick``
form) in a subprocess under each of these settings, and compares every run with the first:

* the machine's default OpenBLAS kernel, 1 thread (the reference);
* another kernel (``OPENBLAS_CORETYPE``, default ``Sandybridge``: AVX without FMA, so every dot
  product rounds differently; pass ``--kernel`` for another);
* 2 BLAS threads (another summation order);
* every model matrix perturbed by 1e-12 relative (the test hook
  ``bridgeflap.design.control.problem_model.PERTURB_ENV``).

It prints, per run, the kernel that numpy reports (threadpoolctl), the status, the flap layout,
K's largest relative difference from the reference, and the closed-loop critical speed's
difference [m/s], against the tolerances a user relies on (same layout, K within 1e-4, critical
speed within 0.01 m/s), plus each run's wall time, the CPU count and the BLAS threads.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

K_RTOL = 1e-4
CRITICAL_ATOL_M_S = 0.01


def _kernel(env) -> str:
    code = ("import numpy, threadpoolctl; print([(d.get('architecture'), d.get('num_threads')) "
            "for d in threadpoolctl.threadpool_info() if d.get('internal_api') == 'openblas'])")
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True).stdout.strip()


def _run(card, quick, extra_env) -> dict:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
           "MPLBACKEND": "Agg", **extra_env}
    with tempfile.TemporaryDirectory() as tmp:
        argv = [sys.executable, "-m", "bridgeflap.design.cli.main", "optimise",
                *([card] if card else []),
                "--checks", "none", "--json", "--out", os.path.join(tmp, "opt"),
                *(["--quick"] if quick else [])]
        t0 = time.perf_counter()
        proc = subprocess.run(argv, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
    out = json.loads(proc.stdout) if proc.stdout.strip() else {}
    lim = out.get("closed_loop_limits") or {}
    return {"env": extra_env, "kernel": _kernel(env), "exit_code": proc.returncode,
            "status": out.get("status"), "flap_positions_m": out.get("flap_positions_m"),
            "coefficients": out.get("coefficients"),
            "critical_speed_m_s": lim.get("critical_speed_m_s"), "wall_s": round(wall, 1)}


def compare(ref: dict, run: dict) -> dict:
    """Layout equality, K's largest relative difference and the critical-speed difference."""
    k0, k1 = ref["coefficients"] or {}, run["coefficients"] or {}
    krel = max((abs(k1[n] - k0[n]) / max(abs(k0[n]), 1e-300) for n in k0
                if k0.get(n) is not None and k1.get(n) is not None), default=float("nan"))
    u0, u1 = ref["critical_speed_m_s"], run["critical_speed_m_s"]
    du = abs(u1 - u0) if u0 is not None and u1 is not None else float("nan")
    same = (ref["flap_positions_m"] == run["flap_positions_m"] and ref["status"] == run["status"])
    return {"same_layout_and_status": same, "k_rel_diff": krel, "critical_diff_m_s": du,
            "within": bool(same and krel <= K_RTOL and du <= CRITICAL_ATOL_M_S)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("card", nargs="?", default=None, help="design card (default: the packaged)")
    p.add_argument("--quick", action="store_true", help="the card's --quick form")
    p.add_argument("--kernel", default="Sandybridge", help="the other OPENBLAS_CORETYPE")
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    settings = [{}, {"OPENBLAS_CORETYPE": args.kernel}, {"OPENBLAS_NUM_THREADS": "2"},
                {"BRIDGEFLAP_PERTURB_REL": "1e-12"}]
    runs = [_run(args.card, args.quick, e) for e in settings]
    rows = [{**r, **compare(runs[0], r)} for r in runs]
    out = {"cpu_count": os.cpu_count(), "tolerances": {"k_rel": K_RTOL,
                                                       "critical_m_s": CRITICAL_ATOL_M_S},
           "runs": rows, "all_within": all(r["within"] for r in rows)}
    if args.json:
        print(json.dumps(out))
        return 0
    print(f"{out['cpu_count']} CPUs; reference: the default kernel, 1 BLAS thread; "
          f"tolerances K {K_RTOL:g} relative, critical speed {CRITICAL_ATOL_M_S} m/s")
    for r in rows:
        print(f"  {json.dumps(r['env']) or '{}':38s} kernel {r['kernel']:24s} {r['status']}, "
              f"{len(r['flap_positions_m'] or [])} flaps, K rel diff {r['k_rel_diff']:.2e}, "
              f"critical {r['critical_speed_m_s']} m/s (diff {r['critical_diff_m_s']:.2e}), "
              f"{r['wall_s']} s: {'within' if r['within'] else 'OUTSIDE'}")
    print(f"all within the tolerances: {out['all_within']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
