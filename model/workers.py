"""The ``if __name__ == "__main__":`` guard that a script starting worker processes needs.

A worker process started by the *spawn* (or *forkserver*) method re-imports the script that
started it, as ``__mp_main__``, to find its functions. A script whose batch call is not under
``if __name__ == "__main__":`` therefore runs the batch again in every worker: there it finds
the output folder locked ("lock held") and its own workers failing to start ("Nanny failed to
start"), errors that do not say what is wrong. Dask's local cluster always spawns; a
``ProcessPoolExecutor`` does so where spawn is the default start method (macOS, Windows; Linux
from Python 3.14 uses forkserver).

:func:`check_main_guard` is called by every public function that starts local worker processes,
before it starts them. It raises one line, :class:`~bridgeflap.model.errors.BridgeflapInputError`
naming ``workers``, when

* this process is itself such a re-import (``multiprocessing``'s bootstrapping flag, the one
  behind its own "An attempt has been made to start a new process" error), or
* the call comes from the top level of a script file run as ``__main__`` and the statement
  running there lies outside any ``if __name__ == "__main__":`` block (read from the script's
  source with :mod:`ast`; a notebook cell, the interactive prompt or a frozen program has no
  script file and is not checked).

:func:`process_pool` is the package's one process-pool mechanism: every local pool of worker
processes (the design's parallel starts and follow-up checks, the layout neighbours, the flap
counts, do-no-harm, fail-safe, erection stages, a study's analyses) is made by it, so that none
skips the guard. It checks the guard before any process starts, keeps the platform's default
start method (no package-wide context is set: fork on Linux up to Python 3.13), makes every
worker end with the process that started it (:func:`_die_with_parent`), gives every worker one
BLAS thread, or the thread count the user chose up to the cores shared among the workers
(:func:`_one_blas_thread`), and starts at least one worker. Dask
(:mod:`bridgeflap.design.batch.cluster`) is for DOE batches only.

On an interrupt (a :class:`KeyboardInterrupt` leaving the pool's ``with`` block, or a shutdown
after :func:`note_interrupt`, which the command line calls on Ctrl-C and SIGTERM) the pool
terminates its worker processes before it waits for them, and with them every process
started while it was open (a worker forked just after the terminal's signal went out, not yet
registered with the pool, would otherwise wait for work forever and the interpreter's exit
with it).
"""

from __future__ import annotations

import ast
import functools
import multiprocessing
import os
import sys
import threading
from concurrent.futures import ProcessPoolExecutor

from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["MAIN_GUARD_REASON", "check_main_guard", "clear_interrupt", "note_interrupt",
           "process_pool"]

_INTERRUPTED = threading.Event()


def note_interrupt() -> None:
    """Record that this process was interrupted (Ctrl-C, SIGTERM): pools shut down from now on
    terminate their workers instead of waiting for their tasks. Called by the command line's
    signal handler; an ``Event.set``, no process is touched here."""
    _INTERRUPTED.set()


def clear_interrupt() -> None:
    """Forget :func:`note_interrupt` (a command run from Python ended; its process goes on)."""
    _INTERRUPTED.clear()


class _Pool(ProcessPoolExecutor):
    """:class:`ProcessPoolExecutor` that terminates its workers when interrupted (module doc)."""

    def __init__(self, *args, **kwargs):
        self._before = set(multiprocessing.active_children())  # Process objects, by identity
        super().__init__(*args, **kwargs)

    def _terminate_workers(self) -> None:
        ours = set((getattr(self, "_processes", None) or {}).values())
        ours.update(p for p in multiprocessing.active_children() if p not in self._before)
        for proc in ours:
            try:
                proc.terminate()
            except (OSError, AttributeError, ValueError):  # already gone or closed
                pass

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        if _INTERRUPTED.is_set():
            self._terminate_workers()
        super().shutdown(wait=wait, cancel_futures=cancel_futures)

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None and issubclass(exc_type, KeyboardInterrupt):
            self._terminate_workers()
        return super().__exit__(exc_type, exc, tb)


#: the reason of the one-line error
MAIN_GUARD_REASON = ("this script starts worker processes, which re-run it: put its code under "
                     "if __name__ == '__main__': (docs: multiprocessing 'safe importing of the "
                     "main module') or use workers=1")


def _is_main_test(test: ast.expr) -> bool:
    """``__name__ == "__main__"`` (either way round)."""
    if not (isinstance(test, ast.Compare) and len(test.ops) == 1
            and isinstance(test.ops[0], ast.Eq)):
        return False
    sides = (test.left, test.comparators[0])
    names = [s.id for s in sides if isinstance(s, ast.Name)]
    texts = [s.value for s in sides if isinstance(s, ast.Constant)]
    return names == ["__name__"] and texts == ["__main__"]


@functools.lru_cache(maxsize=8)
def _guarded_lines(path: str, mtime: float) -> tuple[tuple[int, int], ...] | None:
    """Line ranges of the top-level ``if __name__ == "__main__":`` blocks of ``path`` (None
    when it cannot be read or parsed)."""
    try:
        with open(path, encoding="utf-8") as f:
            tree = ast.parse(f.read(), path)
    except (OSError, SyntaxError, ValueError):
        return None
    return tuple((node.lineno, node.end_lineno or node.lineno) for node in tree.body
                 if isinstance(node, ast.If) and _is_main_test(node.test))


