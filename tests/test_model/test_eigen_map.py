"""model.spectrum.eigen_map: the per-speed eigen-decompositions in threads give the serial
loop's results, bit for bit and in order; serial where threads would not help."""

from __future__ import annotations

import threading
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest
import scipy.linalg

from bridgeflap.model import spectrum
from bridgeflap.model.spectrum import eigen_map


def _mats(n=12, size=60):
    rng = np.random.default_rng(3)
    return [rng.standard_normal((size, size)) for _ in range(n)]


def test_threads_give_the_serial_results_bit_for_bit(monkeypatch):
    # each call computes what the serial loop computes (one LAPACK call on the same data, one
    # BLAS thread): no tolerance
    mats = _mats()
    monkeypatch.setenv("BRIDGEFLAP_EIG_THREADS", "1")
    serial = eigen_map(scipy.linalg.eigvals, mats)
    monkeypatch.setenv("BRIDGEFLAP_EIG_THREADS", "2")
    names = set()

    def eig(a):
        names.add(threading.current_thread().name)
        return scipy.linalg.eigvals(a)

    threaded = eigen_map(eig, mats)
    assert len(threaded) == len(serial)
    for a, b in zip(serial, threaded, strict=True):
        np.testing.assert_array_equal(a, b)
    # the test can fail: it ran in the pool's threads when the machine has two cores
    if spectrum._eig_threads() > 1:
        assert names and all(n.startswith("bridgeflap-eig") for n in names)
    # no thread outlives the call (a later fork starts from one thread)
    assert not any(t.name.startswith("bridgeflap-eig") for t in threading.enumerate())


def test_few_tasks_and_nested_calls_run_in_turn(monkeypatch):
    monkeypatch.setenv("BRIDGEFLAP_EIG_THREADS", "2")
    here = threading.current_thread().name
    seen = eigen_map(lambda _: threading.current_thread().name,
                     range(spectrum.EIG_MAP_MIN_TASKS - 1))
    assert set(seen) == {here}
    inner = eigen_map(lambda _: set(eigen_map(lambda __: threading.current_thread().name,
                                              range(8))), range(8))
    for names in inner:         # each nested map ran in its caller's thread
        assert len(names) == 1


def _threads_in_worker(_):
    return spectrum._eig_threads()


@pytest.mark.parametrize("bad", ["0", "-3", "two"])
def test_the_thread_count_setting_is_bounded(monkeypatch, bad):
    monkeypatch.setenv("BRIDGEFLAP_EIG_THREADS", bad)
    assert 1 <= spectrum._eig_threads() <= 2


def test_a_worker_process_runs_them_in_turn():
    with ProcessPoolExecutor(1) as ex:
        assert ex.submit(_threads_in_worker, 0).result() == 1
