"""The batch runner's tables: flat case rows, ``table.csv`` text, branch-switch flags
(:func:`bridgeflap.design.batch.runner.run_batch`; no files, no physics)."""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping, Sequence
from typing import Any

__all__ = ["cases_dataset", "flat_case_rows", "table_text", "with_branch_flags"]

STATUS_OK = "ok"


def flat_case_rows(rows) -> list[dict]:
    """One flat dict per case record: ``case_id``, ``status``, the parameters and the scalar
    results (``critical_speed_m_s``, ...; nested keys ``a.b``; a result key already taken by a
    parameter is prefixed ``result.``), ``elapsed_s`` and ``error`` (the ``table.csv`` row)."""
    out = []
    for row in rows:
        p: dict = {}
        _flatten(row.get("params") or {}, "", p)
        r: dict = {}
        _flatten(row.get("result") or {}, "", r)
        taken = {"case_id", "status", "elapsed_s", "error"} | set(p)
        out.append({"case_id": row["case_id"], "status": row["status"], **p,
                    **{(f"result.{k}" if k in taken else k): v for k, v in r.items()},
                    "elapsed_s": row.get("elapsed_s"), "error": row.get("error")})
    return out


def cases_dataset(rows):
    """The case records as an :class:`xarray.Dataset` on the dimension ``case`` (coordinate: the
    case ids): one variable per parameter (``params.<path>``; its values also as a coordinate
    named by the path) and per scalar result, plus ``status``, ``elapsed_s`` and ``error``.
    A failed case holds NaN (numbers) or an empty string (text)."""
    import numpy as np
    import xarray as xr

    flat = flat_case_rows(rows)
    params = []
    for row in rows:
        p: dict = {}
        _flatten(row.get("params") or {}, "", p)
        params.extend(k for k in p if k not in params)
    names = list(dict.fromkeys(k for r in flat for k in r if k != "case_id"))
    ids = [r["case_id"] for r in flat]
    data, coords = {}, {"case": ids}
    for name in names:
        values = [r.get(name) for r in flat]
        numeric = all(v is None or (isinstance(v, int | float) and not isinstance(v, bool))
                      for v in values)
        if numeric:
            array = np.array([np.nan if v is None else float(v) for v in values])
        else:
            array = np.array(["" if v is None else str(v) for v in values], dtype=object)
        if name in params:
            coords[name] = ("case", array)
        else:
            data[name] = ("case", array)
    return xr.Dataset(data, coords=coords,
                      attrs={"parameters": ", ".join(params), "cases": len(ids)})


def _flatten(value: Any, prefix: str, out: dict) -> None:
    """Scalar leaves of nested dicts as ``a.b.c`` keys; lists are not table cells and skipped."""
    if isinstance(value, Mapping):
        for key, item in value.items():
            _flatten(item, f"{prefix}.{key}" if prefix else str(key), out)
    elif value is None or isinstance(value, (bool, int, float, str)):
        out[prefix] = value


def with_branch_flags(rows: tuple[dict, ...]) -> tuple[dict, ...]:
    """Rows of a stability DOE with ``branch_switch_neighbour`` and ``neighbour_branches``.

    A row whose parameter-space neighbours have another critical branch is flagged
    (:func:`bridgeflap.design.batch.branch_flags.flag_branch_neighbours`): a response surface or a
    derivative across it spans a branch switch. Only the table and the returned rows carry the
    flags; the per-case files (the ``--resume`` records) stay as computed.
    """
    from bridgeflap.design.batch.branch_flags import flag_branch_neighbours

    ok = [i for i, r in enumerate(rows)
          if r["status"] == STATUS_OK and isinstance(r.get("result"), Mapping)
          and "critical_branch_label" in r["result"]]
    keys = sorted({k for i in ok for k, v in rows[i]["params"].items()
                   if isinstance(v, int | float) and not isinstance(v, bool)})
    if len(ok) < 2 or not keys:
        return rows
    flat = [{**{k: rows[i]["params"][k] for k in keys},
             "critical_branch_label": rows[i]["result"]["critical_branch_label"] or ""}
            for i in ok]
    flags = flag_branch_neighbours(flat, keys)
    out = list(rows)
    for i, f in zip(ok, flags, strict=True):
        out[i] = {**rows[i], "result": {**rows[i]["result"],
                                        "branch_switch_neighbour": f["branch_switch_neighbour"],
                                        "neighbour_branches": ";".join(f["neighbour_branches"])}}
    return tuple(out)


def table_text(rows: Sequence[dict]) -> str:
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
