"""A fault-tolerant batch runner (docs/methods.md#batches-and-doe); the designs are
in :mod:`bridgeflap.design.batch.designs`.

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
      .bridgeflap-output     marker: a bridgeflap output folder
      (bridgeflap.design.io.outputs.OUTPUT_MARKER) cases/<case_id>.json   one per case: {case_id,
      params, status, error, result, elapsed_s,
                             case_hash}
      table.csv              one row per case: case_id, status, params..., results..., elapsed_s,
                             error
      batch.json             summary: {cases, succeeded, failed, timed_out, reused, table, ...}

All three are written atomically (:mod:`bridgeflap.design.io.files`); over a previous output of
another run the folder is written aside and swapped in when complete (:func:`run_batch`, "Where the
files go"). Non-finite numbers are stored as JSON
``null`` and as empty CSV cells.

Integrity (:mod:`bridgeflap.design.io.outputs`): a non-empty ``out_dir`` without the bridgeflap
marker is refused (nothing written); the run holds the folder's lock (a second run into it is
refused); a stored case is reused by ``resume`` only if its ``case_hash`` -- SHA-256 of the case
parameters, the run's *fingerprint* (for a DOE: bridge file content, resolved options, analysis,
package version) -- matches, otherwise it is recomputed and the count is said on stderr. Nothing is
written before the Dask scheduler is reachable
(:data:`bridgeflap.design.batch.cluster.CONNECT_TIMEOUT_S`; the Dask side of the runner is
:mod:`bridgeflap.design.batch.cluster`).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bridgeflap.design.batch.case import (
    STATUS_OK,
    STATUS_TIMEOUT,
    _CaseTimeout,
    _execute_case,
    _timeout_record,
)
from bridgeflap.design.batch.cluster import cluster_client, run_dask
from bridgeflap.design.batch.designs import CASE_ID_KEY
from bridgeflap.design.batch.table import flat_case_rows, table_text, with_branch_flags
from bridgeflap.design.io.files import (
    atomic_write_json,
    atomic_write_text,
    ensure_writable_dir,
    to_jsonable,
)
from bridgeflap.design.io.outputs import (
    OUTPUT_MARKER,
    check_replaceable,
    claim_output,
    is_marked_output,
    remove_stale_file_temporaries,
    swap_into_place,
    temporary_sibling,
    write_marker,
)
from bridgeflap.model.arguments import (
    cases_list,
    check_callable,
    check_mapping,
    check_text,
    checked,
    count,
    flag,
    number,
    optional,
)
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.results import ResultData
from bridgeflap.model.workers import check_main_guard

__all__ = [
    "BatchResult",
    "case_hash",
    "function_fingerprint",
    "run_batch",
]

_CASE_ID_CHARS = frozenset("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789._-")


# --------------------------------------------------------------------------------------------
# batch execution
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BatchResult(ResultData):
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
    reused: int = 0
    stale: int = 0

    def _rows(self) -> list[dict]:
        return flat_case_rows(self.rows)

    def _headline(self) -> dict:
        return {"cases": self.cases, "succeeded": self.succeeded, "failed": self.failed,
                "reused": self.reused, "status": "ok" if not self.failed else
                f"{self.failed} failed", "table": str(self.table_path)}

    def to_xarray(self):
        """The cases on the dimension ``case``
        (:func:`bridgeflap.design.batch.table.cases_dataset`).

        Returns
        -------
        xarray.Dataset
            The parameters as coordinates and each scalar result as a variable on the dimension
            ``case`` (NaN for a failed case).
        """
        from bridgeflap.design.batch.table import cases_dataset

        return cases_dataset(self.rows)

    def plot(self, ax=None, output: str | None = None):
        """One numeric output per case (default: the first), failed cases as red crosses
        (:func:`bridgeflap.design.batch.plots.batch_cases`).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).
        output : str, optional
            The numeric result to draw (default: the first in the table).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        from bridgeflap.design.batch.plots import batch_cases

        return batch_cases(self, ax, output)


