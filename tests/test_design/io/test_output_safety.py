"""Nothing that is not ours is touched: a planted lock link is not followed, a read-only output
folder is refused, a folder of the user's named like a temporary is kept, the temporary of a run
killed while writing its marker is removed, and SIGTERM ends a
command like Ctrl-C (one line, its ``finally`` clean-up run). No physics: no tolerances."""

from __future__ import annotations

import argparse
import os
import signal
from pathlib import Path

import pytest

from bridgeflap.design.cli.run import run
from bridgeflap.design.io import files
from bridgeflap.design.io.outputs import claim_output, lock_path, recover_output, write_marker
from bridgeflap.model.errors import BridgeflapInputError


def _dead_pid() -> int:
    pid = os.fork()
    if pid == 0:
        os._exit(0)
    os.waitpid(pid, 0)
    return pid


def test_a_dangling_lock_link_is_not_followed(tmp_path):
    outside = tmp_path / "elsewhere" / "planted"
    outside.parent.mkdir()
    link = lock_path(tmp_path / "out")
    link.symlink_to(outside)
    with pytest.raises(BridgeflapInputError, match=r"^out: .*symbolic link"):
        with claim_output(tmp_path / "out"):
            pass
    assert not outside.exists() and link.is_symlink()  # nothing created at the link's target


def test_a_read_only_output_folder_is_refused_untouched(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    write_marker(out, "study")
    before = (out / ".bridgeflap-output").read_bytes()
    out.chmod(0o555)
    try:
        with pytest.raises(BridgeflapInputError, match=r"^out: .*read-only"):
            with claim_output(out, kind="study"):
                pass
        assert (out / ".bridgeflap-output").read_bytes() == before
        assert not lock_path(out).exists()
    finally:
        out.chmod(0o755)


def test_only_our_marked_temporaries_of_dead_runs_are_removed(tmp_path):
    target, gone = tmp_path / "s1out", _dead_pid()
    users = tmp_path / f".s1out.tmp-{gone}-mine"  # a user's folder named like one of ours
    unmarked = tmp_path / f".s1out.tmp-{gone}-0123abcd"  # our spelling, not marked, not empty
    ours = tmp_path / f".s1out.tmp-{gone}-89abcdef"
    for folder in (users, unmarked, ours):
        folder.mkdir()
        (folder / "keep.txt").write_text("mine")
    write_marker(ours, "study")
    recover_output(target, say=lambda text: None)
    assert not ours.exists()
    assert (users / "keep.txt").read_text() == "mine"
    assert (unmarked / "keep.txt").read_text() == "mine"


def test_sigterm_ends_a_command_like_ctrl_c(tmp_path, capsys):
    cleaned = tmp_path / "cleaned"

    def command(args):
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            signal.pause()  # never reached past the handler
        finally:
            cleaned.touch()

    def build_parser(argv):
        parser = argparse.ArgumentParser()
        parser.set_defaults(command="term", func=command)
        return parser

    rc = run([], False, build_parser=build_parser, check_args=lambda a: None,
             command_names=["term"])
    assert rc == 128 + signal.SIGTERM and cleaned.exists()
    assert capsys.readouterr().err.strip().splitlines() == ["bridgeflap: interrupted"]
    assert signal.getsignal(signal.SIGTERM) is not None  # restored


def test_a_run_killed_while_writing_its_marker_leaves_no_temporary(tmp_path, monkeypatch):
    """Killed between its marker's temporary file and the rename (the marker is written
    atomically): the folder holds only ``.bridgeflap-output.<12 hex>.tmp``, and the next run
    removes it. The same file beside anything else keeps the folder (not provably ours)."""
    target, gone = tmp_path / "s1out", _dead_pid()
    half = tmp_path / f".s1out.tmp-{gone}-0123abcd"
    mixed = tmp_path / f".s1out.tmp-{gone}-4567abcd"
    for folder in (half, mixed):
        folder.mkdir()
        # the temporary file exactly as write_marker leaves it when killed before its rename
        # (os.replace skipped: the name comes from the code, not from this test)
        left: list[Path] = []
        monkeypatch.setattr(files.os, "replace", lambda src, dst, left=left: left.append(Path(src)))
        write_marker(folder, "study")
        monkeypatch.undo()
        assert [p.name for p in folder.iterdir()] == [left[0].name]
    (mixed / "keep.txt").write_text("mine")
    recover_output(target, say=lambda text: None)
    assert not half.exists()
    assert (mixed / "keep.txt").read_text() == "mine"
