"""Tests of the designs of experiments, the batch runner and the output helpers.

The batch tests start real ``dask.distributed`` local clusters (one or two worker processes)
and kill worker processes on purpose. The analyses are tiny module-level functions, so that
they pickle by reference, and they count their calls with marker files because they run in
other processes.
"""

import csv
import json
import math
import os
import shutil
import signal
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from bridgeflap.design.batch.designs import full_factorial, latin_hypercube, make_design, sobol
from bridgeflap.design.batch.runner import run_batch
from bridgeflap.design.io.files import (
    atomic_savez,
    atomic_write_json,
    ensure_writable_dir,
    to_jsonable,
)
from bridgeflap.design.io.manifest import build_manifest, git_info
from bridgeflap.model.errors import BridgeflapInputError

RANGES = {"wind_speed": (10.0, 80.0), "flap_gain": (-1.0, 1.0), "damping_ratio": (0.001, 0.02)}


# --------------------------------------------------------------------------------------------
# analyses run on the workers (module level so that they pickle)
# --------------------------------------------------------------------------------------------
def _count_call(params):
    """Append one line to ``calls/<name>`` so the test can count calls across processes."""
    calls = Path(params["marker_dir"]) / "calls"
    calls.mkdir(exist_ok=True)
    with open(calls / params["name"], "a") as handle:
        handle.write("call\n")


def toy_analysis(params):
    """y = 2x; misbehaves on request: raise, kill its worker once, sleep."""
    _count_call(params)
    if params.get("mode") == "raise":
        raise ValueError(f"deliberate failure of {params['name']}")
    if params.get("mode") == "kill_once":
        marker = Path(params["marker_dir"]) / f"killed-{params['name']}"
        if not marker.exists():
            marker.touch()
            os.kill(os.getpid(), signal.SIGKILL)
    if params.get("mode") == "sleep":
        time.sleep(params["sleep_s"])
    return {"y": 2.0 * params["x"], "stats": {"nan": np.nan, "n": np.int64(3)}, "trace": [1, 2]}


def _cases(marker_dir, modes):
    return [
        {"case_id": f"case-{i:04d}", "name": f"case-{i:04d}", "x": float(i), "mode": mode,
         "marker_dir": str(marker_dir)}
        for i, mode in enumerate(modes)
    ]


def _calls(marker_dir):
    folder = Path(marker_dir) / "calls"
    return {p.name: len(p.read_text().splitlines()) for p in folder.iterdir()}


def _table(out):
    with open(out / "table.csv", newline="") as handle:
        return list(csv.DictReader(handle))


def _assert_clean(out):
    leftovers = [p for p in Path(out).rglob("*") if p.name.endswith(".tmp")]
    assert leftovers == []


# --------------------------------------------------------------------------------------------
# designs
# --------------------------------------------------------------------------------------------
def test_full_factorial_enumerates_every_combination_once():
    levels = {"wind_speed": [20.0, 40.0, 60.0], "layout": ["none", "trailing"]}
    cases = full_factorial(levels)
    assert len(cases) == 6
    assert [c["case_id"] for c in cases] == [f"case-{i:04d}" for i in range(6)]
    combos = {(c["wind_speed"], c["layout"]) for c in cases}
    assert combos == {(u, s) for u in levels["wind_speed"] for s in levels["layout"]}
    # the last parameter varies fastest, so ids are stable for a given input
    assert (cases[1]["wind_speed"], cases[1]["layout"]) == (20.0, "trailing")
    assert full_factorial(levels) == cases


@pytest.mark.parametrize("design", [latin_hypercube, sobol])
@pytest.mark.parametrize("n", [1, 10, 16])
def test_sampled_designs_size_bounds_and_reproducibility(design, n):
    cases = design(RANGES, n, seed=7)
    assert len(cases) == n
    assert len({c["case_id"] for c in cases}) == n
    for case in cases:
        assert set(case) == {"case_id", *RANGES}
        for name, (lo, hi) in RANGES.items():
            assert lo <= case[name] <= hi
    # same seed: bit-identical (exact equality intended); other seed: a different sample
    assert design(RANGES, n, seed=7) == cases
    assert design(RANGES, n, seed=8) != cases


