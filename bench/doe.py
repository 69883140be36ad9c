"""Benchmark of the DOE batch runner on a 64-case flutter DOE.

Coarse mesh (50 m elements) and 8 modes keep one case at ~0.1-0.2 s. Measures:

* wall time of the 64 cases with 1 and 2 Dask worker processes (scaling ratio; the machine
  has 2 cores, other load lowers the ratio);
* the bare analysis time per case in this process (no runner);
* the per-case overhead of the runner: (serial runner time - bare time) / cases, and
  (1-worker Dask time - bare time) / cases, which includes cluster start-up.

    OPENBLAS_NUM_THREADS=1 python -m bench.doe [--cases 64] [--json]
"""

import argparse
import functools
import json
import os
import tempfile
import time

from design.cases import flutter_case
from design.designs import latin_hypercube
from design.doe import run_batch

OPTIONS = {"speeds": "0:120:2", "modes": 8}
RANGES = {"deck.gj_nm2": (2.8e11, 4.7e11), "cable.main_sag_m": (110.0, 125.0)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=64)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    cases = [{**c, "mesh.element_length_m": 50.0}
             for c in latin_hypercube(RANGES, args.cases, seed=1)]
    fn = functools.partial(flutter_case, bridge="humber", **OPTIONS)
    fn({k: v for k, v in cases[0].items() if k != "case_id"})  # warm imports
    t = time.perf_counter()
    for c in cases:
        fn({k: v for k, v in c.items() if k != "case_id"})
    bare = time.perf_counter() - t
    res = {"cases": args.cases, "bare_s": bare, "bare_per_case_s": bare / args.cases}
    with tempfile.TemporaryDirectory() as tmp:
        for label, kw in (("serial", {"scheduler": "serial"}), ("workers_1", {"workers": 1}),
                          ("workers_2", {"workers": 2})):
            t = time.perf_counter()
            b = run_batch(fn, cases, os.path.join(tmp, label), progress=False, **kw)
            res[f"{label}_s"] = time.perf_counter() - t
            res[f"{label}_failed"] = b.failed
    res["scaling_ratio_1_over_2_workers"] = res["workers_1_s"] / res["workers_2_s"]
    res["overhead_per_case_serial_s"] = (res["serial_s"] - bare) / args.cases
    res["overhead_per_case_dask_1_worker_s"] = (res["workers_1_s"] - bare) / args.cases
    if args.json:
        print(json.dumps(res, indent=1))
    else:
        for k, v in res.items():
            print(f"{k:36s} {v:.4g}" if isinstance(v, float) else f"{k:36s} {v}")


if __name__ == "__main__":
    main()
