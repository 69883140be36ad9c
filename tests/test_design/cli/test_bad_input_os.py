"""The OS refusing a write, Ctrl-C, a bare ``bridgeflap`` and warnings before an error,
as bad-input cases of the contract of tests/test_bad_input.py.

* **OS errors** -- no space left (``ENOSPC``), permission (``EACCES``), read-only file system
  (``EROFS``), a name too long (``ENAMETOOLONG``): exit status 2 and one error line naming the
  option, the path and the OS's reason, never "internal error ... bug"; the previous output
  byte-identical and no temporary left. A full disk is simulated in-process (``os.fsync``
  raising ``ENOSPC``, as a write into a full file system does at the latest), permission and
  read-only by refusing the creation of the atomic writers' temporaries (``os.open``): a
  chmod does not stop root, and the tests must not need a real full or read-only disk.
* **Ctrl-C** -- ``KeyboardInterrupt`` anywhere: one line ``bridgeflap: interrupted``, exit status
  130, temporaries and lock files removed; with process pools (``--workers 2``) SIGINT to the
  whole process group (as a terminal's Ctrl-C) gives no traceback of any worker.
* **Bare ``bridgeflap``** -- a short usage (at most 5 lines), exit status 2.
* **A warning, then a refusal** -- exactly one line: the warnings held back are dropped.
"""

from __future__ import annotations

import errno
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from conftest import subprocess_env

from bridgeflap.design.cli.main import COMMANDS, main
from bridgeflap.design.io.outputs import OUTPUT_MARKER

STUDY = ('name = "tiny"\nbridge = "humber"\nanalyses = ["modes"]\n[quick]\n'
         'element_length_m = 50.0\n[modes]\ncount = {count}\n')
DOE = ('name = "tinydoe"\nbridge = "humber"\nanalysis = "modes"\n[options]\ncount = {count}\n'
       '[design]\nkind = "full-factorial"\n[parameters]\n'
       '"cable.main_sag_m" = {{ values = [115.0, 120.0] }}\n')
LONG = "x" * 300
QUICK_FLUTTER = ["--speeds", "0:20:10", "--modes", "4", "--no-truncation-check"]


