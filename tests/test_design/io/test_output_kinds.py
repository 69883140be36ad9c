"""Typed output folders: one command's output is never replaced by another's.

Every bridgeflap output folder carries a marker naming the command that wrote it
(:func:`bridgeflap.design.io.outputs.write_marker`). ``study --out``, ``optimise --out`` and ``doe
--out`` refuse a folder that holds another kind of output, before any work and with nothing written:
exit 2, one line naming ``out`` and both kinds, the folder byte-identical afterwards. Each CLI
case is refused before its analysis runs (the check follows only the input parsing), so this
file takes seconds.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from bridgeflap.design.cli.main import main
from bridgeflap.design.io.outputs import check_replaceable, claim_output, write_marker
from bridgeflap.model.errors import BridgeflapInputError

ROOT = Path(__file__).resolve().parents[3]


def _snapshot(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` (relative path -> sha256), to show nothing changed."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _folder(root: Path, kind: str) -> Path:
    """A complete-looking output folder of ``kind`` with a result file and a case file."""
    out = root / f"{kind}_out"
    (out / "cases").mkdir(parents=True)
    write_marker(out, kind)
    (out / "result.json").write_text('{"kept": true}')
    (out / "cases" / "case-0000.json").write_text('{"case": 0}')
    (out / "controller.toml").write_text("# a controller\n")
    return out


@pytest.mark.parametrize("kind, other", [("doe", "study"), ("study", "optimise"),
                                         ("optimise", "study"), ("batch", "doe")])
def test_check_replaceable_refuses_another_kind(tmp_path, kind, other):
    out = _folder(tmp_path, kind)
    before = _snapshot(out)
    with pytest.raises(BridgeflapInputError) as err:
        check_replaceable(out, "out", other)
    msg = str(err.value)
    assert "out" in msg and f"bridgeflap {kind} output" in msg and f"not a {other}" in msg
    with pytest.raises(BridgeflapInputError):
        with claim_output(out, "out", kind=other):
            pass  # pragma: no cover - refused before the body
    assert _snapshot(out) == before
    # the same kind, no kind, and an empty folder are accepted as before
    assert check_replaceable(out, "out", kind) == out.absolute()
    assert check_replaceable(out, "out") == out.absolute()
    empty = tmp_path / "empty"
    empty.mkdir()
    assert check_replaceable(empty, "out", other) == empty.absolute()


def _study_file(tmp_path: Path) -> Path:
    return ROOT / "runs" / "humber" / "study.toml"


@pytest.mark.parametrize("command, kind", [
    (["study", "--quick"], "doe"),        # study over a DOE used to delete its cases and table
    (["study", "--quick"], "optimise"),   # ... and an optimise folder's controller.toml
    (["optimise"], "study"),              # optimise over a study used to delete the study
    (["doe", str(ROOT / "runs" / "doe_gj_sag" / "doe.toml")], "study"),
])
def test_cli_refuses_another_commands_folder(tmp_path, capsys, command, kind):
    if command[0] == "doe" and not Path(command[1]).is_file():
        pytest.skip("no packaged DOE file in this checkout")  # pragma: no cover
    out = _folder(tmp_path, kind)
    before = _snapshot(out)
    rc = main([*command, "--out", str(out), "--json"])
    captured = capsys.readouterr()
    lines = [ln for ln in captured.err.splitlines() if ln.strip()]
    assert rc == 2, captured.err
    assert len(lines) == 1 and "out" in lines[0] and kind in lines[0], captured.err
    assert "Traceback" not in captured.err and captured.out == ""
    assert _snapshot(out) == before
    assert not any(p.name.startswith(".") and p.name.endswith(".lock")
                   for p in tmp_path.iterdir()), "a lock file was left behind"


def test_run_lock_is_exclusive_and_leaves_no_file(tmp_path):
    """The run lock refuses a second claim (another thread too) and is removed on release."""
    import threading

    out = tmp_path / "out"
    refused = []
    with claim_output(out, "out", kind="study"):
        assert (tmp_path / ".out.lock").is_file()

        def other():
            try:
                with claim_output(out, "out", kind="study"):
                    pass  # pragma: no cover - refused
            except BridgeflapInputError as exc:
                refused.append(str(exc))

        t = threading.Thread(target=other)
        t.start()
        t.join()
    assert refused and "lock .out.lock held" in refused[0]
    assert not (tmp_path / ".out.lock").exists()
    # a stale lock file (a killed run's: the kernel dropped its lock) is taken over and removed
    (tmp_path / ".out.lock").write_text("")
    with claim_output(out, "out", kind="study"):
        pass
    assert not (tmp_path / ".out.lock").exists()
