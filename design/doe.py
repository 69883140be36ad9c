"""Designs of experiments and a fault-tolerant batch runner (METHODS.md section 7).

This module knows no physics. A *case* is a flat dict of parameters with a ``case_id``; an
*analysis* is a picklable function ``fn(params: dict) -> dict`` (defined at module level)
returning JSON-serialisable numbers and strings. :func:`run_batch` runs the analysis on every
case, each in a separate worker process, and writes one result file per case as soon as it
finishes, so that an interrupted batch resumes without recomputing finished cases.

Failure is data: a case whose function raises, whose worker process dies, or which runs past
its time limit becomes a row with ``status`` ``"failed"`` or ``"timeout"`` and a one-line error
text; the batch always completes.

Output layout of ``run_batch(..., out_dir)``::

    out_dir/
      cases/<case_id>.json   one per case: {case_id, params, status, error, result, elapsed_s}
      table.csv              one row per case: case_id, status, params..., results..., elapsed_s,
                             error
      batch.json             summary: {cases, succeeded, failed, timed_out, reused, table, ...}

All three are written atomically (:mod:`design.io`). Non-finite numbers are stored as JSON
``null`` and as empty CSV cells.
"""

from __future__ import annotations

import asyncio
import csv
import inspect
import io
import itertools
import json
import logging
import math
import os
import signal
import sys
import threading
import time
import uuid
import warnings
from collections import deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from design.io import atomic_write_json, atomic_write_text, ensure_writable_dir, to_jsonable
from model.errors import BridgeflapInputError

__all__ = [
    "BatchResult",
    "DESIGN_KINDS",
    "full_factorial",
    "latin_hypercube",
    "make_design",
    "run_batch",
    "sobol",
]

STATUS_OK = "ok"
STATUS_FAILED = "failed"
STATUS_TIMEOUT = "timeout"
_CASE_ID_KEY = "case_id"
_CASE_ID_CHARS = frozenset("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789._-")
_POLL_S = 0.1


# --------------------------------------------------------------------------------------------
# designs
# --------------------------------------------------------------------------------------------
def _case_ids(n: int) -> list[str]:
    """Stable, sortable ids ``case-0000`` ... (at least four digits)."""
    width = max(4, len(str(n - 1)))
    return [f"case-{i:0{width}d}" for i in range(n)]


def _check_name(name: Any, field: str) -> None:
    if not isinstance(name, str) or not name:
        raise BridgeflapInputError(
            field, f"parameter names must be non-empty strings, got {name!r}"
        )
    if name == _CASE_ID_KEY:
        raise BridgeflapInputError(field, f"{_CASE_ID_KEY!r} is reserved and cannot be a parameter")


def _check_n(n: Any) -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise BridgeflapInputError("n", f"number of cases must be an integer, got {n!r}")
    if n < 1:
        raise BridgeflapInputError("n", f"number of cases must be at least 1, got {n}")
    return int(n)


