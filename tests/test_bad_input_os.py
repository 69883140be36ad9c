"""The OS refusing a write, Ctrl-C, a bare ``bridgeflap`` and warnings before an error (issue 30
items 2-4), as bad-input cases of the contract of tests/test_bad_input.py.

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
from pathlib import Path

import pytest

from design.cli import COMMANDS, main

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
    from model.control import Compensator, Controller
    from model.controller_file import save_controller

    d = tmp_path_factory.mktemp("template") / "d"
    d.mkdir()
    (d / "study.toml").write_text(STUDY.format(count=4))
    (d / "doe.toml").write_text(DOE.format(count=4))
    k = Compensator(-1.1668156764187112, -0.03901371153086817, -1.6746219244786549,
                    0.7122695359413691, 0.08664867156606472)
    save_controller(Controller(k, tuple(56.4 * i for i in range(-12, 13)), 56.4,
                               flap_chord_m=5.0), d / "controller.toml")
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
    assert str(folder) in line and "No space left on device" in line, line
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
    assert os.strerror(code) in line and str(folder) in line, line
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

    import design.driver

    fake = types.SimpleNamespace(summary=lambda: {"status": "failed"}, history=lambda: [],
                                 candidate=None, controller=None)
    monkeypatch.setattr(design.driver, "design", lambda settings, progress=None: fake)
    out = tmp_path / "opt"
    _enospc_after(monkeypatch, 2)  # the marker written, then no room for the history
    line = _error(capsys, main(["optimise", "--quick", "--out", str(out), "--json"]))
    monkeypatch.undo()
    assert line.startswith("bridgeflap: error: out: ") and "No space left" in line, line
    assert "ipopt_history.json" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_an_os_error_without_a_path_is_still_not_a_bug(capsys, monkeypatch):
    import design.cli

    def run(args):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(design.cli, "cmd_rfa", run)
    monkeypatch.setattr(design.cli, "COMMANDS", tuple(
        c if c.name != "rfa" else type(c)(c.name, c.help, c.arguments, run)
        for c in COMMANDS))
    line = _error(capsys, main(["rfa"]))
    assert "No space left on device" in line