def _tree(folder: Path) -> dict:
    """Every file below ``folder`` (hidden ones included) -> its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def _error(capsys, rc: int, code: int = 2) -> str:
    """The one error line of a refused run (progress lines before it allowed), checked."""
    cap = capsys.readouterr()
    assert rc == code, cap.err
    assert "Traceback" not in cap.err and "internal error" not in cap.err, cap.err
    assert "bug" not in cap.err, cap.err
    errors = [ln for ln in cap.err.splitlines() if ln.startswith("bridgeflap: error:")]
    assert len(errors) == 1, cap.err
    return errors[0]


@pytest.fixture(scope="module")
def _template(tmp_path_factory):
    """Inputs and earlier outputs, made once: a study and a DOE folder, a controller file."""
    from bridgeflap.model.aeroelastic.control import Compensator, Controller
    from bridgeflap.model.aeroelastic.controller_file import plant_record, save_controller

    d = tmp_path_factory.mktemp("template") / "d"
    d.mkdir()
    (d / "study.toml").write_text(STUDY.format(count=4))
    (d / "doe.toml").write_text(DOE.format(count=4))
    k = Compensator(-1.1668156764187112, -0.03901371153086817, -1.6746219244786549,
                    0.7122695359413691, 0.08664867156606472)
    save_controller(Controller(k, tuple(56.4 * i for i in range(-12, 13)), 56.4,
                               flap_chord_m=5.0, plant=plant_record("humber", 8)),
                    d / "controller.toml")
    assert main(["study", str(d / "study.toml"), "--quick", "--workers", "1",
                 "--out", str(d / "study_out")]) == 0
    assert main(["doe", str(d / "doe.toml"), "--scheduler", "serial", "--json",
                 "--out", str(d / "doe_out")]) == 0
    return d


@pytest.fixture()
def folder(_template, tmp_path, capsys):
    """A copy of the template for one test (its outputs are the "previous outputs")."""
    import shutil

    d = tmp_path / "d"
    shutil.copytree(_template, d)
    capsys.readouterr()
    return d


def _commands(d: Path) -> dict:
    """Every command that writes: argv writing into ``d`` (fresh targets or earlier outputs)."""
    return {
        "study": ["study", str(d / "study.toml"), "--quick", "--workers", "1", "--out",
                  str(d / "study_out")],
        "doe": ["doe", str(d / "doe.toml"), "--scheduler", "serial", "--json", "--out",
                str(d / "doe_out")],
        "doe-new": ["doe", str(d / "doe.toml"), "--scheduler", "serial", "--json", "--out",
                    str(d / "doe_new")],
        "flutter-plot": ["flutter", *QUICK_FLUTTER, "--plot", str(d / "f.png")],
        "modes-plot": ["modes", "--count", "2", "--plot", str(d / "m.png")],
        "state-space": ["state-space", "--speed", "10", "--modes", "4", "--out",
                        str(d / "ss.npz")],
        "state-space-mat": ["state-space", "--speed", "10", "--modes", "4", "--out",
                            str(d / "ss.mat")],
        "robustness": ["robustness", "--controller", str(d / "controller.toml"), "--samples",
                       "2", "--modes", "6", "--workers", "1", "--out", str(d / "h.csv")],
        "buffeting-plot": ["buffeting", "--speeds", "20,30", "--modes", "4", "--plot",
                           str(d / "b.png")],
    }


#: the option each command's refusal names
FIELD = {"study": "out", "doe": "out", "doe-new": "out", "flutter-plot": "plot",
         "modes-plot": "plot", "state-space": "out", "state-space-mat": "out",
         "robustness": "out", "buffeting-plot": "plot"}


def _check_nothing_changed(d: Path, before: dict) -> None:
    assert _tree(d) == before
    stray = [p.name for p in d.iterdir() if ".tmp" in p.name or ".old-" in p.name
             or p.name.endswith(".lock")]
    assert stray == []


# ------------------------------------------------------------------------------- OS errors
def _enospc_after(monkeypatch, calls: int) -> None:
    """``os.fsync`` of a file raises ENOSPC from its ``calls``-th call on (folders pass)."""
    real, count = os.fsync, [0]

    def fsync(fd):
        import stat

        if not stat.S_ISDIR(os.fstat(fd).st_mode):
            count[0] += 1
            if count[0] >= calls:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(fd)

    monkeypatch.setattr(os, "fsync", fsync)


@pytest.mark.parametrize(("command", "calls"), [(c, 1) for c in sorted(FIELD)] + [
    (c, 3) for c in ("study", "doe", "doe-new")])  # folders: also full after some files
def test_no_space_left_is_one_line_naming_the_path(folder, capsys, monkeypatch, command,
                                                   calls):
    argv = _commands(folder)[command]
    before = _tree(folder)
    _enospc_after(monkeypatch, calls)
    line = _error(capsys, main(argv))
    monkeypatch.undo()
    assert line.startswith(f"bridgeflap: error: {FIELD[command]}: "), line
    # the line names the path; one over 120 characters is cut to its first 60 and last 50
    # (design.cli.common._short), which happens under pytest-xdist's longer tmp folders
    assert str(folder)[:60] in line and "No space left on device" in line, line
    _check_nothing_changed(folder, before)


def _refuse_temporaries(monkeypatch, code: int) -> None:
    """Creating a file (an atomic writer's temporary) fails with ``code``, as in a folder made
    read-only (EACCES for a non-root user) or on a read-only file system (EROFS)."""
    real = os.open

    def fake(path, flags, mode=0o777, *, dir_fd=None):
        if str(path).endswith(".tmp") and flags & os.O_CREAT:
            raise OSError(code, os.strerror(code), os.fspath(path))
        return real(path, flags, mode, dir_fd=dir_fd)

    monkeypatch.setattr(os, "open", fake)


@pytest.mark.parametrize("code", [errno.EACCES, errno.EROFS])
@pytest.mark.parametrize("command", ["study", "doe", "doe-new", "flutter-plot", "state-space",
                                     "robustness"])
def test_permission_and_read_only_are_one_line(folder, capsys, monkeypatch, command, code):
    argv = _commands(folder)[command]
    before = _tree(folder)
    _refuse_temporaries(monkeypatch, code)
    line = _error(capsys, main(argv))
    monkeypatch.undo()
    assert line.startswith(f"bridgeflap: error: {FIELD[command]}: "), line
    # the path, cut to its first 60 and last 50 characters when over 120 (as above)
    assert os.strerror(code) in line and str(folder)[:60] in line, line
    _check_nothing_changed(folder, before)


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0,
                    reason="root writes into a read-only folder (covered by the monkeypatch)")
@pytest.mark.parametrize("command", ["study", "doe", "state-space", "flutter-plot"])
def test_read_only_folder_is_one_line(folder, capsys, command):
    ro = folder / "ro"
    ro.mkdir()
    argv = [a.replace(str(folder / "study_out"), str(ro / "o")).replace(
        str(folder / "doe_out"), str(ro / "o")).replace(str(folder / "ss.npz"), str(ro / "s.npz"))
        .replace(str(folder / "f.png"), str(ro / "f.png")) for a in _commands(folder)[command]]
    ro.chmod(0o555)
    try:
        line = _error(capsys, main(argv))
    finally:
        ro.chmod(0o755)
    assert f"error: {FIELD[command]}:" in line and str(ro) in line, line
    assert list(ro.iterdir()) == []


@pytest.mark.parametrize("command", sorted(FIELD))
def test_name_too_long_is_one_line(folder, capsys, command):
    argv = [a.replace(str(folder / "study_out"), str(folder / LONG))
            .replace(str(folder / "doe_out"), str(folder / LONG))
            .replace(str(folder / "doe_new"), str(folder / LONG / "o"))
            .replace(str(folder / "ss."), str(folder / LONG) + ".")
            .replace(str(folder / "h.csv"), str(folder / LONG) + ".csv")
            .replace(str(folder) + "/f.png", str(folder / LONG) + ".png")
            .replace(str(folder) + "/m.png", str(folder / LONG) + ".png")
            .replace(str(folder) + "/b.png", str(folder / LONG) + ".png")
            for a in _commands(folder)[command]]
    assert any(LONG in a for a in argv)
    before = _tree(folder)
    line = _error(capsys, main(argv))
    assert f"error: {FIELD[command]}:" in line and "File name too long" in line, line
    assert len(line) < 400  # the long name is shortened
    _check_nothing_changed(folder, before)


def test_optimise_out_of_space_is_one_line_and_removes_its_temporary(tmp_path, capsys,
                                                                   monkeypatch):
    """The design is replaced by a stand-in (the real one takes minutes): what is tested is
    the writing of its folder."""
    import types

    import bridgeflap.design.control.search.driver

    fake = types.SimpleNamespace(summary=lambda: {"status": "failed"}, history=lambda: [],
                                 candidate=None, controller=None, extras={})
    monkeypatch.setattr(bridgeflap.design.control.search.driver, "design",
                        lambda settings, progress=None, **kw: fake)
    out = tmp_path / "opt"
    _enospc_after(monkeypatch, 2)  # the marker written, then no room for the history
    line = _error(capsys, main(["optimise", "--quick", "--out", str(out), "--json"]))
    monkeypatch.undo()
    assert line.startswith("bridgeflap: error: out: ") and "No space left" in line, line
    assert "ipopt_history.json" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_an_os_error_without_a_path_is_still_not_a_bug(capsys, monkeypatch):
    import bridgeflap.design.cli.main

    def run(args):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(bridgeflap.design.cli.main, "cmd_rfa", run)
    monkeypatch.setattr(bridgeflap.design.cli.main, "COMMANDS", tuple(
        c if c.name != "rfa" else type(c)(c.name, c.help, c.arguments, run)
        for c in COMMANDS))
    line = _error(capsys, main(["rfa"]))
    assert "No space left on device" in line


# ------------------------------------------------------------------------------- Ctrl-C
def _interrupted(capsys, rc: int) -> None:
    """Exit 130 and the one line ``bridgeflap: interrupted`` (progress lines before it)."""
    cap = capsys.readouterr()
    assert rc == 130, cap.err
    assert cap.err.endswith("bridgeflap: interrupted\n"), cap.err
    assert cap.err.count("bridgeflap: interrupted") == 1, cap.err
    assert "Traceback" not in cap.err and "error" not in cap.err, cap.err


def _raise_keyboard_interrupt(*args, **kwargs):
    raise KeyboardInterrupt


#: command -> (module, function) where the serial run is interrupted
INTERRUPT_AT = {
    "study": ("bridgeflap.design.studies.study", "_run_one"),
    "doe": ("bridgeflap.design.batch.runner", "_execute_case"),
    "doe-new": ("bridgeflap.design.batch.runner", "_execute_case"),
    "flutter-plot": ("os", "fsync"),
    "modes-plot": ("os", "fsync"),
    "state-space": ("os", "fsync"),
    "robustness": ("bridgeflap.design.assessment.harm", "_rows_of"),
    "buffeting-plot": ("bridgeflap.model.response.buffeting", "buffeting"),
}


@pytest.mark.parametrize("command", sorted(INTERRUPT_AT))
def test_ctrl_c_is_one_line_exit_130_and_leaves_nothing(folder, capsys, monkeypatch, command):
    import importlib

    argv = _commands(folder)[command]
    before = _tree(folder)
    module, name = INTERRUPT_AT[command]
    monkeypatch.setattr(importlib.import_module(module), name, _raise_keyboard_interrupt)
    rc = main(argv)
    monkeypatch.undo()
    _interrupted(capsys, rc)
    _check_nothing_changed(folder, before)  # no temporary folder, file or lock left


def _group_gone(pgid: int, timeout: float = 60.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.1)
    return False


BIG_DOE = ('name = "bigdoe"\nbridge = "humber"\nanalysis = "flutter"\n[options]\n'
           'speeds = "0:80:1"\nmodes = 10\n[design]\nkind = "full-factorial"\n[parameters]\n'
           '"cable.main_sag_m" = {{ values = {sags} }}\n')


def _ctrl_c_group(argv: list[str], progress: str, cwd: Path) -> str:
    """Run the CLI in its own process group, wait for ``progress`` (a regular expression) on
    its stderr, send SIGINT
    to the whole group (a terminal's Ctrl-C); the exit status must be 130; its stderr."""
    env = subprocess_env(MPLBACKEND="Agg")  # the package, wherever cwd is
    proc = subprocess.Popen([sys.executable, "-c",
                             "import sys; from bridgeflap.design.cli.main import main; "
                             "sys.exit(main())",
                              *argv],
                            cwd=cwd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            start_new_session=True)
    chunks: list[bytes] = []
    reader = threading.Thread(target=lambda: chunks.extend(iter(
        lambda: proc.stderr.read1(4096), b"")), daemon=True)
    reader.start()
    try:
        deadline = time.monotonic() + 300  # a bound on a loaded machine, not a timing
        while not re.search(progress.encode(), b"".join(chunks)) and proc.poll() is None \
                and time.monotonic() < deadline:
            time.sleep(0.05)
        assert proc.poll() is None, b"".join(chunks).decode()
        os.killpg(proc.pid, signal.SIGINT)
        try:
            # the command ends by itself at most INTERRUPT_GRACE_S after the signal
            rc = proc.wait(timeout=300)
        except subprocess.TimeoutExpired:  # say what still runs and what it printed
            tree = subprocess.run(["ps", "-o", "pid,ppid,stat,etime,cmd", "-g", str(proc.pid)],
                                  capture_output=True, text=True).stdout
            pytest.fail(f"no exit 300 s after SIGINT; processes:\n{tree}\nstderr:\n"
                        + b"".join(chunks).decode(errors="replace"))
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        reader.join(timeout=60)
        proc.stderr.close()  # also on a failure: no unclosed pipe for a later test to meet
    err = b"".join(chunks).decode(errors="replace")
    assert rc == 130, err
    assert _group_gone(proc.pid), "worker processes outlived the interrupted run"
    assert err.rstrip("\n").endswith("bridgeflap: interrupted"), err
    assert err.count("bridgeflap: interrupted") == 1, err
    for bad in ("Traceback", "Error", "Exception", "error:"):
        assert bad not in err, err
    return err


@pytest.mark.parametrize("resumed", [False, True])
def test_ctrl_c_of_a_two_worker_doe_prints_no_worker_traceback(tmp_path, resumed):
    doe = tmp_path / "doe.toml"
    sags = [100.0 + 0.5 * i for i in range(60)]
    doe.write_text(BIG_DOE.format(sags=sags))
    out = tmp_path / "out"
    if resumed:  # a previous output of another definition: the run writes aside
        (tmp_path / "small.toml").write_text(DOE.format(count=4))
        assert main(["doe", str(tmp_path / "small.toml"), "--scheduler", "serial", "--json",
                     "--out", str(out)]) == 0
        before = _tree(out)
    _ctrl_c_group(["doe", str(doe), "--workers", "2", "--out", str(out)], r" [1-9]\d*/60 ",
                  tmp_path)  # a case finished
    if resumed:
        assert _tree(out) == before
    else:  # a first run keeps its finished cases where --resume finds them
        assert (out / OUTPUT_MARKER).is_file() and list((out / "cases").glob("*.json"))
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".out.")] == []