def _normalise_cases(cases: Sequence[Mapping]) -> list[tuple[str, dict]]:
    """Check the cases; return ``(case_id, params)`` pairs in input order."""
    if isinstance(cases, Mapping) or not isinstance(cases, Iterable):
        raise BridgeflapInputError("cases", "expected a list of case dicts")
    out, seen = [], set()
    for i, case in enumerate(cases):
        if not isinstance(case, Mapping):
            raise BridgeflapInputError(f"cases[{i}]", f"expected a dict, got {type(case).__name__}")
        params = {k: v for k, v in case.items() if k != CASE_ID_KEY}
        case_id = case.get(CASE_ID_KEY, f"case-{i:04d}")
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


def function_fingerprint(fn: Callable) -> str:
    """A stable text naming ``fn`` and its bound settings (a ``functools.partial``'s arguments).

    The default fingerprint of :func:`run_batch`; callers that know more (a DOE: the bridge
    file's content) pass their own. A bound in-memory
    :class:`~bridgeflap.model.structure.spec.BridgeSpec` is named by
    :func:`bridgeflap.design.io.identity.bridge_identity` (the hash of its canonical form).
    """
    import functools

    from bridgeflap.design.io.identity import bridge_identity
    from bridgeflap.model.structure.spec import BridgeSpec

    parts = []
    while isinstance(fn, functools.partial):
        kw = {k: bridge_identity(v) if isinstance(v, BridgeSpec) else v
              for k, v in fn.keywords.items()}
        parts.append(json.dumps({"args": to_jsonable(list(fn.args)),
                                 "keywords": to_jsonable(kw)},
                                sort_keys=True, default=repr))
        fn = fn.func
    parts.append(f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', repr(fn))}")
    return "|".join(reversed(parts))


def case_hash(params: Mapping, fingerprint: str) -> str:
    """SHA-256 (hex) of one case: its parameters and the run's ``fingerprint``."""
    text = json.dumps({"params": to_jsonable(dict(params)), "run": fingerprint},
                      sort_keys=True, allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _load_reusable(path: Path, params: dict, digest: str) -> tuple[dict | None, bool]:
    """``(record, stale)``: the stored record at ``path`` if it is a successful run of the same
    case (same ``case_hash``); ``stale`` when a successful record of another case is there."""
    try:
        stored = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None, False
    if not isinstance(stored, dict) or stored.get("status") != STATUS_OK:
        return None, False
    if stored.get("case_hash") != digest or stored.get("params") != params:
        return None, True
    return stored, False


@checked(fn=check_callable, cases=cases_list, scheduler=optional(check_text), resume=flag,
         timeout_s=optional(number(0.0, 1.0e7, strict=True)), progress=flag,
         retries=count(0, 100), fingerprint=optional(check_text), files=optional(check_mapping),
         kind=check_text, definition=optional(check_text))
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
    fingerprint: str | None = None,
    files: Mapping[str, Any] | None = None,
    kind: str = "batch",
    definition: str | None = None,
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
        same ``case_hash`` (parameters and ``fingerprint``); run the missing, failed and
        timed-out ones, and recompute (saying so on stderr) those stored by another run.
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
    fingerprint : str, optional
        What besides a case's parameters determines its result (the ``case_hash`` key).
    files : mapping, optional
        Extra JSON files written into the folder (name -> content), e.g. ``doe.json``.
    kind : str, optional
        The output kind in the folder's marker
        (:func:`bridgeflap.design.io.outputs.check_replaceable`).
    definition : str, optional
        The name in ``files`` that defines the run (``doe.json``): a resume writes into the
        stored folder in place only if that file is as stored (see "Where the files go").

    Where the files go: into ``out_dir`` itself when it is missing or empty, or, with
    ``resume``, when it holds this same run (every stored case file a case of this design
    with this run's ``case_hash``; ``definition`` unchanged): the finished case files of an
    interrupted run are then where the next ``resume`` finds them. Otherwise (a previous
    output of any other run, or any run without ``resume``) into a temporary sibling folder
    that replaces ``out_dir`` only when complete
    (:func:`bridgeflap.design.io.outputs.swap_into_place`), the reused case files copied over: a
    killed or interrupted run leaves the previous output as it was, and no file of another
    definition nor a case beyond this design survives.

    Returns
    -------
    BatchResult
        Counts, the table path and the records.

    Raises
    ------
    BridgeflapInputError
        For malformed arguments, an unwritable or foreign ``out_dir``, a folder another run
        holds, an unreachable scheduler; never because a case failed.
    """
    if not callable(fn):
        raise BridgeflapInputError("fn", "the analysis must be callable")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise BridgeflapInputError("workers", f"must be an integer >= 1, got {workers!r}")
    if scheduler is None:  # a local cluster's nannies spawn: they re-run an unguarded script,
        check_main_guard(max(2, workers), "spawn")  # one nanny, for workers=1, included
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
    if fingerprint is None:
        fingerprint = f"{function_fingerprint(fn)}|bridgeflap {_package_version()}"
    digests = {case_id: case_hash(params, fingerprint) for case_id, params in normalised}
    target = check_replaceable(out_dir, "out", kind)  # typed: another kind's folder refused

    with contextlib.ExitStack() as stack:
        # a remote scheduler is reached before anything is written (a dead address fails in
        # CONNECT_TIMEOUT_S with one line); a local cluster is started under the lock
        client = None
        if scheduler not in (None, "serial"):
            client = stack.enter_context(cluster_client(workers, scheduler))
        out = stack.enter_context(claim_output(target, "out", kind=kind))
        records: dict[str, dict] = {}
        pending: list[tuple[str, dict]] = []
        stale = []
        for case_id, params in normalised:
            stored, old = (_load_reusable(out / "cases" / f"{case_id}.json", params,
                                          digests[case_id]) if resume else (None, False))
            if stored is not None:
                records[case_id] = stored
            else:
                pending.append((case_id, params))
                if old:
                    stale.append(case_id)
        reused = len(records)
        if stale:
            print(f"bridgeflap: resume: {len(stale)} stored case(s) in {out} are from a "
                  f"different run (case hash differs or missing) and are recomputed: "
                  f"{', '.join(stale[:5])}{', ...' if len(stale) > 5 else ''}",
                  file=sys.stderr, flush=True)
        if pending and client is None and scheduler is None:
            client = stack.enter_context(cluster_client(workers, None))

        # where the files go: straight into ``out`` only when it holds nothing or, resumed,
        # this very run's cases (its interrupted case files are what a resume reuses); else a
        # temporary sibling swapped in at the end, so a kill leaves the previous output whole
        # and no file of another definition (or a case beyond this design) survives
        in_place = _in_place(out, digests, resume, files, definition)
        existed = out.exists()
        dest = out if in_place else temporary_sibling(out)
        # the case files are written by one background thread: an atomic write (fsync of the
        # file and its folder, ~10 ms) then overlaps the next case instead of delaying it; all
        # are on disk (or their error raised) before the table is written
        from concurrent.futures import ThreadPoolExecutor

        writer = ThreadPoolExecutor(1, thread_name_prefix="case-writer")
        try:
            if in_place:
                ensure_writable_dir(out)
                if not is_marked_output(out):
                    write_marker(out, kind)
                for folder in (out, out / "cases"):  # half-written files of a killed run
                    remove_stale_file_temporaries(folder)
            else:
                dest.mkdir()
                write_marker(dest, kind)
            for name, content in (files or {}).items():
                atomic_write_json(dest / name, content)
            case_dir = ensure_writable_dir(dest / "cases")
            if not in_place:  # the reused cases move into the new folder as they are
                for case_id in records:
                    shutil.copyfile(out / "cases" / f"{case_id}.json",
                                    case_dir / f"{case_id}.json")

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
            writes = []

            def finish(record: dict) -> None:
                record = {**record, "case_hash": digests[record["case_id"]]}
                writes.append(writer.submit(atomic_write_json,
                                            case_dir / f"{record['case_id']}.json", record))
                records[record["case_id"]] = record
                bar.update(1)
                if record["status"] != STATUS_OK:
                    bar.set_postfix_str(f"{record['case_id']}: {record['status']}", refresh=False)

            try:
                if pending:
                    if scheduler == "serial":
                        _run_serial(fn, pending, timeout_s, finish)
                    else:
                        run_dask(client, fn, pending, workers, scheduler, timeout_s, retries,
                                 finish)
            finally:
                bar.close()
                for done in writes:  # every finished case is on disk, even when interrupted
                    done.result()

            rows = with_branch_flags(tuple(records[case_id] for case_id, _ in normalised))
            table_path = out / "table.csv"
            atomic_write_text(dest / table_path.name, table_text(rows))
            succeeded = sum(row["status"] == STATUS_OK for row in rows)
            timed_out = sum(row["status"] == STATUS_TIMEOUT for row in rows)
            atomic_write_json(
                dest / "batch.json",
                {
                    "cases": len(rows),
                    "succeeded": succeeded,
                    "failed": len(rows) - succeeded,
                    "timed_out": timed_out,
                    "reused": reused,
                    "recomputed_stale": len(stale),
                    "table": table_path.name,
                    "case_dir": case_dir.name,
                    "statuses": {row["case_id"]: row["status"] for row in rows},
                },
            )
            writer.shutdown()
            if not in_place:
                swap_into_place(dest, out)
        except BaseException:
            writer.shutdown(cancel_futures=True)  # no write into a folder being removed
            if not in_place or not existed:
                if not in_place or not any((out / "cases").glob("*.json")):
                    shutil.rmtree(dest, ignore_errors=True)  # no finished case to resume
            elif not any((out / "cases").glob("*.json")):  # a folder given empty: empty again
                for name in (OUTPUT_MARKER, "cases", *(files or {})):
                    shutil.rmtree(out / name, ignore_errors=True)
                    with contextlib.suppress(OSError):
                        (out / name).unlink()
            raise

    if rows and not succeeded:  # nothing usable: a typed error, never an empty table
        from bridgeflap.model.errors import BatchFailedError

        first = next((r.get("error") or r["status"] for r in rows), "")
        raise BatchFailedError(len(rows), out, _one_line_error(first))
    return BatchResult(
        cases=len(rows),
        succeeded=succeeded,
        failed=len(rows) - succeeded,
        table_path=table_path,
        rows=rows,
        reused=reused,
        stale=len(stale),
    )


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _in_place(out: Path, digests: Mapping[str, str], resume: bool,
              files: Mapping[str, Any] | None, definition: str | None) -> bool:
    """Whether a batch writes straight into ``out``: a missing or empty folder (or one holding
    just the marker), or, with ``resume``, a folder of this same run -- every stored case file
    one of this design's cases with this run's ``case_hash``, and the ``definition`` file (a
    name in ``files``, e.g. ``doe.json``) as stored. Anything else is written elsewhere and
    swapped in (:func:`run_batch`)."""
    try:
        names = {p.name for p in out.iterdir()}
    except FileNotFoundError:
        return True
    if not names - {OUTPUT_MARKER}:
        return True
    if not resume:
        return False
    if definition is not None and _read_json(out / definition) != json.loads(
            json.dumps(to_jsonable((files or {}).get(definition)), allow_nan=False)):
        return False
    for path in (out / "cases").glob("*.json"):
        stored = _read_json(path)
        if not isinstance(stored, dict) or stored.get("case_hash") != digests.get(path.stem):
            return False
    return True


def _one_line_error(text: str, limit: int = 300) -> str:
    line = " ".join(str(text).split())
    return line if len(line) <= limit else line[:limit - 3] + "..."


def _package_version() -> str:
    import importlib.metadata

    try:
        return importlib.metadata.version("bridgeflap")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


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
            record = _timeout_record(case_id, params, timeout_s, elapsed)
        finish(record)
