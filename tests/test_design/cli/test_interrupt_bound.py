"""Ctrl-C ends a command whatever its clean-up waits for: the pool terminates the workers it
started (also one started while the signal went out, not yet registered), and the console
script's watchdog ends a clean-up that hangs after the grace time, with the same exit status
and the one line (:mod:`bridgeflap.design.cli.run`, :mod:`bridgeflap.model.workers`)."""

from __future__ import annotations

import multiprocessing
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from conftest import subprocess_env

from bridgeflap.model.workers import process_pool


def _sleep(seconds: float) -> float:
    time.sleep(seconds)
    return seconds


def _gone(procs, timeout: float = 30.0) -> bool:
    # a terminated process ends within milliseconds; 30 s bounds a loaded CI machine
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if not any(p.is_alive() for p in procs):
            return True
        time.sleep(0.05)
    return False


@pytest.mark.skipif(multiprocessing.get_start_method() != "fork", reason="forks a test helper")
def test_an_interrupted_pool_terminates_its_workers_and_what_it_started():
    """A KeyboardInterrupt leaving the pool: its busy workers and a process started while it
    was open (as a worker forked just after the signal, unknown to the pool) are terminated,
    instead of the pool waiting 600 s for their tasks."""
    stray = multiprocessing.Process(target=_sleep, args=(600,))
    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        with process_pool(2) as pool:
            futures = [pool.submit(_sleep, 600) for _ in range(2)]
            time.sleep(0.5)  # the workers have taken their tasks
            workers = list(pool._processes.values())
            stray.start()
            raise KeyboardInterrupt
    assert _gone([*workers, stray])
    assert time.monotonic() - start < 120  # never the 600 s of the tasks
    assert all(f.done() for f in futures)


def _console(script: str, tmp_path: Path) -> subprocess.Popen:
    path = tmp_path / "console.py"
    path.write_text(textwrap.dedent(script))
    env = subprocess_env()
    return subprocess.Popen([sys.executable, str(path)], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=tmp_path,
                            start_new_session=True)


HANGING = """
    import argparse, sys, time
    import bridgeflap.design.cli.run as r

    r.INTERRUPT_GRACE_S = {grace}

    def hang(args):
        try:  # the line inside: a signal that comes while it is written is in the try too
            print("running", flush=True)
            time.sleep(600)
        finally:  # a clean-up that never ends
            time.sleep(600)

    def parser(argv):
        p = argparse.ArgumentParser()
        p.set_defaults(command="hang", func=hang)
        return p

    sys.exit(r.run([], False, build_parser=parser, check_args=lambda a: None,
                   command_names=["hang"], bounded_interrupt={bounded}))
"""


@pytest.mark.parametrize("signum,status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_hanging_clean_up_ends_after_the_grace_time(tmp_path, signum, status):
    proc = _console(HANGING.format(grace=1.0, bounded=True), tmp_path)
    try:
        assert proc.stdout.readline().strip() == "running"
        sent = time.monotonic()
        os.killpg(proc.pid, signum)
        rc = proc.wait(timeout=120)  # the grace is 1 s; 120 s bounds a loaded machine
        took = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    err = proc.stderr.read()
    proc.stdout.close()
    proc.stderr.close()
    assert rc == status
    assert err.strip().splitlines() == ["bridgeflap: interrupted"], err
    assert took >= 1.0  # not before the grace: a clean-up in time runs to its end


def test_a_command_run_from_python_is_never_ended_by_the_watchdog(tmp_path):
    """Without ``bounded_interrupt`` (a call from Python, whose process goes on) nothing ends
    the process: still running well after the grace time."""
    proc = _console(HANGING.format(grace=0.2, bounded=False), tmp_path)
    try:
        assert proc.stdout.readline().strip() == "running"
        os.killpg(proc.pid, signal.SIGINT)
        with pytest.raises(subprocess.TimeoutExpired):
            proc.wait(timeout=3)  # 15 times the grace
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        proc.stdout.close()
        proc.stderr.close()
