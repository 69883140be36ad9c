"""Ctrl-C and SIGTERM during an Ipopt solve end it
(bridgeflap.design.control.formulation.ipopt_hooks).

Without the deferral a KeyboardInterrupt raised inside one of CasADi's Python callbacks was
caught by CasADi and the solve went on to a design (6 of 9 signals lost in a measured run).
No physics here: the checks are on counts and exceptions, no tolerances.
"""

from __future__ import annotations

import argparse
import os
import signal

import numpy as np
import pytest

from bridgeflap.design.cli.run import run
from bridgeflap.design.control.formulation.ipopt_hooks import signals_deferred, stop_requested
from bridgeflap.design.control.formulation.nlp import DesignProblem
from bridgeflap.design.control.search.driver import build_model
from bridgeflap.design.control.settings import load_settings


@pytest.fixture(scope="module")
def small():
    # Humber, 6 modes, 5 flap pairs: the design's code path on small matrices
    s = load_settings(None, n_modes=6, flap_count=5, robust_design_speeds_m_s=(30.0, 60.0),
                      n_robust_omega=8, max_iter=60)
    return s, build_model(s)[1]


_SCRIPT = """
import os, signal, sys
import numpy as np
from bridgeflap.design.control.search.driver import build_model
from bridgeflap.design.control.formulation.ipopt_hooks import stop_requested
from bridgeflap.design.control.formulation.nlp import DesignProblem
from bridgeflap.design.control.settings import load_settings

# Python's own Ctrl-C handler, whatever disposition this process inherited (a pytest-xdist
# worker ignores SIGINT, and so would its children)
signal.signal(signal.SIGINT, signal.default_int_handler)
s = load_settings(None, n_modes=6, flap_count=5, robust_design_speeds_m_s=(30.0, 60.0),
                  n_robust_omega=8, max_iter=60)
prob = DesignProblem(s, build_model(s)[1])
seen = []
signum = int(sys.argv[1])

def tick(i, f, x):
    seen.append(i)
    if len(seen) == 3:
        os.kill(os.getpid(), signum)

prob.on_iteration = tick
try:
    prob.solve(np.array([0.0, 0.5, -1.0, 0.05, 0.5]), [0.0, 40.0, 80.0])
    print("returned", len(seen))
except KeyboardInterrupt:
    print("interrupted", len(seen), signal.getsignal(signal.SIGINT) is signal.default_int_handler,
          stop_requested())
"""


def _run_script(signum):
    """The solve in a fresh interpreter's main thread (a pytest-xdist worker may run tests
    where no signal handler can be set)."""
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", _SCRIPT, str(int(signum))],
                          capture_output=True, text=True, timeout=600,
                          env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    return proc.stdout.strip().splitlines()[-1:] or [proc.stderr[-2000:]]


def test_ctrl_c_during_a_solve_raises_and_stops_ipopt_at_the_next_iteration():
    out = _run_script(signal.SIGINT)
    # the solve raised (no Solve returned), the handler is back, no stop pending; the signal
    # arrived inside iteration 3's callback and Ipopt stopped at the next one (the callback
    # returns before calling tick again): 3 iterations seen
    assert out == ["interrupted 3 True False"], out


def _solve_signalled(small, signum, at=3):
    s, model = small
    prob = DesignProblem(s, model)
    seen = []

    def tick(i, f, x):
        seen.append(i)
        if len(seen) == at:
            os.kill(os.getpid(), signum)

    prob.on_iteration = tick
    prob.solve(np.array([0.0, 0.5, -1.0, 0.05, 0.5]), [0.0, 40.0, 80.0])
    return seen


def test_sigterm_during_a_solve_ends_the_command_with_143(small, capsys):
    import threading

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signal handlers can be set in the main thread only")

    def command(args):
        _solve_signalled(small, signal.SIGTERM)
        return 0          # never reached: the solve must not return a design

    def build_parser(argv):
        parser = argparse.ArgumentParser()
        parser.set_defaults(command="optimise", func=command)
        return parser

    rc = run([], False, build_parser=build_parser, check_args=lambda a: None,
             command_names=["optimise"])
    assert rc == 128 + signal.SIGTERM
    assert capsys.readouterr().err.strip().splitlines() == ["bridgeflap: interrupted"]


def test_an_ignored_signal_stays_ignored():
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with signals_deferred():
            assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGINT)
            assert not stop_requested()        # nothing held: the solve goes on
        assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)


def test_nested_blocks_deliver_once_at_the_outermost():
    got = []
    previous = signal.signal(signal.SIGINT, lambda n, f: got.append(n))
    try:
        with pytest.raises(KeyboardInterrupt):   # a handler that returns: still no design
            with signals_deferred():
                with signals_deferred():
                    os.kill(os.getpid(), signal.SIGINT)
                    assert stop_requested() and got == []
                assert stop_requested() and got == []   # handed to the enclosing block
        assert got == [signal.SIGINT]
    finally:
        signal.signal(signal.SIGINT, previous)


@pytest.mark.slow
@pytest.mark.parametrize("signum,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_during_optimise_ends_it_and_writes_nothing(tmp_path, signum, code):
    """`bridgeflap optimise` signalled while Ipopt runs: the exit status of the signal, the one
    line, no controller and the previous output untouched. The signal is sent once the first
    Ipopt progress line is printed (so it lands inside a solve, where it was lost before)."""
    import subprocess
    import sys
    import time

    out = tmp_path / "opt"
    out.mkdir()
    (out / "keep.txt").write_text("an earlier result")
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "MPLBACKEND": "Agg"}
    proc = subprocess.Popen([sys.executable, "-m", "bridgeflap.design.cli.main", "optimise",
                             "--quick", "--checks", "none", "--out", str(tmp_path / "new")],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    for line in proc.stderr:        # progress lines: wait for the first Ipopt iteration
        if "Ipopt running" in line or time.monotonic() - t0 > 300:
            break
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == code, err[-2000:]
    assert err.strip().splitlines()[-1] == "bridgeflap: interrupted"
    assert not (tmp_path / "new" / "controller.toml").exists()
    assert (out / "keep.txt").read_text() == "an earlier result"
