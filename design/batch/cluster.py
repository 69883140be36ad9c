"""The Dask side of the batch runner :func:`bridgeflap.design.batch.runner.run_batch` (no physics,
no files).

:func:`cluster_client` gives a client on a local cluster or on a remote scheduler (reached
within :data:`CONNECT_TIMEOUT_S`, else one line naming ``scheduler``); :func:`run_dask` runs the
cases with at most one in flight per worker thread, retries cases whose worker died, and
abandons (and restarts the worker of) a case past its time limit. Local clusters listen on
random ports only: a batch never depends on a free well-known port (8787).

Local worker processes run a case at the in-process speed (:data:`LOCAL_WORKER_CONFIG`): glibc
malloc keeps its dynamic thresholds (distributed's default ``MALLOC_TRIM_THRESHOLD_=65536``
made every freed large NumPy array go back to the kernel, ~86,000 page faults and +45 % CPU
per flutter case) and distributed's statistical profiler is off (no dashboard shows it). The
environment variables the nannies set in this process to spawn their workers are restored
when the cluster closes.
"""

from __future__ import annotations

import asyncio
import contextlib
import copy
import logging
import os
import time
import uuid
from collections import deque

from bridgeflap.design.io.scratch import scratch_folder
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.workers import check_main_guard

__all__ = ["CONNECT_TIMEOUT_S", "LOCAL_WORKER_CONFIG", "LOCAL_WORKER_PRELOAD",
           "WORKERS_TIMEOUT_S", "cluster_client", "connect_scheduler", "probe_scheduler",
           "dask_setup", "run_dask"]

_POLL_S = 0.1
#: connect timeout to a remote Dask scheduler [s]: a dead address fails within this
CONNECT_TIMEOUT_S = 5.0
#: the largest handshake a Dask scheduler sends (a few hundred bytes; :func:`probe_scheduler`)
_HANDSHAKE_MAX_BYTES = 1 << 20
#: time the client's own connection may take past the connect timeout before it is given up
#: [s] (distributed's connect and handshake each get the timeout; a hang gets no more)
_CLIENT_GRACE_S = 2.0
#: how long a reachable remote scheduler may take to show its first worker [s]
WORKERS_TIMEOUT_S = 30.0
#: dask settings of a local cluster's workers, measured on the 64-case flutter DOE of
#: ``bench/doe.py`` (one worker, per case: bare 0.25 s CPU in-process vs 0.38 s in the worker):
#:
#: * ``MALLOC_TRIM_THRESHOLD_`` unset (``None``; a value set in this process's environment
#:   still applies): distributed sets 65536 before spawning a worker, and any such variable
#:   switches glibc's dynamic mmap/trim thresholds off, so every array above 128 KiB is
#:   mmap-ed and unmapped again: 86,500 minor page faults and 0.087 s system time per case,
#:   against 370 and 0.002 s in-process (and in the worker without it: 50 and 0.003 s);
#: * the statistical profiler off: it samples the task thread's stack every 10 ms on the
#:   worker's event-loop thread, holding the GIL; that thread's CPU during 17 cases was
#:   0.17 s with it, 0.08 s without (2 % of the cases' 4.4 s); nothing here reads profiles.
#:
#: Workers of a remote scheduler are started by their owner, with that owner's settings.
LOCAL_WORKER_CONFIG = {
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    "distributed.worker.profile.enabled": False,
}
#: local workers also preload this module (:func:`dask_setup`): they ignore SIGINT, so that a
#: Ctrl-C of the terminal (which signals the whole process group) prints no worker's
#: traceback; the client's process is interrupted and closes the cluster (design.cli.run)
LOCAL_WORKER_PRELOAD = {"distributed.worker.preload": ["bridgeflap.design.batch.cluster"]}