def _check_seed(seed: Any) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise BridgeflapInputError("seed", f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def _check_ranges(ranges: Any) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Validate ``{name: (lo, hi)}``; return names, lower and upper bounds."""
    if not isinstance(ranges, Mapping) or not ranges:
        raise BridgeflapInputError("ranges", "at least one parameter range {name: (lo, hi)} needed")
    names, lows, highs = [], [], []
    for name, bounds in ranges.items():
        field = f"ranges.{name}"
        _check_name(name, field)
        try:
            lo, hi = (float(b) for b in bounds)
        except (TypeError, ValueError):
            raise BridgeflapInputError(field, f"expected (lo, hi), got {bounds!r}") from None
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise BridgeflapInputError(field, f"bounds must be finite, got ({lo}, {hi})")
        if lo >= hi:
            raise BridgeflapInputError(field, f"lower bound {lo} must be below upper bound {hi}")
        names.append(name)
        lows.append(lo)
        highs.append(hi)
    return names, np.array(lows), np.array(highs)


def _rng_kwarg(engine: type, seed: int) -> dict:
    """Seed keyword of a ``scipy.stats.qmc`` engine (``rng`` from SciPy 1.15, else ``seed``)."""
    generator = np.random.default_rng(seed)
    params = inspect.signature(engine).parameters
    return {"rng": generator} if "rng" in params else {"seed": generator}


def _scaled_cases(names: list[str], unit: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list:
    points = lo + unit * (hi - lo)
    # rounding in lo + u*(hi - lo) may step a hair outside [lo, hi]; clip to the stated bounds
    points = np.clip(points, lo, hi)
    return [
        {_CASE_ID_KEY: cid, **{name: float(v) for name, v in zip(names, row, strict=True)}}
        for cid, row in zip(_case_ids(len(points)), points, strict=True)
    ]


def full_factorial(levels: Mapping[str, Sequence]) -> list[dict]:
    """All combinations of the given parameter levels.

    Parameters
    ----------
    levels : mapping of str to sequence
        Parameter name -> its levels (any JSON-serialisable values, in the parameter's unit).

    Returns
    -------
    list of dict
        ``prod(len(v))`` cases ``{"case_id": "case-0000", name: level, ...}``; the last
        parameter varies fastest (``itertools.product`` order), so ids are stable for a given
        ``levels``.
    """
    if not isinstance(levels, Mapping) or not levels:
        raise BridgeflapInputError("levels", "at least one parameter with its levels needed")
    names, values = [], []
    for name, vals in levels.items():
        _check_name(name, f"levels.{name}")
        if isinstance(vals, (str, bytes)) or not isinstance(vals, Iterable):
            raise BridgeflapInputError(f"levels.{name}", f"expected a list of levels, got {vals!r}")
        vals = list(vals)
        if not vals:
            raise BridgeflapInputError(f"levels.{name}", "no levels given")
        names.append(name)
        values.append(vals)
    combos = list(itertools.product(*values))
    return [
        {_CASE_ID_KEY: cid, **dict(zip(names, combo, strict=True))}
        for cid, combo in zip(_case_ids(len(combos)), combos, strict=True)
    ]


def latin_hypercube(ranges: Mapping[str, tuple[float, float]], n: int, seed: int) -> list[dict]:
    """Latin hypercube sample of ``n`` cases in a box.

    Parameters
    ----------
    ranges : mapping of str to (float, float)
        Parameter name -> (lower, upper) bound, in the parameter's unit; lower < upper.
    n : int
        Number of cases (>= 1).
    seed : int
        Seed of the random generator; the same seed gives the same cases.

    Returns
    -------
    list of dict
        ``n`` cases; in every parameter each of the ``n`` equal strata of [lo, hi] holds
        exactly one case.

    Notes
    -----
    Uses :class:`scipy.stats.qmc.LatinHypercube` (McKay, Beckman & Conover 1979).
    """
    from scipy.stats import qmc

    names, lo, hi = _check_ranges(ranges)
    n = _check_n(n)
    seed = _check_seed(seed)
    engine = qmc.LatinHypercube(d=len(names), **_rng_kwarg(qmc.LatinHypercube, seed))
    return _scaled_cases(names, engine.random(n), lo, hi)


def sobol(ranges: Mapping[str, tuple[float, float]], n: int, seed: int) -> list[dict]:
    """Scrambled Sobol' sample of ``n`` cases in a box.

    Parameters
    ----------
    ranges : mapping of str to (float, float)
        Parameter name -> (lower, upper) bound, in the parameter's unit; lower < upper.
    n : int
        Number of cases (>= 1). A power of two keeps the balance properties of the sequence
        (the first ``2**m`` points form a (t, m, d)-net); other ``n`` are allowed and simply
        take the first ``n`` points.
    seed : int
        Seed of the scrambling; the same seed gives the same cases.

    Returns
    -------
    list of dict
        ``n`` cases.

    Notes
    -----
    Uses :class:`scipy.stats.qmc.Sobol` with Owen-type scrambling (Sobol' 1967; Owen 1998).
    SciPy's warning about non-power-of-two sizes is suppressed locally because here it is a
    deliberate choice.
    """
    from scipy.stats import qmc

    names, lo, hi = _check_ranges(ranges)
    n = _check_n(n)
    seed = _check_seed(seed)
    engine = qmc.Sobol(d=len(names), scramble=True, **_rng_kwarg(qmc.Sobol, seed))
    if n & (n - 1) == 0:
        unit = engine.random_base2(m=n.bit_length() - 1)
    else:
        with warnings.catch_warnings():
            warnings.filterwarnings(
                "ignore", message=".*balance properties.*", category=UserWarning
            )
            unit = engine.random(n)
    return _scaled_cases(names, unit, lo, hi)


DESIGN_KINDS: dict[str, Callable[..., list[dict]]] = {
    "full_factorial": full_factorial,
    "latin_hypercube": latin_hypercube,
    "sobol": sobol,
}


def make_design(kind: str, **options: Any) -> list[dict]:
    """Build a design by name, e.g. from a run configuration.

    Parameters
    ----------
    kind : str
        One of ``"full_factorial"``, ``"latin_hypercube"``, ``"sobol"``.
    **options
        The keyword arguments of that design function (``levels``; or ``ranges``, ``n``,
        ``seed``).

    Returns
    -------
    list of dict
        The cases.
    """
    if kind not in DESIGN_KINDS:
        known = ", ".join(sorted(DESIGN_KINDS))
        raise BridgeflapInputError("kind", f"unknown design kind {kind!r} (known: {known})")
    func = DESIGN_KINDS[kind]
    params = inspect.signature(func).parameters
    for key in options:
        if key not in params:
            raise BridgeflapInputError(key, f"not an option of the {kind} design")
    for key, par in params.items():
        if par.default is inspect.Parameter.empty and key not in options:
            raise BridgeflapInputError(key, f"required by the {kind} design")
    return func(**options)


# --------------------------------------------------------------------------------------------
# batch execution
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BatchResult:
    """Outcome of :func:`run_batch`.

    Attributes
    ----------
    cases : int
        Number of cases in the batch.
    succeeded : int
        Cases with status ``"ok"`` (including ones reused from an earlier run).
    failed : int
        Cases with any other status (``"failed"`` or ``"timeout"``).
    table_path : pathlib.Path
        The written ``table.csv``.
    rows : tuple of dict
        The case records in input order, as written to ``cases/<case_id>.json``.
    """

    cases: int
    succeeded: int
    failed: int
    table_path: Path
    rows: tuple[dict, ...]


def _one_line(text: str, limit: int = 500) -> str:
    line = " ".join(str(text).split())
    return line if len(line) <= limit else line[: limit - 3] + "..."


def _error_text(exc: BaseException) -> str:
    message = str(exc)
    return _one_line(f"{type(exc).__name__}: {message}" if message else type(exc).__name__)


def _record(case_id, params, status, error, result, elapsed_s) -> dict:
    return {
        "case_id": case_id,
        "params": params,
        "status": status,
        "error": error,
        "result": result,
        "elapsed_s": elapsed_s,
    }


class _CaseTimeout(Exception):
    """Raised inside a serial case by the alarm signal."""


def _execute_case(fn: Callable[[dict], Mapping], case_id: str, params: dict) -> dict:
    """Run one case and return its record; every exception of ``fn`` becomes a failed record.

    This is what runs on a worker process. ``params`` are already JSON-converted.
    """
    start = time.perf_counter()
    try:
        result = fn(dict(params))
        if not isinstance(result, Mapping):
            raise TypeError(f"the analysis must return a dict, got {type(result).__name__}")
        result = to_jsonable(dict(result))
        json.dumps(result, allow_nan=False)  # fail here, in the case, not when writing
        status, error = STATUS_OK, None
    except _CaseTimeout:
        raise
    except (Exception, SystemExit) as exc:  # solver failure is data, never an aborted batch
        status, error, result = STATUS_FAILED, _error_text(exc), None
    return _record(case_id, params, status, error, result, time.perf_counter() - start)


def _normalise_cases(cases: Sequence[Mapping]) -> list[tuple[str, dict]]:
    """Check the cases; return ``(case_id, params)`` pairs in input order."""
    if isinstance(cases, Mapping) or not isinstance(cases, Iterable):
        raise BridgeflapInputError("cases", "expected a list of case dicts")
    out, seen = [], set()
    for i, case in enumerate(cases):
        if not isinstance(case, Mapping):
            raise BridgeflapInputError(f"cases[{i}]", f"expected a dict, got {type(case).__name__}")
        params = {k: v for k, v in case.items() if k != _CASE_ID_KEY}
        case_id = case.get(_CASE_ID_KEY, f"case-{i:04d}")
        if (
            not isinstance(case_id, str)
            or not case_id
            or case_id[0] == "."
            or not set(case_id) <= _CASE_ID_CHARS
        ):
            raise BridgeflapInputError(
                f"cases[{i}].case_id",
                f"{case_id!r} is not a valid id (letters, digits, '.', '_', '-'; no leading '.')",
            )
        if case_id in seen:
            raise BridgeflapInputError(f"cases[{i}].case_id", f"duplicate id {case_id!r}")
        seen.add(case_id)
        try:
            params = to_jsonable(params)
        except TypeError as exc:
            raise BridgeflapInputError(f"cases[{i}]", str(exc)) from None
        out.append((case_id, params))
    if not out:
        raise BridgeflapInputError("cases", "no cases to run")
    return out


def _load_reusable(path: Path, params: dict) -> dict | None:
    """The stored record at ``path`` if it is a successful run of the same parameters."""
    try:
        stored = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(stored, dict) or stored.get("status") != STATUS_OK:
        return None
    if stored.get("params") != params:
        return None
    return stored


def _flatten(value: Any, prefix: str, out: dict) -> None:
    """Scalar leaves of nested dicts as ``a.b.c`` keys; lists are not table cells and skipped."""
    if isinstance(value, Mapping):
        for key, item in value.items():
            _flatten(item, f"{prefix}.{key}" if prefix else str(key), out)
    elif value is None or isinstance(value, (bool, int, float, str)):
        out[prefix] = value


def _table_text(rows: Sequence[dict]) -> str:
    """CSV text: case_id, status, params..., flattened scalar results..., elapsed_s, error.

    A result column whose name is already taken (a parameter or a fixed column) is prefixed
    with ``result.``.
    """
    fixed = {"case_id", "status", "elapsed_s", "error"}
    param_cols: dict[str, None] = {}
    flat_params, flat_results = [], []
    for row in rows:
        p: dict = {}
        _flatten(row.get("params") or {}, "", p)
        flat_params.append(p)
        param_cols.update(dict.fromkeys(p))
    taken = fixed | set(param_cols)
    result_cols: dict[str, None] = {}
    for row in rows:
        r: dict = {}
        _flatten(row.get("result") or {}, "", r)
        r = {(f"result.{k}" if k in taken else k): v for k, v in r.items()}
        flat_results.append(r)
        result_cols.update(dict.fromkeys(r))
    header = ["case_id", "status", *param_cols, *result_cols, "elapsed_s", "error"]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=header, lineterminator="\n")
    writer.writeheader()
    for row, p, r in zip(rows, flat_params, flat_results, strict=True):
        writer.writerow(
            {
                "case_id": row["case_id"],
                "status": row["status"],
                **p,
                **r,
                "elapsed_s": row.get("elapsed_s"),
                "error": row.get("error") or "",
            }
        )
    return buffer.getvalue()


def run_batch(
    fn: Callable[[dict], Mapping],
    cases: Sequence[Mapping],
    out_dir: str | os.PathLike,
    workers: int = 1,
    scheduler: str | None = None,
    resume: bool = False,
    timeout_s: float | None = None,
    progress: bool = True,
    retries: int = 1,
) -> BatchResult:
    """Run ``fn`` on every case in separate worker processes; never abort on a failed case.

    Parameters
    ----------
    fn : callable
        The analysis, ``fn(params) -> dict`` of JSON-serialisable values. It must be picklable
        (a function defined at module level) and receives the case without its ``case_id``.
    cases : sequence of dict
        Cases as returned by the design functions; a missing ``case_id`` is set to
        ``case-<index>``.
    out_dir : str or os.PathLike
        Output folder, created if needed (see the module docstring for its layout).
    workers : int, optional
        Number of worker processes of the local Dask cluster (one thread each).
    scheduler : str, optional
        ``None``: start a ``dask.distributed.LocalCluster`` of ``workers`` processes.
        An address (``"tcp://host:8786"``): use that Dask scheduler and its workers (the
        workers must be able to import ``fn``'s module; results are written here, by the
        client). ``"serial"``: run in this process, one case after another (debugging, tests).
    resume : bool, optional
        Reuse every case whose ``cases/<case_id>.json`` exists with status ``"ok"`` and the
        same parameters; run the missing, failed and timed-out ones.
    timeout_s : float, optional
        Wall-clock limit per case [s], counted from submission (at most one case per worker
        thread is in flight, so this is close to its run time). A case past it is recorded as
        ``"timeout"`` and its worker process is restarted (local cluster, or remote workers
        with a nanny). In serial mode the limit is enforced with ``SIGALRM`` where available
        (POSIX main thread; it interrupts Python code, not a long call into C), otherwise
        checked after the case returns.
    progress : bool, optional
        Show a tqdm progress bar on stderr.
    retries : int, optional
        How often a case is resubmitted after its worker process died (crash, out of memory,
        killed) before it is recorded as failed. One retry by default: it also rescues a case
        that was merely queued on a worker when another case crashed it. Exceptions raised
        by ``fn`` are never retried: they are deterministic.

    Returns
    -------
    BatchResult
        Counts, the table path and the records.

    Raises
    ------
    BridgeflapInputError
        For malformed arguments or an unwritable ``out_dir``; never because a case failed.
    """
    if not callable(fn):
        raise BridgeflapInputError("fn", "the analysis must be callable")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise BridgeflapInputError("workers", f"must be an integer >= 1, got {workers!r}")
    if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
        raise BridgeflapInputError("retries", f"must be an integer >= 0, got {retries!r}")
    if timeout_s is not None:
        try:
            timeout_s = float(timeout_s)
        except (TypeError, ValueError):
            raise BridgeflapInputError(
                "timeout_s", f"must be a number, got {timeout_s!r}"
            ) from None
        if not timeout_s > 0.0:
            raise BridgeflapInputError("timeout_s", f"must be positive, got {timeout_s}")
    if scheduler is not None and (not isinstance(scheduler, str) or not scheduler):
        raise BridgeflapInputError(
            "scheduler", f"expected an address or 'serial', got {scheduler!r}"
        )
    normalised = _normalise_cases(cases)

    out = ensure_writable_dir(out_dir)
    case_dir = ensure_writable_dir(out / "cases")

    records: dict[str, dict] = {}
    pending: list[tuple[str, dict]] = []
    for case_id, params in normalised:
        stored = _load_reusable(case_dir / f"{case_id}.json", params) if resume else None
        if stored is not None:
            records[case_id] = stored
        else:
            pending.append((case_id, params))
    reused = len(records)

    from tqdm.auto import tqdm

    bar = tqdm(
        total=len(normalised),
        initial=reused,
        desc="cases",
        unit="case",
        file=sys.stderr,
        disable=not progress,
        dynamic_ncols=True,
    )

    def finish(record: dict) -> None:
        atomic_write_json(case_dir / f"{record['case_id']}.json", record)
        records[record["case_id"]] = record
        bar.update(1)
        if record["status"] != STATUS_OK:
            bar.set_postfix_str(f"{record['case_id']}: {record['status']}", refresh=False)

    try:
        if pending:
            if scheduler == "serial":
                _run_serial(fn, pending, timeout_s, finish)
            else:
                _run_dask(fn, pending, workers, scheduler, timeout_s, retries, finish)
    finally:
        bar.close()

    rows = tuple(records[case_id] for case_id, _ in normalised)
    table_path = out / "table.csv"
    atomic_write_text(table_path, _table_text(rows))
    succeeded = sum(row["status"] == STATUS_OK for row in rows)
    timed_out = sum(row["status"] == STATUS_TIMEOUT for row in rows)
    atomic_write_json(
        out / "batch.json",
        {
            "cases": len(rows),
            "succeeded": succeeded,
            "failed": len(rows) - succeeded,
            "timed_out": timed_out,
            "reused": reused,
            "table": table_path.name,
            "case_dir": case_dir.name,
            "statuses": {row["case_id"]: row["status"] for row in rows},
        },
    )
    return BatchResult(
        cases=len(rows),
        succeeded=succeeded,
        failed=len(rows) - succeeded,
        table_path=table_path,
        rows=rows,
    )


def _run_serial(fn, pending, timeout_s, finish) -> None:
    """Run the cases in this process, in order."""
    use_alarm = (
        timeout_s is not None
        and hasattr(signal, "setitimer")
        and threading.current_thread() is threading.main_thread()
    )

    def on_alarm(signum, frame):
        raise _CaseTimeout

    for case_id, params in pending:
        start = time.perf_counter()
        previous = signal.signal(signal.SIGALRM, on_alarm) if use_alarm else None
        try:
            if use_alarm:
                signal.setitimer(signal.ITIMER_REAL, timeout_s)
            record = _execute_case(fn, case_id, params)
        except _CaseTimeout:
            record = None
        finally:
            if use_alarm:
                signal.setitimer(signal.ITIMER_REAL, 0.0)
                signal.signal(signal.SIGALRM, previous)
        elapsed = time.perf_counter() - start
        if record is None or (timeout_s is not None and elapsed > timeout_s):
            record = _record(
                case_id,
                params,
                STATUS_TIMEOUT,
                f"exceeded the time limit of {timeout_s:g} s",
                None,
                elapsed,
            )
        finish(record)


def _start_client(workers: int, scheduler: str | None):
    """A dask client and, for a local cluster, the cluster (to close afterwards)."""
    import dask
    from dask.distributed import Client, LocalCluster

    if scheduler is None:
        # allowed-failures 0: a worker death surfaces at once as KilledWorker, and retries
        # are ours (counted per case); saturation 1.0 keeps at most one task per worker thread,
        # so a dying worker takes no innocent queued case with it.
        settings = {
            "distributed.scheduler.allowed-failures": 0,
            "distributed.scheduler.worker-saturation": 1.0,
        }
        with dask.config.set(settings):
            cluster = LocalCluster(
                n_workers=workers,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.CRITICAL,
            )
            client = Client(cluster)
        return client, cluster
    try:
        client = Client(scheduler, timeout="30s")
    except (OSError, ValueError) as exc:
        raise BridgeflapInputError("scheduler", f"cannot connect to {scheduler}: {exc}") from exc
    client.wait_for_workers(1, timeout=60)
    return client, None


def _run_dask(fn, pending, workers, scheduler, timeout_s, retries, finish) -> None:
    """Run the cases on a Dask cluster with at most one case in flight per worker thread."""
    from dask.distributed import wait

    client, cluster = _start_client(workers, scheduler)
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
            for future in done:
                case_id, params, attempt, submitted = in_flight.pop(future)
                elapsed = time.monotonic() - submitted
                if future.status == "finished":
                    finish(future.result())
                    continue
                reason = _future_error(future)
                if attempt < retries:
                    queue.appendleft((case_id, params, attempt + 1))
                    continue
                finish(_record(case_id, params, STATUS_FAILED, reason, None, elapsed))
            if timeout_s is None:
                continue
            now = time.monotonic()
            late = [f for f, (*_, submitted) in in_flight.items() if now - submitted > timeout_s]
            for future in late:
                case_id, params, _, submitted = in_flight.pop(future)
                elapsed = time.monotonic() - submitted
                _abandon(client, future)
                finish(
                    _record(
                        case_id,
                        params,
                        STATUS_TIMEOUT,
                        f"exceeded the time limit of {timeout_s:g} s",
                        None,
                        elapsed,
                    )
                )
    finally:
        for future in in_flight:
            future.cancel()
        client.close()
        if cluster is not None:
            cluster.close()


def _future_error(future) -> str:
    """One-line reason why a future did not finish (worker died, cancelled, ...)."""
    if future.status == "cancelled":
        return "worker task cancelled (scheduler or worker lost)"
    try:
        exc = future.exception(timeout=5)
    except Exception as err:  # noqa: BLE001 - any failure to fetch the reason is itself a reason
        return _error_text(err)
    if exc is None:
        return f"worker task ended with status {future.status}"
    name = type(exc).__name__
    if name == "KilledWorker":
        return "worker process died while running the case (KilledWorker)"
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
