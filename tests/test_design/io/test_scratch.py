"""No scratch folder stays behind in the temp folder: a run killed with SIGKILL leaves its
``bridgeflap-<kind>-<pid>-*`` folder, and the next run of that kind removes it (its owner is
dead), never a live process's folder nor one named otherwise. The acceptance checks run
outside their scratch folder, and a local Dask cluster's scratch space is a folder of the run.
No numbers are compared, so there are no tolerances; the waits are bounded (30 s for a Python
child to start on a loaded 2-core machine).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

from bridgeflap.design.io.scratch import remove_stale_scratch, scratch_folder, scratch_prefix

CHILD = """
import sys, time
from bridgeflap.design.io.scratch import scratch_folder
with scratch_folder(sys.argv[2], sys.argv[1]) as path:
    (path / "work.txt").write_text("half-way")
    print(path, flush=True)
    time.sleep(600)
"""


def test_a_killed_runs_scratch_folder_is_removed_by_the_next_run(tmp_path):
    proc = subprocess.Popen([sys.executable, "-c", CHILD, str(tmp_path), "accept"],
                            stdout=subprocess.PIPE, text=True)
    try:
        left = tmp_path / proc.stdout.readline().strip()  # the child is inside its block
        assert left.is_dir() and left.name.startswith(f"{scratch_prefix('accept')}{proc.pid}-")
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
        proc.stdout.close()
    assert left.is_dir()  # SIGKILL ran no clean-up: the folder stays ...
    live = tmp_path / f"{scratch_prefix('accept')}{os.getpid()}-mine"
    live.mkdir()
    other = tmp_path / f"{scratch_prefix('accept')}notapid"
    other.mkdir()
    dask_left = tmp_path / f"{scratch_prefix('dask')}{proc.pid}-x"
    dask_left.mkdir()
    with scratch_folder("accept", tmp_path) as mine:  # ... until the next run of its kind
        assert not left.exists() and mine.is_dir()
    assert not mine.exists()
    # a live owner's folder, a folder named otherwise and another kind's are not touched
    assert live.is_dir() and other.is_dir() and dask_left.is_dir()
    assert remove_stale_scratch("dask", tmp_path) == [dask_left]


def test_the_acceptance_checks_run_outside_the_scratch_folder(monkeypatch):
    """A kill during the checks (minutes) leaves no folder: the scratch folder only lives for
    writing the controller and reading it back."""
    import tempfile

    from bridgeflap import design
    from bridgeflap.model.aeroelastic.control import Compensator, Controller

    seen = []

    def acceptance(controller, settings, opts, closed_loop=None, progress=None, bridge=None,
                   closed_loop_limits=None):
        seen.extend(p for p in os.listdir(tempfile.gettempdir())
                    if p.startswith(f"{scratch_prefix('accept')}{os.getpid()}-"))
        return {"checks": list(opts.checks), "status": "passed"}, {}

    monkeypatch.setattr("bridgeflap.design.assessment.acceptance.acceptance", acceptance)
    res = design.accept(Controller(Compensator(0.0, 0.1, 0.5, 0.0, 0.1), (0.0,), 10.0),
                        checks="robustness")
    assert res.status == "passed" and seen == []


def test_a_local_dask_cluster_keeps_its_scratch_space_in_the_runs_folder(tmp_path, monkeypatch):
    from bridgeflap.design.batch.cluster import cluster_client

    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    t0 = time.monotonic()
    with cluster_client(1, None) as client:
        dirs = client.run(lambda dask_worker: dask_worker.local_directory)
        (worker_dir,) = dirs.values()
        assert worker_dir.startswith(str(tmp_path / scratch_prefix("dask"))), worker_dir
    # closed: nothing of the cluster is left in the temp folder (a cluster starts in ~5 s)
    assert sorted(os.listdir(tmp_path)) == [], os.listdir(tmp_path)
    assert time.monotonic() - t0 < 120