def _unguarded_top_level_call() -> bool:
    """The call stack starts in a script's top-level statement outside a main guard."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if not path or not os.path.isfile(path):
        return False
    path = os.path.realpath(path)
    frame, top = sys._getframe(1), None
    while frame is not None:  # the outermost frame running the script's module code
        if (frame.f_code.co_name == "<module>"
                and os.path.realpath(frame.f_code.co_filename) == path):
            top = frame
        frame = frame.f_back
    if top is None:
        return False
    guarded = _guarded_lines(path, os.path.getmtime(path))
    if guarded is None:
        return False
    return not any(lo <= top.f_lineno <= hi for lo, hi in guarded)


def check_main_guard(workers: int, start_method: str | None = None) -> None:
    """Raise the one-line guard error before ``workers`` > 1 local processes are started.

    Parameters
    ----------
    workers : int
        Worker processes about to be started (nothing is checked for 1 or fewer: a caller
        that starts one spawned process, a Dask nanny or a pool of one, passes at least 2).
    start_method : str, optional
        How they start: ``"spawn"`` (Dask's nannies), ``"forkserver"`` or ``"fork"``; default
        the ``multiprocessing`` default of this platform. A forked worker does not re-import
        the script, so nothing is checked then.

    Raises
    ------
    BridgeflapInputError
        ``workers``: :data:`MAIN_GUARD_REASON`.
    """
    if int(workers) <= 1:
        return
    if getattr(multiprocessing.current_process(), "_inheriting", False):
        raise BridgeflapInputError("workers", MAIN_GUARD_REASON)  # a worker re-running it
    method = start_method or multiprocessing.get_start_method(allow_none=True) or \
        multiprocessing.get_context().get_start_method()
    if method != "fork" and _unguarded_top_level_call():
        raise BridgeflapInputError("workers", MAIN_GUARD_REASON)


def process_pool(workers: int, *, die_with_parent: bool = True) -> ProcessPoolExecutor:
    """The package's process pool of ``workers`` local processes (the module docstring).

    Parameters
    ----------
    workers : int
        ``max_workers`` of the pool (at least 1 is used).
    die_with_parent : bool
        The workers end with this process (:func:`_die_with_parent`; default). Every worker
        uses one BLAS thread, or the count the user set up to its share of the cores
        (:func:`_one_blas_thread`).

    Returns
    -------
    concurrent.futures.ProcessPoolExecutor
        Started on the platform's default start method; a context manager as usual.

    Raises
    ------
    BridgeflapInputError
        ``workers``: :data:`MAIN_GUARD_REASON` (:func:`check_main_guard`), before any process
        starts; checked for every pool, one worker included (a spawned worker re-runs the
        script whatever the pool's size).
    """
    check_main_guard(max(2, int(workers)))  # even one spawned worker re-runs the script
    n = max(1, int(workers))
    return _Pool(max_workers=n, initializer=_worker_start,
                 initargs=(os.getpid() if die_with_parent else None, _worker_blas_cap(n)))


#: The BLAS thread variables a user sets to choose the threads; with none set, a worker of the
#: package's pools uses one BLAS thread (:func:`_one_blas_thread`).
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _worker_blas_cap(workers: int) -> int:
    """BLAS threads a worker of a pool of ``workers`` may use when the user set a thread count:
    the cores this process may run on, shared among the workers (at least 1)."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    return max(1, cores // max(1, int(workers)))


def _worker_start(parent: int | None, cap: int | None = None) -> None:
    """Pool initializer: one BLAS thread (:func:`_one_blas_thread`), and with ``parent`` the
    worker ends with it (:func:`_die_with_parent`)."""
    _one_blas_thread(cap)
    if parent is not None:
        _die_with_parent(parent)


def _one_blas_thread(cap: int | None = None) -> None:
    """One BLAS thread in a worker process, unless the user set a thread variable; then the
    user's count, but at most ``cap`` (:func:`_worker_blas_cap`: the cores shared among the
    pool's workers).

    The matrices are small (at most a few hundred rows) and the pool already runs one task per
    core: a worker with the library's default thread count (one per core) puts
    ``workers x cores`` spinning threads on the cores. Measured on a 2-core machine, one
    fixed-layout design of the placement search (``evaluate_layout``, quick card): 25.7 s
    alone, 85 s each when two workers ran at once with 2 BLAS threads each, 24 s each with 1.
    The command line already runs with one thread (``design.cli.main``); this gives a script
    calling the API the same workers. The calling process is left alone (library code never
    sets the user's environment); only the worker's own BLAS pool is limited.

    A count the user set is a budget for the machine, not for each worker: with
    ``OPENBLAS_NUM_THREADS=2`` on 2 cores the two check workers of ``bridgeflap optimise
    --workers 2`` kept two threads each, and the default card's run had not finished after 22
    minutes (2 min 41 s with one thread each). A worker now keeps the user's count up to the
    cores divided among the workers.
    """
    try:
        from threadpoolctl import threadpool_info, threadpool_limits
    except ImportError:  # pragma: no cover - a dependency (pyproject.toml)
        return
    if not any(v in os.environ for v in THREAD_VARIABLES):
        threadpool_limits(1, user_api="blas")
        return
    if cap is not None:
        have = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
        if have and max(have) > cap:
            threadpool_limits(int(cap), user_api="blas")


def _die_with_parent(parent: int) -> None:
    """Pool initializer: the worker ends with the process that started it, even one killed by
    SIGKILL (Linux ``PR_SET_PDEATHSIG``), so that no orphan writes into a folder a later run
    has claimed (elsewhere the pool's own broken-pipe handling ends it after its task). Linux
    sends the signal when the *thread* that started the worker ends: submit to the pool from
    a thread that outlives it (every caller in the package does)."""
    import signal

    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # 1 = PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux
        pass
    if os.getppid() != parent:  # the parent ended before the line above
        os._exit(1)
