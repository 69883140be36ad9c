"""The local Dask cluster's workers run with
:data:`bridgeflap.design.batch.cluster.LOCAL_WORKER_CONFIG`.

A worker of distributed's defaults spent +45 % CPU on a flutter case (``bench/doe.py``): its
nanny sets ``MALLOC_TRIM_THRESHOLD_`` before spawning it, which switches glibc's dynamic
mmap threshold off, so every freed large array is unmapped and the next one faults its pages in
again. These tests check the settings inside the worker processes (also after a restart, as
an abandoned case does), count page faults rather than time anything, and check that the
environment of this process is left as it was. The serial-vs-Dask equality of the results is
checked in ``tests/test_parallel.py``.
"""

from __future__ import annotations

import contextlib
import io
import os
import platform
import subprocess
import sys

import pytest

from bridgeflap.design.batch.cluster import LOCAL_WORKER_CONFIG, cluster_client

GLIBC = sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc"

#: 1 MiB arrays allocated and freed in turn, and the page-fault budget for them: a fresh
#: mapping of 1 MiB faults in 256 pages of 4 KiB, so 200 of them cost >= 51,200 faults, while
#: glibc's dynamic threshold reuses the heap chunk after the first free. 5,000 leaves room
#: for the few first-time mappings and Python's own allocations in between (measured: ~510 in a
#: worker, ~500 in a fresh process; 51,400 with distributed's old setting).
PROBE_ARRAYS = 200
FAULT_BUDGET = 5000

PROBE = f"""
import resource
import numpy as np
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range({PROBE_ARRAYS}):
    a = np.ones(131072)  # 1 MiB, every page written
    del a
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _worker_state() -> dict:
    """What a worker sees: its settings, and the page faults of the allocation probe."""
    import dask

    scope: dict = {}
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(PROBE, scope)  # noqa: S102 - the fixed probe text above
    return {"malloc_trim": os.environ.get("MALLOC_TRIM_THRESHOLD_"),
            "profile": dask.config.get("distributed.worker.profile.enabled"),
            "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
            "faults": int(out.getvalue())}


def _env(keys) -> dict:
    return {k: os.environ.get(k) for k in keys}


def test_the_config_disables_the_trim_threshold_and_the_profiler():
    # the two settings the benchmark found; a change here must come with a new measurement
    assert LOCAL_WORKER_CONFIG == {
        "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
        "distributed.worker.profile.enabled": False,
    }


@pytest.mark.skipif(not GLIBC, reason="glibc malloc behaviour (Linux)")
def test_the_probe_sees_the_trim_threshold():
    # the probe can fail: with distributed's old value every array faults its pages in again
    env = {**os.environ, "MALLOC_TRIM_THRESHOLD_": "65536"}
    faults = int(subprocess.run([sys.executable, "-c", PROBE], env=env, check=True,
                                capture_output=True, text=True).stdout)
    assert faults > 10 * FAULT_BUDGET


@pytest.mark.skipif(not GLIBC, reason="glibc malloc behaviour (Linux)")
def test_local_workers_run_with_the_config_also_after_a_restart(monkeypatch):
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    monkeypatch.delenv("PYTHONHASHSEED", raising=False)
    keys = ("MALLOC_TRIM_THRESHOLD_", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
            "OPENBLAS_NUM_THREADS", "PYTHONHASHSEED")
    before = _env(keys)
    with cluster_client(2, None) as client:
        states = [client.run(_worker_state)]
        client.restart_workers(list(client.scheduler_info()["workers"]), timeout=60)
        states.append(client.run(_worker_state))
    for state in states:
        assert len(state) == 2
        for address, seen in state.items():
            assert seen["malloc_trim"] is None, address
            assert seen["profile"] is False, address
            assert seen["blas_threads"] == "1", address  # one BLAS thread per worker process
            assert seen["faults"] < FAULT_BUDGET, (address, seen["faults"])
    # the nannies' pre-spawn variables do not outlive the cluster in this process
    assert _env(keys) == before
