"""Fault tests of the output folders: foreign folders, kills, concurrent runs,
stale resumes, busy ports, unreachable schedulers, oversized designs.

The commands run as subprocesses where a process must die or two must overlap; the studies are
tiny (one ``modes`` analysis on a 50 m mesh, about a second) and the DOEs use the ``modes``
analysis with the serial scheduler unless a Dask cluster is the point of the test. Fault
injection uses the test hook :data:`bridgeflap.design.io.outputs.FAULT_ENV` (unset in normal use).
"""

import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bridgeflap.design.batch.runner import case_hash, run_batch
from bridgeflap.design.cli.main import main
from bridgeflap.design.io.outputs import (
    FAULT_ENV,
    OUTPUT_MARKER,
    claim_output,
    lock_path,
    write_marker,
)
from bridgeflap.design.studies.experiments import MAX_DOE_CASES, doe_from_dict
from bridgeflap.design.studies.study import run_study
from bridgeflap.model.errors import BridgeflapInputError

CLI = [sys.executable, "-c",
       "import sys; from bridgeflap.design.cli.main import main; sys.exit(main())"]
STUDY = """
name = "tiny"
bridge = "humber"
analyses = ["modes"]
[quick]
element_length_m = 50.0
[modes]
count = {count}
"""
DOE = """
name = "tinydoe"
bridge = "{bridge}"
analysis = "modes"
[options]
count = {count}
[design]
kind = "full-factorial"
[parameters]
"cable.main_sag_m" = {{ values = [115.0, 120.0] }}
"""


def _env(**extra):
    return {**os.environ, "OPENBLAS_NUM_THREADS": "1", "MPLBACKEND": "Agg", **extra}


def _tree(folder: Path) -> dict:
    """Every file below ``folder`` (hidden ones included) -> its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def _study(tmp_path, count=4) -> Path:
    f = tmp_path / "study.toml"
    f.write_text(STUDY.format(count=count))
    return f


def _run(args, **env):
    return subprocess.run([*CLI, *args], env=_env(**env), capture_output=True, text=True,
                          timeout=600)


def _error_line(stderr: str) -> str:
    """The single error line of a refused run (progress lines before it are allowed)."""
    errors = [line for line in stderr.splitlines() if line.startswith("bridgeflap: error:")]
    assert len(errors) == 1, stderr
    assert "Traceback" not in stderr, stderr
    return errors[0]


def _leftovers(parent: Path, name: str) -> list[str]:
    """Temporary or backup siblings of output folder ``name`` (the lock file is expected)."""
    return sorted(p.name for p in parent.iterdir()
                  if p.name.startswith(f".{name}.") and p.name != f".{name}.lock")


def _dead_pid() -> int:
    """The pid of a process that has exited (and been reaped)."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


# --------------------------------------------------------------------------- C1 ownership
def test_user_folder_without_marker_is_never_replaced(tmp_path):
    study = _study(tmp_path)
    doe = tmp_path / "doe.toml"
    doe.write_text(DOE.format(bridge="humber", count=4))
    user = tmp_path / "mine"
    (user / "sub").mkdir(parents=True)
    (user / "thesis.tex").write_text("years of work")
    (user / "sub" / "data.bin").write_bytes(bytes(range(256)))
    before = _tree(user)
    for args in (["study", str(study), "--quick", "--out", str(user)],
                 ["doe", str(doe), "--scheduler", "serial", "--out", str(user)],
                 ["doe", str(doe), "--scheduler", "serial", "--resume", "--out", str(user)]):
        r = _run(args)
        assert r.returncode == 2, r.stderr
        line = _error_line(r.stderr)
        assert "out:" in line and "--out" in line and OUTPUT_MARKER in line
        assert _tree(user) == before  # byte-identical, nothing added
    # nothing was created next to it either (refused before the lock)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["doe.toml", "mine", "study.toml"]