@pytest.mark.parametrize("design", [latin_hypercube, sobol])
def test_sampled_designs_are_stratified(design):
    # Latin hypercube: by construction each of the n strata of each parameter holds one point.
    # Scrambled Sobol with n = 2**m: every one-dimensional projection of the first 2**m points
    # is a (0, m, 1)-net, i.e. also one point per stratum. Both are exact properties; the only
    # tolerance is the rounding of lo + u*(hi - lo), far below a stratum width.
    n = 16
    cases = design(RANGES, n, seed=3)
    for name, (lo, hi) in RANGES.items():
        strata = sorted(int((c[name] - lo) / (hi - lo) * n) for c in cases)
        assert strata == list(range(n))


@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda: latin_hypercube({}, 4, 0), "ranges"),
        (lambda: sobol({"a": (1.0, 1.0)}, 4, 0), "ranges.a"),
        (lambda: sobol({"a": (2.0, 1.0)}, 4, 0), "ranges.a"),
        (lambda: latin_hypercube({"a": (0.0, math.inf)}, 4, 0), "ranges.a"),
        (lambda: latin_hypercube({"a": (0.0, 1.0)}, 0, 0), "n"),
        (lambda: sobol({"a": (0.0, 1.0)}, 2.5, 0), "n"),
        (lambda: full_factorial({}), "levels"),
        (lambda: full_factorial({"a": []}), "levels.a"),
        (lambda: full_factorial({"case_id": [1]}), "levels.case_id"),
        (lambda: make_design("orthogonal_array", levels={"a": [1]}), "kind"),
        (lambda: make_design("sobol", ranges={"a": (0, 1)}, n=4, seeds=1), "seeds"),
    ],
)
def test_invalid_designs_name_the_field(call, field):
    with pytest.raises(BridgeflapInputError) as info:
        call()
    assert info.value.field == field


def test_make_design_dispatches_to_the_named_design():
    assert make_design("sobol", ranges=RANGES, n=8, seed=1) == sobol(RANGES, 8, 1)


# --------------------------------------------------------------------------------------------
# batches
# --------------------------------------------------------------------------------------------
def test_failing_case_becomes_a_row_and_the_batch_completes(tmp_path):
    out = tmp_path / "out"
    cases = _cases(tmp_path, ["ok", "raise", "ok", "ok"])
    result = run_batch(toy_analysis, cases, out, workers=2, progress=False)

    assert (result.cases, result.succeeded, result.failed) == (4, 3, 1)
    statuses = [row["status"] for row in result.rows]
    assert statuses == ["ok", "failed", "ok", "ok"]
    failed = json.loads((out / "cases" / "case-0001.json").read_text())
    assert failed["status"] == "failed"
    assert failed["error"] == "ValueError: deliberate failure of case-0001"
    assert failed["result"] is None
    ok = json.loads((out / "cases" / "case-0002.json").read_text())
    # y = 2x computed exactly in binary floating point; NaN stored as JSON null
    assert ok["result"] == {"y": 4.0, "stats": {"nan": None, "n": 3}, "trace": [1, 2]}
    assert ok["params"]["x"] == 2.0

    table = _table(out)
    assert [r["case_id"] for r in table] == [c["case_id"] for c in cases]
    assert [r["status"] for r in table] == statuses
    assert table[1]["error"].startswith("ValueError: deliberate failure")
    assert [r["y"] for r in table] == ["0.0", "", "4.0", "6.0"]
    assert "trace" not in table[0]  # lists are not table cells
    summary = json.loads((out / "batch.json").read_text())
    assert (summary["cases"], summary["succeeded"], summary["failed"]) == (4, 3, 1)
    assert summary["table"] == "table.csv"
    _assert_clean(out)


