"""One case of a batch (:func:`bridgeflap.design.batch.runner.run_batch`): run it, catch what it
raises, and make its record (``ok``, ``failed`` with the one-line reason, ``timeout``). Shared by
the local runner (:mod:`bridgeflap.design.batch.runner`) and the Dask one
(:mod:`bridgeflap.design.batch.cluster`); imports neither. This is
what runs on a worker process."""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Mapping

from bridgeflap.design.io.files import to_jsonable

STATUS_OK = "ok"
STATUS_FAILED = "failed"
STATUS_TIMEOUT = "timeout"


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


def _timeout_record(case_id, params, timeout_s: float, elapsed_s: float) -> dict:
    return _record(case_id, params, STATUS_TIMEOUT,
                   f"exceeded the time limit of {timeout_s:g} s", None, elapsed_s)


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
