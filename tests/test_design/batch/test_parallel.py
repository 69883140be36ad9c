"""The parallel paths give the serial numbers: erection stages in worker
processes, a study's analyses in worker processes, DOE cases on Dask workers.

Each parallel run is compared with the serial one field by field, exactly: the same function
runs on the same input in another process, so even the last bit must agree (a difference would
mean shared state between cases or a case run on the wrong input). No timings here: the
speed-ups are measured by ``bench/study.py`` and ``bench/doe.py``.
"""

from __future__ import annotations

import functools
import json
import math

import pytest

from bridgeflap.design.batch.runner import run_batch
from bridgeflap.design.studies.cases import flutter_case
from bridgeflap.design.studies.study import run_study
from bridgeflap.model.analysis import erection
from bridgeflap.model.structure.loader import load_bridge

#: coarse mesh, few modes and a coarse grid: each stage or case takes a fraction of a second
MESH = {"mesh.element_length_m": 50.0}

SMALL_STUDY = """
name = "par"
bridge = "humber"
analyses = ["modes", "flutter", "erection", "frequency_ratio"]
[quick]
element_length_m = 50.0
[modes]
count = 6
[flutter]
speeds = "0:100:2"
modes = 6
truncation_check = false
[erection]
fractions = "0.5:1.0:0.5"
speeds = "0:100:4"
modes = 6
[frequency_ratio]
fractions = "0.5:1.0:0.5"
"""


def _same(a, b, path="") -> None:
    """``a == b`` with NaN equal to NaN, naming the first differing field."""
    if isinstance(a, dict) and isinstance(b, dict):
        assert a.keys() == b.keys(), path
        for k in a:
            _same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list | tuple) and isinstance(b, list | tuple):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{path}[{i}]")
    elif isinstance(a, float) and isinstance(b, float) and math.isnan(a):
        assert math.isnan(b), path
    else:
        assert a == b, f"{path}: {a!r} != {b!r}"


def test_erection_stages_in_two_processes_match_serial():
    spec = load_bridge("humber").replace(**MESH)
    seen = []
    args = (spec, [0.4, 0.7, 1.0], [0.0, 20.0, 40.0, 60.0, 80.0, 100.0], 6)
    serial = erection(*args)
    parallel = erection(*args, progress=seen.append, workers=2)
    assert seen == [0.4, 0.7, 1.0]  # progress in stage order, once per stage
    _same(serial.summary(), parallel.summary())
    assert len(parallel.stages) == 3 and parallel.completed["stage"] == "completed bridge"


def test_study_with_two_workers_writes_the_serial_results(tmp_path):
    f = tmp_path / "study.toml"
    f.write_text(SMALL_STUDY)
    serial = run_study(f, out_dir=tmp_path / "serial", quick=True, workers=1)
    parallel = run_study(f, out_dir=tmp_path / "parallel", quick=True, workers=2)
    assert list(parallel.statuses) == ["modes", "flutter", "erection", "frequency_ratio"]
    assert dict(parallel.statuses) == dict(serial.statuses)
    files = sorted(p.relative_to(serial.out_dir) for p in (serial.out_dir / "results").iterdir())
    assert files == sorted(p.relative_to(parallel.out_dir)
                           for p in (parallel.out_dir / "results").iterdir())
    for name in files:
        if name.suffix != ".json":
            continue
        a, b = (json.loads((d / name).read_text()) for d in (serial.out_dir, parallel.out_dir))
        a.pop("elapsed_s"), b.pop("elapsed_s")
        _same(a, b, str(name))
    assert (parallel.out_dir / "figures" / "erection.png").is_file()
    assert parallel.objects["flutter"] is not None  # the plot of StudyResult still works


def test_study_refuses_a_bad_worker_count(tmp_path):
    from bridgeflap.model.errors import BridgeflapInputError

    with pytest.raises(BridgeflapInputError, match="workers"):
        run_study(None, out_dir=tmp_path / "x", quick=True, workers=0)
    assert not (tmp_path / "x").exists()


def test_doe_rows_on_two_dask_workers_match_serial(tmp_path):
    fn = functools.partial(flutter_case, bridge="humber", speeds="0:120:4", modes=6,
                           truncation_check=False)
    cases = [{**MESH, "deck.gj_nm2": g, "cable.main_sag_m": s}
             for g in (3.0e11, 3.7e11) for s in (112.0, 120.0)]
    serial = run_batch(fn, cases, tmp_path / "serial", scheduler="serial", progress=False)
    dask = run_batch(fn, cases, tmp_path / "dask", workers=2, progress=False)
    assert serial.succeeded == dask.succeeded == len(cases)
    for a, b in zip(serial.rows, dask.rows, strict=True):
        assert a["case_id"] == b["case_id"]
        _same(a["result"], b["result"], a["case_id"])
