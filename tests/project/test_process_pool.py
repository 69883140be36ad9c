"""One process-pool mechanism: every local pool of worker processes is made
by :func:`bridgeflap.model.workers.process_pool`, which checks the ``if __name__ == "__main__":``
guard before any process starts (:mod:`bridgeflap.model.workers`; tests/test_main_guard.py)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

from conftest import subprocess_env

from bridgeflap.model.workers import MAIN_GUARD_REASON, process_pool

ROOT = Path(__file__).resolve().parents[2]
REFUSED = f"bridgeflap.model.errors.BridgeflapInputError: workers: {MAIN_GUARD_REASON}"


def _run(script: str, tmp_path: Path) -> subprocess.CompletedProcess:
    path = tmp_path / "user_script.py"
    path.write_text(textwrap.dedent(script))
    env = subprocess_env()
    # a refusal takes about a second; a re-running spawned worker would take far longer
    return subprocess.run([sys.executable, str(path)], env=env, capture_output=True,
                          text=True, timeout=60, cwd=tmp_path)


def test_no_other_process_pool_in_the_package():
    """A pool made elsewhere would skip the guard: ``ProcessPoolExecutor`` is subclassed in
    model/workers.py and constructed nowhere else."""
    found = []
    for pkg in ("design", "model"):
        for path in sorted((ROOT / pkg).rglob("*.py")):
            text = path.read_text(encoding="utf-8")
            if "ProcessPoolExecutor(" in text or "(ProcessPoolExecutor)" in text:
                found.append(path.relative_to(ROOT).as_posix())
    assert found == ["model/workers.py"]


def test_factory_refuses_an_unguarded_script_under_spawn(tmp_path):
    """Even a pool of one worker is refused: a spawned worker re-runs the script whatever the
    pool's size."""
    proc = _run("""
        import multiprocessing

        from bridgeflap.model.workers import process_pool

        multiprocessing.set_start_method("spawn")
        print("before")
        with process_pool(1) as ex:
            print("ran")
        """, tmp_path)
    assert proc.returncode == 1 and proc.stdout == "before\n", proc.stderr
    assert proc.stderr.strip().splitlines()[-1] == REFUSED
    assert proc.stderr.count("Traceback") == 1


def test_factory_runs_a_guarded_script_under_spawn(tmp_path):
    proc = _run("""
        import multiprocessing

        from bridgeflap.model.workers import process_pool

        if __name__ == "__main__":
            multiprocessing.set_start_method("spawn")
            with process_pool(2) as ex:
                print("two workers:", sorted(ex.map(abs, [-3, 4])))
        """, tmp_path)
    assert proc.returncode == 0 and proc.stdout == "two workers: [3, 4]\n", proc.stderr


def test_do_no_harm_refuses_an_unguarded_script(tmp_path):
    """do-no-harm's pool did not check the guard before the factory; it refuses now, before
    any variant is swept."""
    proc = _run("""
        import multiprocessing

        from bridgeflap.design.assessment.harm import do_no_harm
        from bridgeflap.model.aeroelastic.control import Compensator, Controller

        multiprocessing.set_start_method("spawn")
        k = Compensator(-1.05, 0.72, -4.99, 0.25, 0.20)
        c = Controller(k, tuple(56.4 * i for i in range(-12, 13) if abs(i) >= 4), 56.4,
                       flap_chord_m=3.0)
        do_no_harm(c, count=2, workers=2)
        print("ran")
        """, tmp_path)
    assert proc.returncode == 1 and "ran" not in proc.stdout
    assert proc.stderr.strip().splitlines()[-1] == REFUSED
    assert proc.stderr.count("Traceback") == 1


def test_factory_in_process():
    """Guarded (pytest's entry point), clamped to one worker, the initializer installed."""
    with process_pool(0) as ex:
        assert ex._max_workers == 1
        assert ex.submit(os.getppid).result() == os.getpid()
    with process_pool(2, die_with_parent=False) as ex:
        assert ex._max_workers == 2 and ex._initargs[0] is None


def _blas_threads() -> list[int]:
    from threadpoolctl import threadpool_info

    return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]


def test_a_worker_uses_one_blas_thread_unless_the_user_chose(monkeypatch):
    """Two workers with a BLAS thread per core each oversubscribe the cores (measured 3.3x
    slower per task on 2 cores, model.workers._one_blas_thread); a user's choice stands."""
    from threadpoolctl import threadpool_limits

    for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        monkeypatch.delenv(v, raising=False)
    # the parent on 2 threads (where the machine has them), as a script's numpy starts
    with threadpool_limits(2, user_api="blas"), process_pool(1) as ex:
        assert set(ex.submit(_blas_threads).result()) == {1}
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")
    with threadpool_limits(2, user_api="blas"), process_pool(1) as ex:
        # the worker keeps what it inherited (2 here), not the one-thread default, up to the
        # cores (one worker)
        assert set(ex.submit(_blas_threads).result()) == {min(n, _cores())
                                                           for n in _blas_threads()}


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def test_a_users_thread_count_is_shared_among_the_workers(monkeypatch):
    """A thread count the user set is the machine's budget: each of two workers keeps it up to
    half of the cores (two workers with two threads each on 2 cores made the default card's
    checks crawl, model.workers._one_blas_thread)."""
    from threadpoolctl import threadpool_limits

    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")
    with threadpool_limits(2, user_api="blas"), process_pool(2) as ex:
        parent = set(_blas_threads())
        got = {n for f in [ex.submit(_blas_threads) for _ in range(4)] for n in f.result()}
    assert got == {min(n, max(1, _cores() // 2)) for n in parent}
