"""DOE and batch output folders written aside and swapped in.

A batch writes straight into its folder only when the folder is new (or empty) or, with
``resume``, holds this very run; over any other previous output it writes a temporary sibling
and swaps it in when complete (:func:`bridgeflap.design.batch.runner.run_batch`). So: a smaller
design leaves no case file of a larger earlier one, and a run of another definition that is killed
or interrupted leaves the previous output byte-identical.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bridgeflap.design.batch.runner import run_batch
from bridgeflap.design.cli.main import main
from bridgeflap.design.io.outputs import FAULT_ENV, OUTPUT_MARKER

CLI = [sys.executable, "-c",
       "import sys; from bridgeflap.design.cli.main import main; sys.exit(main())"]
DOE = """
name = "swapdoe"
bridge = "humber"
analysis = "modes"
[options]
count = {count}
[design]
kind = "full-factorial"
[parameters]
"cable.main_sag_m" = {{ values = {sags} }}
"""


def _tree(folder: Path) -> dict:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def _siblings(parent: Path, name: str) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if p.name.startswith(f".{name}."))


def _square(params):
    if params.get("interrupt"):
        raise KeyboardInterrupt
    return {"y": params["x"] ** 2}


def _cases(n, interrupt_at=None):
    return [{"case_id": f"c{i}", "x": float(i), **({"interrupt": True} if i == interrupt_at
                                                   else {})} for i in range(n)]


def test_a_smaller_design_leaves_no_case_file_of_the_larger_one(tmp_path):
    out = tmp_path / "out"
    run_batch(_square, _cases(5), out, scheduler="serial", progress=False)
    assert len(list((out / "cases").iterdir())) == 5
    run_batch(_square, _cases(2), out, scheduler="serial", progress=False)
    assert sorted(p.name for p in (out / "cases").iterdir()) == ["c0.json", "c1.json"]
    # resumed, too: the two stored cases are reused (copied), the other three are gone
    run_batch(_square, _cases(5), out, scheduler="serial", progress=False)
    again = run_batch(_square, _cases(2), out, scheduler="serial", progress=False, resume=True)
    assert again.reused == 2
    assert sorted(p.name for p in (out / "cases").iterdir()) == ["c0.json", "c1.json"]
    assert json.loads((out / "batch.json").read_text())["cases"] == 2
    assert _siblings(tmp_path, "out") == []


def test_an_interrupted_run_over_another_output_leaves_it_byte_identical(tmp_path):
    out = tmp_path / "out"
    run_batch(_square, _cases(4), out, scheduler="serial", progress=False, fingerprint="A")
    before = _tree(out)
    for resume in (False, True):  # another fingerprint: its cases are not this run's
        with pytest.raises(KeyboardInterrupt):
            run_batch(_square, _cases(4, interrupt_at=2), out, scheduler="serial",
                      progress=False, fingerprint="B", resume=resume)
        assert _tree(out) == before
        assert _siblings(tmp_path, "out") == []  # the temporary folder is removed


def test_an_interrupted_first_run_resumes_in_place(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        run_batch(_square, _cases(4, interrupt_at=2), out, scheduler="serial", progress=False)
    done = {p.name: p.read_bytes() for p in (out / "cases").iterdir()}
    assert sorted(done) == ["c0.json", "c1.json"]  # the finished cases stay for a resume
    second = run_batch(_square, _cases(4), out, scheduler="serial", progress=False, resume=True)
    assert (second.reused, second.succeeded) == (2, 4)
    for name, data in done.items():
        assert (out / "cases" / name).read_bytes() == data
    # interrupted again while resuming the same run: still in place, nothing lost
    (out / "cases" / "c3.json").unlink()
    with pytest.raises(KeyboardInterrupt):
        run_batch(_square, _cases(4, interrupt_at=3), out, scheduler="serial", progress=False,
                  resume=True)
    assert sorted(p.name for p in (out / "cases").iterdir()) == ["c0.json", "c1.json",
                                                                   "c2.json"]


def test_doe_of_another_definition_killed_leaves_the_previous_doe_whole(tmp_path):
    doe = tmp_path / "doe.toml"
    out = tmp_path / "out"
    doe.write_text(DOE.format(count=4, sags="[115.0, 118.0, 121.0]"))
    assert main(["doe", str(doe), "--scheduler", "serial", "--out", str(out)]) == 0
    before = _tree(out)
    assert len(list((out / "cases").iterdir())) == 3
    # definition B, paused just before its swap, then SIGKILLed: nothing of B is in out
    doe.write_text(DOE.format(count=5, sags="[115.0]"))
    pause = tmp_path / "pause"
    pause.touch()
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", FAULT_ENV: "pause-before-swap",
           "BRIDGEFLAP_TEST_PAUSE_FILE": str(pause)}
    for resume in ([], ["--resume"]):
        proc = subprocess.Popen([*CLI, "doe", str(doe), "--scheduler", "serial", "--out",
                                 str(out), *resume], env=env, stderr=subprocess.DEVNULL)
        reached = Path(f"{pause}.reached")
        deadline = time.monotonic() + 300  # a bound on a loaded machine, not a timing
        while not reached.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert reached.exists(), "the run never reached its swap"
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        reached.unlink()
        assert _tree(out) == before
    # the next run of B cleans the dead temporaries and replaces A completely
    assert main(["doe", str(doe), "--scheduler", "serial", "--out", str(out)]) == 0
    assert sorted(p.name for p in (out / "cases").iterdir()) == ["case-0000.json"]
    assert json.loads((out / "doe.json").read_text())["options"]["count"] == 5
    assert (out / OUTPUT_MARKER).is_file()
    assert _siblings(tmp_path, "out") == []