def test_killed_worker_is_a_failed_row_and_resume_recomputes_only_unfinished(tmp_path):
    out = tmp_path / "out"
    cases = _cases(tmp_path, ["ok", "kill_once", "raise", "ok", "ok"])
    first = run_batch(toy_analysis, cases, out, workers=2, progress=False, retries=0)

    statuses = {row["case_id"]: row["status"] for row in first.rows}
    assert statuses == {
        "case-0000": "ok", "case-0001": "failed", "case-0002": "failed",
        "case-0003": "ok", "case-0004": "ok",
    }
    assert "worker process died" in first.rows[1]["error"]
    assert _calls(tmp_path) == dict.fromkeys(statuses, 1)

    # an interrupted batch: one finished case file is missing
    (out / "cases" / "case-0004.json").unlink()
    second = run_batch(toy_analysis, cases, out, workers=2, resume=True, progress=False)

    # recomputed: the killed case (now succeeds), the raising case (fails again), the missing one
    assert _calls(tmp_path) == {
        "case-0000": 1, "case-0001": 2, "case-0002": 2, "case-0003": 1, "case-0004": 2,
    }
    assert [row["status"] for row in second.rows] == ["ok", "ok", "failed", "ok", "ok"]
    assert (second.succeeded, second.failed) == (4, 1)
    assert json.loads((out / "batch.json").read_text())["reused"] == 2
    assert len(_table(out)) == len(cases)
    _assert_clean(out)


def test_killed_worker_is_retried_when_asked(tmp_path):
    out = tmp_path / "out"
    cases = _cases(tmp_path, ["kill_once", "ok"])
    result = run_batch(toy_analysis, cases, out, workers=1, progress=False, retries=1)
    assert [row["status"] for row in result.rows] == ["ok", "ok"]
    assert _calls(tmp_path)["case-0000"] == 2
    assert result.rows[0]["result"]["y"] == 0.0


def test_case_past_its_time_limit_is_a_timeout_row_and_the_worker_is_freed(tmp_path):
    out = tmp_path / "out"
    cases = _cases(tmp_path, ["sleep", "ok"])
    cases[0]["sleep_s"] = 60.0
    start = time.monotonic()
    result = run_batch(toy_analysis, cases, out, workers=1, timeout_s=1.0, progress=False)
    # one worker: case-0001 can only run if the sleeping worker was restarted, and the batch
    # ends long before the 60 s sleep would (30 s leaves room for cluster start and restart)
    assert time.monotonic() - start < 30.0
    assert [row["status"] for row in result.rows] == ["timeout", "ok"]
    assert "time limit" in result.rows[0]["error"]
    _assert_clean(out)


def test_serial_scheduler_matches_and_reruns_changed_parameters(tmp_path):
    out = tmp_path / "out"
    cases = _cases(tmp_path, ["ok", "raise", "ok"])
    first = run_batch(toy_analysis, cases, out, scheduler="serial", progress=False)
    assert [row["status"] for row in first.rows] == ["ok", "failed", "ok"]

    cases[2]["x"] = 10.0  # changed parameters: the stored ok result must not be reused
    second = run_batch(toy_analysis, cases, out, scheduler="serial", resume=True, progress=False)
    assert _calls(tmp_path) == {"case-0000": 1, "case-0001": 2, "case-0002": 2}
    assert second.rows[2]["result"]["y"] == 20.0
    _assert_clean(out)


def test_serial_timeout_interrupts_python_code(tmp_path):
    # an ok case beside it: a batch whose every case fails raises (BatchFailedError)
    cases = _cases(tmp_path, ["sleep", "ok"])
    cases[0]["sleep_s"] = 30.0
    result = run_batch(
        toy_analysis, cases, tmp_path / "out", scheduler="serial", timeout_s=0.2, progress=False
    )
    assert result.rows[0]["status"] == "timeout" and result.rows[1]["status"] == "ok"
    # SIGALRM stops time.sleep; 5 s is generous against a loaded CI machine
    assert result.rows[0]["elapsed_s"] < 5.0


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"workers": 0}, "workers"),
        ({"timeout_s": -1.0}, "timeout_s"),
        ({"retries": -1}, "retries"),
        ({"cases": []}, "cases"),
        ({"cases": [{"case_id": "a"}, {"case_id": "a"}]}, "cases[1].case_id"),
        ({"cases": [{"case_id": "../escape"}]}, "cases[0].case_id"),
    ],
)
def test_invalid_batch_arguments_name_the_field(tmp_path, kwargs, field):
    args = {"cases": [{"case_id": "a", "x": 1.0}], "scheduler": "serial", "progress": False}
    args.update(kwargs)
    with pytest.raises(BridgeflapInputError) as info:
        run_batch(toy_analysis, out_dir=tmp_path / "out", **args)
    assert info.value.field == field
    assert not (tmp_path / "out").exists()