def dask_setup(worker=None) -> None:
    """Dask preload hook of a local worker (:data:`LOCAL_WORKER_CONFIG`): ignore SIGINT."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def cluster_client(workers: int, scheduler: str | None):
    """A dask client on a local cluster (``scheduler=None``) or on ``scheduler``; closed after.

    The local cluster listens on random ports only (scheduler port 0, no dashboard, its HTTP
    server on port 0), so a batch never depends on a free well-known port such as 8787 (a
    busy 8787 used to make distributed fall back with a warning and a leaked socket). A
    remote address must answer within :data:`CONNECT_TIMEOUT_S` and show a worker within
    :data:`WORKERS_TIMEOUT_S`, else one-line :class:`BridgeflapInputError` naming
    ``scheduler``; distributed's own connection log lines are silenced meanwhile.
    """
    import dask
    from dask.distributed import Client, LocalCluster

    cluster = None
    if scheduler is None:
        # even one worker is a spawned nanny that re-runs an unguarded script
        check_main_guard(max(2, workers),
                         dask.config.get("distributed.worker.multiprocessing-method", "spawn"))
        # allowed-failures 0: a worker death surfaces at once as KilledWorker, and retries
        # are ours (counted per case); saturation 1.0 keeps at most one task per worker thread,
        # so a dying worker takes no innocent queued case with it.
        settings = {
            "distributed.scheduler.allowed-failures": 0,
            "distributed.scheduler.worker-saturation": 1.0,
            **LOCAL_WORKER_CONFIG,
            **LOCAL_WORKER_PRELOAD,
        }
        # the nannies write their pre-spawn variables (and PYTHONHASHSEED) into os.environ
        # before each worker start; restored after the cluster closes
        saved_env = {k: os.environ.get(k) for k in
                     (*dask.config.get("distributed.nanny.pre-spawn-environ"), "PYTHONHASHSEED")}
        # the workers' scratch space (dask-scratch-space) in a folder of this run, removed
        # when the cluster closes; one left by a killed run is removed by the next
        scratch = contextlib.ExitStack()
        local_directory = scratch.enter_context(scratch_folder("dask"))
        try:
            with dask.config.set({**settings, "temporary-directory": str(local_directory)}):
                cluster = LocalCluster(
                    local_directory=str(local_directory),
                    n_workers=workers,
                    threads_per_worker=1,
                    processes=True,
                    scheduler_port=0,
                    # no dashboard; the scheduler's HTTP server (health/metrics routes) starts
                    # even without one, on the default port 8787 unless told otherwise: port 0
                    dashboard_address=None,
                    scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
                    worker_dashboard_address=None,
                    silence_logs=logging.CRITICAL,
                    # the workers' dask config, a copy: a nanny keeps only a shallow one of
                    # the global config, which the end of this ``config.set`` reverts, so a
                    # restarted worker (an abandoned case) would run with the defaults again
                    config=copy.deepcopy(dask.config.config),
                )
                try:
                    client = Client(cluster)
                except BaseException:
                    cluster.close()
                    raise
        except BaseException:
            _restore_environ(saved_env)
            scratch.close()
            raise
    else:
        client = connect_scheduler(scheduler)
        try:
            client.wait_for_workers(1, timeout=WORKERS_TIMEOUT_S)
        except (OSError, TimeoutError, asyncio.TimeoutError):
            client.close()
            raise BridgeflapInputError(
                "scheduler", f"{scheduler} has no worker after {WORKERS_TIMEOUT_S:g} s") from None
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
            _restore_environ(saved_env)
            scratch.close()


def _refused(scheduler: str, reason: str) -> BridgeflapInputError:
    return BridgeflapInputError("scheduler", f"{scheduler}: {reason}")


def _host_port(scheduler: str) -> tuple[str, int] | None:
    """``(host, port)`` of a plain-TCP address (``tcp://host:port`` or ``host:port``); None
    for another protocol (``tls://``, ``ws://``, ``inproc://``), which is not probed."""
    text = scheduler.strip()
    if "://" in text:
        protocol, _, text = text.partition("://")
        if protocol.lower() != "tcp":
            return None
    text = text.split("/", 1)[0]
    host, sep, port = text.rpartition(":") if text.count(":") == 1 or "]:" in text else (
        text, "", "8786")  # Dask's default port when none is given
    host = host.strip("[]")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise BridgeflapInputError("scheduler", f"{scheduler!r} is not a Dask scheduler address "
                                                "such as tcp://host:8786 (or 'local')")
    return host, int(port)


def _recv_exactly(sock, n: int, deadline: float) -> bytes:
    data = bytearray()
    while len(data) < n:
        left = deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError
        sock.settimeout(left)
        chunk = sock.recv(n - len(data))  # socket.timeout is TimeoutError
        if not chunk:
            raise ConnectionError("closed the connection")
        data += chunk
    return bytes(data)


def probe_scheduler(scheduler: str, timeout_s: float = CONNECT_TIMEOUT_S) -> None:
    """Raise one line naming ``scheduler`` unless a Dask scheduler answers at its address
    within ``timeout_s``.

    A Dask scheduler speaks first: on a new TCP connection it sends its handshake, one framed
    message (an 8-byte length, then the frame count and each frame's length, 8 bytes each, then
    the frames). The probe reads that message under a hard deadline and checks its framing, so
    a server that accepts and never answers (a hang in distributed), or one that speaks
    another protocol (an HTTP server's reply read as a length of exabytes: a MemoryError in
    distributed) is refused here, before distributed reads anything. Addresses of other
    protocols than TCP are left to distributed (:func:`connect_scheduler`'s deadline).
    """
    import socket
    import struct

    where = _host_port(scheduler)
    if where is None:
        return
    deadline = time.monotonic() + timeout_s
    try:
        with socket.create_connection(where, timeout=timeout_s) as sock:
            (total,) = struct.unpack("<Q", _recv_exactly(sock, 8, deadline))
            if not 16 <= total <= _HANDSHAKE_MAX_BYTES:
                raise _refused(scheduler, "answers, but not as a Dask scheduler (another "
                                          "service listens there)")
            body = _recv_exactly(sock, total, deadline)
    except TimeoutError:
        raise _refused(scheduler, f"no Dask scheduler answered within {timeout_s:g} s") from None
    except OSError as exc:  # refused, unreachable, reset, a name that does not resolve
        reason = " ".join(str(exc.strerror or exc).split())[:200] or type(exc).__name__
        raise _refused(scheduler, f"cannot connect within {timeout_s:g} s ({reason})") from None
    (frames,) = struct.unpack_from("<Q", body)
    sizes = (struct.unpack_from(f"<{frames}Q", body, 8)
             if 1 <= frames <= 64 and 8 + 8 * frames <= total else None)
    if sizes is None or 8 + 8 * frames + sum(sizes) != total:
        raise _refused(scheduler, "answers, but not as a Dask scheduler (another service "
                                  "listens there)")


def connect_scheduler(scheduler: str, timeout_s: float = CONNECT_TIMEOUT_S):
    """A :class:`dask.distributed.Client` of the Dask scheduler at ``scheduler``, or one line
    naming ``scheduler`` within about ``timeout_s`` (:func:`probe_scheduler` first, then the
    client's own connection under a hard deadline: whatever distributed raises, MemoryError
    included, or a connection that never completes, is that one line).

    distributed's own connection log lines are silenced meanwhile.
    """
    import threading

    from dask.distributed import Client

    deadline = time.monotonic() + timeout_s
    probe_scheduler(scheduler, timeout_s)
    left = max(1.0, deadline - time.monotonic())  # a scheduler answers the probe at once
    loggers = [logging.getLogger(n) for n in ("distributed", "tornado", "asyncio")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL)
    box: dict = {}
    lock = threading.Lock()

    def connect():
        try:
            client = Client(scheduler, timeout=f"{left:.3f}s")
        except BaseException as exc:  # noqa: BLE001 - every failure becomes one line below
            box["error"] = exc
            return
        with lock:
            late = box.get("late", False)
            if not late:
                box["client"] = client
        if late:  # the deadline passed meanwhile: nobody will use this client
            client.close()

    thread = threading.Thread(target=connect, name="bridgeflap-scheduler-connect", daemon=True)
    try:
        thread.start()
        thread.join(left + _CLIENT_GRACE_S)
        with lock:
            box["late"] = "client" not in box and "error" not in box
        if box["late"]:
            raise _refused(scheduler, f"no Dask scheduler answered within {timeout_s:g} s")
    finally:
        for lg, level in zip(loggers, levels, strict=True):
            lg.setLevel(level)
    exc = box.get("error")
    if exc is not None:
        if isinstance(exc, KeyboardInterrupt):
            raise exc
        reason = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise _refused(scheduler, f"cannot connect within {timeout_s:g} s "
                                  f"({type(exc).__name__}: {reason})") from None
    return box["client"]


def _restore_environ(saved: dict) -> None:
    """Put back the environment variables in ``saved`` (``None``: it was not set)."""
    for key, value in saved.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value


def run_dask(client, fn, pending, workers, scheduler, timeout_s, retries, finish) -> None:
    """Run the cases on a Dask cluster with at most one case in flight per worker thread;
    ``finish(record)`` is called as each case ends
    (:func:`bridgeflap.design.batch.runner.run_batch`).

    One case per thread, not more: a second one submitted ahead would not wait on the
    scheduler (single tasks are not "root-ish", so distributed's queueing does not hold them
    back) but on the worker, and a dying worker would take it along. The round trip between a
    case's end and the next one's start is kept short instead: the next case is submitted as
    soon as one is seen done, before its result is fetched, and ``finish`` only queues the
    case's file for a writer thread (:func:`bridgeflap.design.batch.runner.run_batch`).
    """
    from dask.distributed import wait

    from bridgeflap.design.batch.case import (
        STATUS_FAILED,
        _execute_case,
        _record,
        _timeout_record,
    )

    token = uuid.uuid4().hex[:8]
    queue = deque((case_id, params, 0) for case_id, params in pending)
    in_flight: dict = {}  # future -> (case_id, params, attempt, submitted_at)
    try:
        capacity = max(1, sum(client.nthreads().values())) if scheduler else workers

        def submit(case_id, params, attempt):
            future = client.submit(
                _execute_case,
                fn,
                case_id,
                params,
                key=f"bridgeflap-{token}-{case_id}-{attempt}",
                pure=False,
                retries=0,
            )
            in_flight[future] = (case_id, params, attempt, time.monotonic())

        while queue or in_flight:
            while queue and len(in_flight) < capacity:
                submit(*queue.popleft())
            try:
                done, _ = wait(list(in_flight), timeout=_POLL_S, return_when="FIRST_COMPLETED")
            except (TimeoutError, asyncio.TimeoutError):
                done = set()
            ended = []
            for future in done:
                case_id, params, attempt, submitted = in_flight.pop(future)
                ended.append((future, case_id, params, attempt, time.monotonic() - submitted))
                if future.status != "finished" and attempt < retries:
                    queue.appendleft((case_id, params, attempt + 1))
            # the freed worker threads get their next cases before any result travels back
            while queue and len(in_flight) < capacity:
                submit(*queue.popleft())
            for future, case_id, params, attempt, elapsed in ended:
                if future.status == "finished":
                    finish(future.result())
                elif attempt >= retries:
                    finish(_record(case_id, params, STATUS_FAILED, _future_error(future), None,
                                   elapsed))
            if timeout_s is None:
                continue
            now = time.monotonic()
            late = [f for f, (*_, submitted) in in_flight.items() if now - submitted > timeout_s]
            for future in late:
                case_id, params, _, submitted = in_flight.pop(future)
                elapsed = time.monotonic() - submitted
                _abandon(client, future)
                finish(_timeout_record(case_id, params, timeout_s, elapsed))
    finally:
        for future in in_flight:
            future.cancel()


def _future_error(future) -> str:
    """One-line reason why a future did not finish (worker died, cancelled, ...)."""
    if future.status == "cancelled":
        return "worker task cancelled (scheduler or worker lost)"
    try:
        exc = future.exception(timeout=5)
    except Exception as err:  # noqa: BLE001 - any failure to fetch the reason is itself a reason
        from bridgeflap.design.batch.case import _error_text

        return _error_text(err)
    if exc is None:
        return f"worker task ended with status {future.status}"
    name = type(exc).__name__
    if name == "KilledWorker":
        return "worker process died while running the case (KilledWorker)"
    from bridgeflap.design.batch.case import _error_text

    return _error_text(exc)


def _abandon(client, future) -> None:
    """Stop a case that ran past its time limit: cancel it and restart its worker process."""
    key = future.key
    try:
        processing = client.processing()
    except Exception:  # noqa: BLE001 - best effort; the case is recorded as timeout anyway
        processing = {}
    addresses = [addr for addr, keys in processing.items() if key in keys]
    future.cancel()
    if addresses:
        try:
            client.restart_workers(addresses, timeout=60, raise_for_error=False)
        except Exception:  # noqa: BLE001 - e.g. a remote worker without a nanny
            pass
