"""A script without ``if __name__ == "__main__":`` that starts worker processes: the spawned
workers would re-run it ("lock held", "Nanny failed to start"); the batch
refuses before starting any, in one line naming the fix (:mod:`bridgeflap.model.workers`)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from conftest import subprocess_env

from bridgeflap.model.workers import MAIN_GUARD_REASON, check_main_guard


def _run(script: str, tmp_path: Path) -> subprocess.CompletedProcess:
    path = tmp_path / "user_script.py"
    path.write_text(textwrap.dedent(script))
    env = subprocess_env()
    # 60 s: the refusal takes ~1 s (an import of design); a re-running worker would hang longer
    return subprocess.run([sys.executable, str(path), str(tmp_path / "out")], env=env,
                          capture_output=True, text=True, timeout=60, cwd=tmp_path)


@pytest.mark.parametrize("workers", [1, 2])
def test_unguarded_batch_is_refused_in_one_line(tmp_path, workers):
    """One worker too: a local Dask cluster of one worker is a spawned nanny all the same."""
    proc = _run(f"""
        import sys
        from bridgeflap import design

        design.run_batch(dict, [{{"x": 1.0}}, {{"x": 2.0}}], sys.argv[1], workers={workers},
                         progress=False)
        print("ran")
        """, tmp_path)
    assert proc.returncode == 1 and "ran" not in proc.stdout
    last = proc.stderr.strip().splitlines()[-1]
    assert last == f"bridgeflap.model.errors.BridgeflapInputError: workers: {MAIN_GUARD_REASON}"
    # refused before any worker started: no worker's error, no output folder
    assert "Nanny" not in proc.stderr and "lock" not in proc.stderr
    assert proc.stderr.count("Traceback") == 1
    assert not (tmp_path / "out").exists()


def test_unguarded_serial_batch_runs(tmp_path):
    """``scheduler="serial"`` starts no process: an unguarded script may run it."""
    proc = _run("""
        import sys
        from bridgeflap import design

        design.run_batch(dict, [{"x": 1.0}], sys.argv[1], scheduler="serial", progress=False)
        print("ran")
        """, tmp_path)
    assert proc.returncode == 0 and "ran" in proc.stdout, proc.stderr


def test_guard_reads_the_script(tmp_path):
    """The same call under the guard passes the check; so does any call with a forked pool
    (no re-import) or one worker; the reversed comparison is a guard too."""
    proc = _run("""
        from bridgeflap.model.workers import check_main_guard

        check_main_guard(2, "fork")
        check_main_guard(1, "spawn")
        try:
            check_main_guard(2, "spawn")
        except Exception as exc:
            print("refused:", type(exc).__name__)

        def main():
            check_main_guard(2, "spawn")
            print("guarded ok")

        if "__main__" == __name__:
            main()
        """, tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split("\n")[:2] == ["refused: BridgeflapInputError", "guarded ok"]


def test_pytest_and_one_worker_pass():
    # pytest's own entry point is guarded; one worker starts no process
    check_main_guard(2, "spawn")
    check_main_guard(1)


@pytest.mark.parametrize("workers", [0, 1])
def test_no_workers_no_check(workers):
    check_main_guard(workers, "spawn")