def test_empty_folder_is_used_and_a_marked_folder_replaced(tmp_path):
    study = _study(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    run_study(study, out_dir=out, quick=True)
    tag = json.loads((out / OUTPUT_MARKER).read_text())
    assert tag["tool"] == "bridgeflap" and tag["kind"] == "study"
    (out / "results" / "extra.txt").write_text("stale")  # a marked folder is ours: replaced
    run_study(study, out_dir=out, quick=True)
    assert not (out / "results" / "extra.txt").exists()
    assert _leftovers(tmp_path, "out") == []


def test_optimise_refuses_a_user_folder_before_designing(tmp_path, capsys):
    user = tmp_path / "mine"
    user.mkdir()
    (user / "controller.toml").write_text("# my own hand-tuned controller\n")
    before = _tree(user)
    assert main(["optimise", "--quick", "--out", str(user)]) == 2
    line = _error_line(capsys.readouterr().err)
    assert "--out" in line and OUTPUT_MARKER in line
    assert _tree(user) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"]


def test_doe_does_not_write_into_a_study_folder(tmp_path):
    out = tmp_path / "out"
    run_study(_study(tmp_path), out_dir=out, quick=True)
    before = _tree(out)
    doe = tmp_path / "doe.toml"
    doe.write_text(DOE.format(bridge="humber", count=4))
    assert main(["doe", str(doe), "--scheduler", "serial", "--out", str(out)]) == 2
    assert _tree(out) == before


# --------------------------------------------------------------------------- C2 crash-safe swap
def test_sigkill_during_the_swap_then_the_next_run_recovers_the_previous_output(tmp_path):
    study = _study(tmp_path)
    out = tmp_path / "out"
    args = ["study", str(study), "--quick", "--out", str(out)]
    assert _run(args).returncode == 0
    before = _tree(out)

    # killed between "previous -> backup" and "new -> target": no target, a marked backup
    r = _run(args, **{FAULT_ENV: "kill-mid-swap"})
    assert r.returncode == -9, r.stderr
    assert not out.exists()
    backups = [n for n in _leftovers(tmp_path, "out") if n.startswith(".out.old-")]
    assert len(backups) == 1

    # the next run restores the previous output first; here it then fails before its own
    # swap, so what is left is exactly the recovered previous output
    r = _run(args, **{FAULT_ENV: "fail-before-swap"})
    assert r.returncode != 0
    assert "recovered the previous output" in r.stderr
    assert _tree(out) == before
    assert _leftovers(tmp_path, "out") == []

    # and a normal run then replaces it as usual
    assert _run(args).returncode == 0
    assert (out / OUTPUT_MARKER).is_file() and _leftovers(tmp_path, "out") == []


def test_stale_temporaries_of_dead_runs_are_cleaned_and_nothing_else(tmp_path):
    study = _study(tmp_path)
    out = tmp_path / "out"
    gone = _dead_pid()
    # ours: named .<name>.tmp-<pid>-<8 hex> and marked (or empty: killed before its marker)
    dead, empty_dead = (tmp_path / f".out.tmp-{gone}-{tag}" for tag in ("0123abcd", "4567cdef"))
    # not provably ours, whatever the name looks like: a user's folder is never deleted
    unmarked_dead, users, oddly_named, alive = (
        tmp_path / f".out.tmp-{tag}" for tag in (f"{gone}-89abcdef", f"{gone}-mine", "dead",
                                                  f"{os.getpid()}-0a0b0c0d"))
    for folder in (dead, unmarked_dead, users, oddly_named, alive):
        folder.mkdir()
        (folder / "half.json").write_text("{")
    empty_dead.mkdir()
    for folder, pid in ((dead, gone), (oddly_named, gone), (alive, os.getpid())):
        write_marker(folder, "study")
        tag = json.loads((folder / OUTPUT_MARKER).read_text())
        (folder / OUTPUT_MARKER).write_text(json.dumps({**tag, "pid": pid}))
    run_study(study, out_dir=out, quick=True)
    assert not dead.exists()  # ours, marked, its process is gone
    assert not empty_dead.exists()  # ours, killed before its marker: empty, nothing lost
    for kept in (unmarked_dead, users, oddly_named, alive):  # content and all
        assert (kept / "half.json").read_text() == "{", kept.name


# --------------------------------------------------------------------------- C3 one run at a time
def test_second_concurrent_run_is_refused_and_the_first_completes(tmp_path):
    study = _study(tmp_path)
    out = tmp_path / "out"
    pause = tmp_path / "pause"
    pause.touch()
    reached = Path(f"{pause}.reached")
    first = subprocess.Popen(
        [*CLI, "study", str(study), "--quick", "--out", str(out), "--json"],
        env=_env(**{FAULT_ENV: "pause-before-swap", "BRIDGEFLAP_TEST_PAUSE_FILE": str(pause)}),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 300  # a generous bound on a loaded machine, not a timing
        while not reached.exists() and first.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert reached.exists(), "the first run never reached its swap"
        for args in (["study", str(study), "--quick", "--out", str(out)],
                     ["doe", str(tmp_path / "doe.toml"), "--scheduler", "serial", "--out",
                      str(out)]):
            (tmp_path / "doe.toml").write_text(DOE.format(bridge="humber", count=4))
            second = _run(args)
            assert second.returncode == 2, second.stderr
            line = _error_line(second.stderr)
            assert "another bridgeflap run" in line and "--out" in line
    finally:
        pause.unlink()
        stdout, stderr = first.communicate(timeout=600)
    assert first.returncode == 0, stderr
    assert json.loads(stdout)["status"] == "ok"
    assert (out / OUTPUT_MARKER).is_file() and _leftovers(tmp_path, "out") == []


def test_lock_is_reentrant_in_one_thread_and_exclusive_across_threads_and_processes(tmp_path):
    out = tmp_path / "out"
    with claim_output(out) as folder, claim_output(out):
        assert lock_path(folder) == tmp_path / ".out.lock" and lock_path(folder).exists()
        code = ("import sys; from bridgeflap.design.io.outputs import claim_output\n"
                "from bridgeflap.model.errors import BridgeflapInputError\n"
                "try:\n    claim_output(sys.argv[1]).__enter__()\n"
                "except BridgeflapInputError as e:\n    print(e); sys.exit(2)\n")
        r = subprocess.run([sys.executable, "-c", code, str(out)], env=_env(),
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 2 and "another bridgeflap run" in r.stdout
        import threading

        errors = []

        def other_thread():
            try:
                with claim_output(out):
                    errors.append(None)
            except BridgeflapInputError as exc:
                errors.append(exc)

        thread = threading.Thread(target=other_thread)
        thread.start()
        thread.join()
        assert len(errors) == 1 and isinstance(errors[0], BridgeflapInputError)
    assert not out.exists()  # the lock lives next to the folder, never inside it


# --------------------------------------------------------------------------- C4 resume, scheduler
def test_stale_resume_recomputes_the_cases_of_another_doe(tmp_path):
    bridge = tmp_path / "bridge.toml"
    from importlib import resources

    text = resources.files("bridgeflap.model.bridges").joinpath("humber.toml").read_text("utf-8")
    bridge.write_text(text)
    doe = tmp_path / "doe.toml"
    out = tmp_path / "out"
    args = ["doe", str(doe), "--scheduler", "serial", "--out", str(out), "--json"]

    def run(resume=True):
        r = _run(args + (["--resume"] if resume else []))
        assert r.returncode == 0, r.stderr
        return json.loads(r.stdout), r.stderr

    doe.write_text(DOE.format(bridge=bridge, count=4))
    first, _ = run(resume=False)
    assert (first["cases"], first["succeeded"], first["reused"]) == (2, 2, 0)
    hashes = {p.name: json.loads(p.read_text())["case_hash"] for p in (out / "cases").iterdir()}
    again, err = run()
    assert again["reused"] == 2 and "different run" not in err

    # same parameter values, other options: another DOE's cases, recomputed and said so
    doe.write_text(DOE.format(bridge=bridge, count=5))
    other, err = run()
    assert other["reused"] == 0 and "2 stored case(s)" in err and "recomputed" in err
    new = {p.name: json.loads(p.read_text())["case_hash"] for p in (out / "cases").iterdir()}
    assert set(new) == set(hashes) and all(new[k] != hashes[k] for k in new)

    # same options, the bridge file's content changed: recomputed again
    bridge.write_text(text + "\n# edited\n")
    edited, err = run()
    assert edited["reused"] == 0 and "recomputed" in err


def _square(params):
    return {"y": params["x"] ** 2}


def test_batch_resume_keys_on_the_fingerprint(tmp_path):
    out = tmp_path / "out"
    cases = [{"case_id": "a", "x": 2.0}]
    first = run_batch(_square, cases, out, scheduler="serial", progress=False, fingerprint="A")
    stored = json.loads((out / "cases" / "a.json").read_text())
    assert stored["case_hash"] == case_hash({"x": 2.0}, "A")
    half = out / "cases" / ".a.json.0123456789ab.tmp"  # what a kill mid-write leaves
    half.write_text('{"case_id": "a", "par')
    assert run_batch(_square, cases, out, scheduler="serial", progress=False, resume=True,
                     fingerprint="A").reused == 1
    assert not half.exists()
    second = run_batch(_square, cases, out, scheduler="serial", progress=False, resume=True,
                       fingerprint="B")
    assert (second.reused, second.stale) == (0, 1)
    assert first.rows[0]["result"] == second.rows[0]["result"] == {"y": 4.0}


def test_dead_scheduler_fails_fast_with_one_line_and_writes_nothing(tmp_path):
    doe = tmp_path / "doe.toml"
    doe.write_text(DOE.format(bridge="humber", count=4))
    with socket.socket() as s:  # a port nobody listens on (bound, then released)
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    out = tmp_path / "sub" / "out"
    r = _run(["doe", str(doe), "--scheduler", f"tcp://127.0.0.1:{port}", "--out", str(out)])
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1, r.stderr
    assert "scheduler:" in r.stderr and "cannot connect" in r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["doe.toml"]  # not even the parent


# --------------------------------------------------------------------------- C5 ordering
def test_invalid_option_exits_2_and_leaves_the_previous_output_byte_identical(tmp_path):
    out = tmp_path / "out"
    good = _study(tmp_path)
    assert main(["study", str(good), "--quick", "--out", str(out)]) == 0
    before = _tree(out)
    bad = tmp_path / "bad.toml"
    # a checked option (modes must be >= 1) and one only the flutter solver knows (rfa): both
    # must stop the run before the good folder is replaced
    for extra in ('[flutter]\nmodes = 0\nspeeds = "0:20:10"\n',
                  '[flutter]\nrfa = "bogus"\nspeeds = "0:20:10"\nmodes = 4\n'):
        bad.write_text('name = "tiny"\nanalyses = ["modes", "flutter"]\n[modes]\ncount = 4\n'
                       + extra)
        r = _run(["study", str(bad), "--quick", "--out", str(out)])
        assert r.returncode == 2, r.stderr
        assert "flutter." in _error_line(r.stderr)
        assert _tree(out) == before
        assert _leftovers(tmp_path, "out") == []


@pytest.mark.parametrize("bad", [
    "modes = 0",
    'rfa = "bogus"',
])
def test_doe_with_an_invalid_option_leaves_the_previous_output_byte_identical(tmp_path, bad):
    doe = tmp_path / "doe.toml"
    doe.write_text(DOE.format(bridge="humber", count=4))
    out = tmp_path / "out"
    assert main(["doe", str(doe), "--scheduler", "serial", "--out", str(out)]) == 0
    before = _tree(out)
    text = (DOE.replace('analysis = "modes"', 'analysis = "flutter"')
            .replace("count = {count}", 'speeds = "0:20:10"\n' + bad))
    doe.write_text(text.format(bridge="humber"))
    r = _run(["doe", str(doe), "--scheduler", "serial", "--out", str(out)])
    assert r.returncode == 2, r.stderr
    assert "options." in _error_line(r.stderr)
    assert _tree(out) == before


# --------------------------------------------------------------------------- C7 size limits
@pytest.mark.parametrize(
    ("design", "params", "field"),
    [
        ({"levels": 100000}, {"cable.main_sag_m": [100.0, 130.0], "deck.gj_nm2": [3e11, 4e11]},
         "design.levels"),
        ({"levels": MAX_DOE_CASES + 1}, {"cable.main_sag_m": [100.0, 130.0]}, "design.levels"),
        ({"kind": "lhs", "n": MAX_DOE_CASES + 1}, {"cable.main_sag_m": [100.0, 130.0]},
         "design.n"),
        ({}, {"cable.main_sag_m": {"values": [100.0 + 0.001 * i for i in range(400)]},
              "deck.gj_nm2": {"values": [3e11 + 1e8 * i for i in range(300)]}},
         "parameters.cable.main_sag_m"),
    ],
)
def test_oversized_design_is_refused_before_allocating(design, params, field):
    data = {"name": "big", "analysis": "modes", "design": design, "parameters": params}
    with pytest.raises(BridgeflapInputError) as info:
        doe_from_dict(data)
    assert info.value.field == field and str(MAX_DOE_CASES) in info.value.reason


# --------------------------------------------------------------------------- C8 busy port 8787
def test_two_worker_doe_runs_while_port_8787_is_held(tmp_path):
    holder = socket.socket()
    try:
        holder.bind(("127.0.0.1", 8787))
        holder.listen()
    except OSError:
        # someone else holds 8787 already: the very situation under test, so go on
        holder.close()
        holder = None
    try:
        doe = tmp_path / "doe.toml"
        doe.write_text(DOE.format(bridge="humber", count=4))
        out = tmp_path / "out"
        # a subprocess with warnings as errors: a fallback from a busy 8787 leaks a socket
        # (ResourceWarning) and warns "Port 8787 is already in use"
        r = subprocess.run([sys.executable, "-W", "error::ResourceWarning", *CLI[1:], "doe",
                            str(doe), "--workers", "2", "--out", str(out), "--json"],
                           env=_env(), capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr[-2000:]
        s = json.loads(r.stdout)
        assert (s["cases"], s["succeeded"]) == (2, 2)
        assert "8787" not in r.stderr
        # in this process too (pytest turns warnings into errors)
        batch = run_batch(_square, [{"case_id": "a", "x": 3.0}, {"case_id": "b", "x": 4.0}],
                          tmp_path / "batch", workers=2, progress=False)
        assert [row["result"]["y"] for row in batch.rows] == [9.0, 16.0]
    finally:
        if holder is not None:
            holder.close()
