"""Benchmark of the DOE batch runner on a 64-case flutter DOE.

Coarse mesh (50 m elements) and 8 modes keep one case at ~0.2 s. Measures, best of
``--repeat`` runs each:

* ``bare``: the analysis on every case in this process, no runner;
* ``serial``: the runner in this process (``scheduler="serial"``): files, hashes, table;
* ``dask_<n>``: the runner on a local Dask cluster of ``n`` worker processes, and ``startup``,
  the time to start (and close) such a cluster with one case run on each worker (its imports
  and caches, ~1 s, which ``bare`` pays in an untimed first case) -- the ``steady`` times
  subtract it;
* ratios: 1 -> 2 workers (total and steady), the per-case runner overhead relative to a bare
  case (serial runner, and 1-worker Dask without its start-up);
* ``cpu_share``: CPU time over wall time of the cases inside the workers. Below ~0.9 with two
  workers on two cores the cases did not get a core each: other load on the machine, not the
  runner, then limits the ratio (report it with the load average);
* ``case_cpu_s``: median CPU time of a case inside its process (of the last run; the median
  leaves out a worker's first case, which pays the imports and caches), and
  ``case_cpu_in_worker_vs_serial_pct`` its excess in a one-worker cluster over the serial
  runner: the part of the Dask overhead that other load on the machine hardly changes;
* ``page_faults_per_case``: median minor page faults of a case inside its process (ditto).
  A worker far above the serial runner's few hundred runs with glibc's dynamic malloc
  thresholds switched off (``MALLOC_TRIM_THRESHOLD_``,
  :data:`bridgeflap.design.batch.cluster.LOCAL_WORKER_CONFIG`): every large array is mapped and
  unmapped again, system time that ``cpu_share`` still counts.

The machine is often shared: the load average before and after each run is printed.

    OPENBLAS_NUM_THREADS=1 python -m bench.doe [--cases 64] [--repeat 3] [--json]
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import statistics
import tempfile
import time

OPTIONS = {"speeds": "0:120:2", "modes": 8}
RANGES = {"deck.gj_nm2": (2.8e11, 4.7e11), "cable.main_sag_m": (110.0, 125.0)}


def _minor_faults() -> int:
    try:
        import resource
    except ImportError:  # pragma: no cover - Windows
        return 0
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def timed_case(params: dict, fn) -> dict:
    """``fn(params)`` with the case's CPU and wall time and its minor page faults inside its
    process (for ``cpu_share`` and ``page_faults_per_case``)."""
    wall, cpu, faults = time.perf_counter(), time.process_time(), _minor_faults()
    out = dict(fn(params))
    out["bench_cpu_s"] = time.process_time() - cpu
    out["bench_wall_s"] = time.perf_counter() - wall
    out["bench_minor_faults"] = _minor_faults() - faults
    return out


def _load() -> str:
    return "/".join(f"{x:.2f}" for x in os.getloadavg())


def blas_threads() -> str:
    """The BLAS libraries loaded and their thread counts (threadpoolctl)."""
    import numpy  # noqa: F401 - loads the BLAS that threadpoolctl then reports

    try:
        from threadpoolctl import threadpool_info

        return ", ".join(f"{i.get('internal_api')}={i.get('num_threads')}"
                         for i in threadpool_info() if i.get("user_api") == "blas") or "none"
    except ImportError:  # pragma: no cover
        return f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}"


def _startup(workers: int, fn, params: dict) -> float:
    """Start a local cluster of ``workers``, run ``fn(params)`` once on every worker (the
    imports and caches a worker's first case pays, as the untimed first ``bare`` case does),
    close it [s]."""
    from bridgeflap.design.batch.cluster import cluster_client

    t = time.perf_counter()
    with cluster_client(workers, None) as client:
        client.run(fn, params)
    return time.perf_counter() - t


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=64)
    ap.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    from bridgeflap.design.batch.designs import latin_hypercube
    from bridgeflap.design.batch.runner import run_batch
    from bridgeflap.design.studies.cases import flutter_case

    cases = [{**c, "mesh.element_length_m": 50.0}
             for c in latin_hypercube(RANGES, args.cases, seed=1)]
    plain = [{k: v for k, v in c.items() if k != "case_id"} for c in cases]
    fn = functools.partial(timed_case, fn=functools.partial(flutter_case, bridge="humber",
                                                            **OPTIONS))
    fn(plain[0])  # warm imports and caches (the RFA fit)
    res = {"cases": args.cases, "cpu_count": os.cpu_count(), "blas": blas_threads(),
           "repeat": args.repeat, "load_start": _load()}

    def best(label, run):
        times = []
        for _ in range(args.repeat):
            before = _load()
            t = time.perf_counter()
            out = run()
            times.append(time.perf_counter() - t)
            res[f"{label}_load"] = f"{before} -> {_load()}"
        res[f"{label}_s"] = min(times)
        return out

    best("bare", lambda: [fn(p) for p in plain])
    with tempfile.TemporaryDirectory() as tmp:
        counter = iter(range(10 ** 6))

        def batch(**kw):
            b = run_batch(fn, cases, os.path.join(tmp, str(next(counter))), progress=False,
                          fingerprint="bench.doe", **kw)
            rows = [r["result"] for r in b.rows if r["status"] == "ok"]
            cpu = [r["bench_cpu_s"] for r in rows]
            return (b.failed, sum(cpu) / max(1e-12, sum(r["bench_wall_s"] for r in rows)),
                    statistics.median(cpu),
                    statistics.median(r["bench_minor_faults"] for r in rows))

        for label, kw in (("serial", {"scheduler": "serial"}), ("dask_1", {"workers": 1}),
                          ("dask_2", {"workers": 2})):
            if label.startswith("dask"):
                n = kw["workers"]
                best(f"startup_{n}", lambda n=n: _startup(n, fn, plain[0]))
            (res[f"{label}_failed"], res[f"cpu_share_{label}"], res[f"case_cpu_s_{label}"],
             res[f"page_faults_per_case_{label}"]) = best(label, lambda kw=kw: batch(**kw))
        for n in (1, 2):
            res[f"dask_{n}_steady_s"] = res[f"dask_{n}_s"] - res[f"startup_{n}_s"]
    bare = res["bare_s"] / args.cases
    res["bare_per_case_s"] = bare
    res["ratio_1_to_2_workers"] = res["dask_1_s"] / res["dask_2_s"]
    res["ratio_1_to_2_workers_steady"] = res["dask_1_steady_s"] / res["dask_2_steady_s"]
    res["overhead_per_case_serial_pct"] = 100 * (res["serial_s"] - res["bare_s"]) / res["bare_s"]
    res["overhead_per_case_dask_1_pct"] = (100 * (res["dask_1_steady_s"] - res["bare_s"])
                                           / res["bare_s"])
    res["case_cpu_in_worker_vs_serial_pct"] = (
        100 * (res["case_cpu_s_dask_1"] - res["case_cpu_s_serial"]) / res["case_cpu_s_serial"])
    res["load_end"] = _load()
    if args.json:
        print(json.dumps(res, indent=1))
    else:
        print(f"DOE runner benchmark: {args.cases} flutter cases, best of {args.repeat}; "
              f"{res['cpu_count']} CPUs, BLAS {res['blas']}; load {res['load_start']} -> "
              f"{res['load_end']} (1/5/15 min)")
        for k, v in res.items():
            if k not in ("cases", "cpu_count", "blas", "repeat", "load_start", "load_end"):
                print(f"  {k:34s} {v:.4g}" if isinstance(v, float) else f"  {k:34s} {v}")


if __name__ == "__main__":
    main()