# --------------------------------------------------------------------------------------------
# output helpers and manifest
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Record:
    speed: float
    where: Path


def test_to_jsonable_gives_strict_json():
    obj = {
        "a": np.float64(1.5), "b": np.array([[1.0, np.nan], [np.inf, 2.0]]), "c": np.int32(4),
        "d": _Record(float("-inf"), Path("/tmp/x")), "e": (np.bool_(True), 1 + 2j), 3: None,
    }
    converted = to_jsonable(obj)
    assert converted == {
        "a": 1.5, "b": [[1.0, None], [None, 2.0]], "c": 4,
        "d": {"speed": None, "where": "/tmp/x"}, "e": [True, {"real": 1.0, "imag": 2.0}],
        "3": None,
    }
    json.dumps(converted, allow_nan=False)  # raises on any NaN/inf left behind
    with pytest.raises(TypeError, match="object"):
        to_jsonable(object())


def test_atomic_writers_write_complete_files_and_no_temporaries(tmp_path):
    atomic_write_json(tmp_path / "r.json", {"x": np.nan, "y": [1.0, np.inf]})
    text = (tmp_path / "r.json").read_text()
    assert "NaN" not in text and "Infinity" not in text
    assert json.loads(text) == {"x": None, "y": [1.0, None]}

    matrix = np.arange(6.0).reshape(2, 3)
    atomic_savez(tmp_path / "arrays.npz", matrix=matrix)
    with np.load(tmp_path / "arrays.npz") as data:
        np.testing.assert_array_equal(data["matrix"], matrix)  # stored bit for bit
    _assert_clean(tmp_path)


def test_ensure_writable_dir_creates_or_refuses_without_leftovers(tmp_path):
    nested = ensure_writable_dir(tmp_path / "a" / "b")
    assert nested.is_dir() and list(nested.iterdir()) == []

    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(BridgeflapInputError) as info:
        ensure_writable_dir(blocker / "sub" / "dir")
    assert info.value.field == "out"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "file"]

    if hasattr(os, "geteuid") and os.geteuid() != 0:  # root ignores permission bits
        locked = tmp_path / "locked"
        locked.mkdir(mode=0o500)
        try:
            with pytest.raises(BridgeflapInputError):
                ensure_writable_dir(locked / "x" / "y")
            assert list(locked.iterdir()) == []
        finally:
            locked.chmod(0o700)


def test_manifest_is_json_and_names_versions_and_commit():
    config = {"n": np.int64(3), "out": Path("/tmp/run")}
    manifest = build_manifest(config)
    json.dumps(manifest, allow_nan=False)
    assert manifest["config"] == {"n": 3, "out": "/tmp/run"}
    for name in ("bridgeflap", "numpy", "scipy", "casadi", "ipopt", "matplotlib", "dask"):
        assert isinstance(manifest["packages"][name], str) and manifest["packages"][name]
    assert manifest["packages"]["numpy"] == np.__version__
    commit = manifest["git"]["commit"]
    assert commit == "unknown" or (len(commit) == 40 and int(commit, 16) >= 0)
    assert manifest["time_utc"].endswith("+00:00")


@pytest.mark.skipif(shutil.which("git") is None, reason="git not installed")
def test_git_info_reports_commit_and_dirty_flag_only_at_a_checkout_root(tmp_path):
    def git(*args):
        subprocess.run(
            ["git", "-c", "user.name=t", "-c", "user.email=t@t", *args],
            cwd=tmp_path, check=True, capture_output=True,
        )

    assert git_info(tmp_path) == {"commit": "unknown", "dirty": None}
    git("init", "-q")
    (tmp_path / "f.txt").write_text("1")
    git("add", "f.txt")
    git("commit", "-q", "-m", "init")
    head = subprocess.run(
        ["git", "rev-parse", "HEAD"], cwd=tmp_path, check=True, capture_output=True, text=True
    ).stdout.strip()
    assert git_info(tmp_path) == {"commit": head, "dirty": False}
    (tmp_path / "f.txt").write_text("2")
    assert git_info(tmp_path) == {"commit": head, "dirty": True}
    # a folder inside someone else's checkout (e.g. site-packages in a venv) is not ours
    (tmp_path / "site-packages").mkdir()
    assert git_info(tmp_path / "site-packages")["commit"] == "unknown"