def test_ctrl_c_of_a_two_worker_robustness_run(tmp_path, _template):
    out = tmp_path / "h.csv"
    _ctrl_c_group(["robustness", "--controller", str(_template / "controller.toml"),
                   "--samples", "60", "--modes", "8", "--workers", "2", "--out", str(out)],
                  "do no harm:", tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_of_a_two_worker_study(tmp_path):
    out = tmp_path / "out"
    _ctrl_c_group(["study", "--quick", "--workers", "2", "--out", str(out)],
                  "worker processes", tmp_path)
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------- bare bridgeflap, warnings
def test_bare_bridgeflap_is_a_short_usage_and_exit_2(capsys):
    assert main([]) == 2
    cap = capsys.readouterr()
    lines = cap.err.splitlines()
    assert cap.out == "" and 2 <= len(lines) <= 5, cap.err
    assert lines[0].startswith("usage: bridgeflap") and "bridgeflap --help" in lines[-1]
    assert all(c.name in cap.err for c in COMMANDS)


@pytest.fixture()
def box_controller(tmp_path):
    """A controller file designed on humber:box: ``--bridge`` defaults to it, with a note."""
    from bridgeflap.model.aeroelastic.control import Compensator, Controller
    from bridgeflap.model.aeroelastic.controller_file import plant_record, save_controller

    k = Compensator(-1.1668156764187112, -0.03901371153086817, -1.6746219244786549,
                    0.7122695359413691, 0.08664867156606472)
    return save_controller(Controller(k, (0.0,), 50.0, flap_chord_m=3.0,
                                      plant=plant_record("humber:box", 8)),
                           tmp_path / "box.toml")


def test_a_note_then_a_refusal_is_one_line(capsys, box_controller):
    rc = main(["flutter", "--controller", str(box_controller), "--order", "full"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1, err
    assert err.startswith("bridgeflap: error: controller: "), err
    # accepted, the same note is shown (once)
    rc = main(["flutter", "--controller", str(box_controller), "--speeds", "0:20:10",
               "--modes", "4", "--json"])
    err = capsys.readouterr().err
    assert rc == 0 and err.count("bridgeflap: note: --bridge humber:box") == 1, err


@pytest.mark.filterwarnings("always::UserWarning")
def test_a_python_warning_then_a_refusal_is_one_line(capsys, monkeypatch):
    import warnings

    import bridgeflap.design.cli.main
    from bridgeflap.model.errors import BridgeflapInputError

    def run(args):
        warnings.warn("a deprecated spelling", UserWarning, stacklevel=1)
        raise BridgeflapInputError("name", "refused after the warning")

    monkeypatch.setattr(bridgeflap.design.cli.main, "COMMANDS", tuple(
        c if c.name != "rfa" else type(c)(c.name, c.help, c.arguments, run)
        for c in COMMANDS))
    rc = main(["rfa"])
    err = capsys.readouterr().err
    assert rc == 2 and err == "bridgeflap: error: name: refused after the warning\n", err
