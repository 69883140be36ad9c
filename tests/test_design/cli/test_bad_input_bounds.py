"""Counts and targets with stated bounds, refused in one line before any work or progress line:
a card's counts, ``optimise --check-samples``, ``erection --design-stage`` with a missing card or
an unusable ``--save-controller`` target (each used to run for minutes, or end in an internal
error, before saying so)."""

from __future__ import annotations

import pytest

from bridgeflap.design.cli.main import main


def _card(tmp_path, text):
    p = tmp_path / "card.toml"
    p.write_text(text)
    return str(p)


@pytest.mark.parametrize("argv,field", [
    (["optimise", "--check-samples", "1000000000"], "check-samples"),
    (["optimise", "--workers", "100000"], "workers"),
    (["optimise", "{card:variants = 100000000}"], "variants"),
    (["optimise", "{card:fresh_variant_modes = 1000}"], "fresh_variant_modes"),
    (["optimise", "{card:verification_modes = 1000}"], "verification_modes"),
    (["optimise", "{card:n_modes = 101}"], "n_modes"),
    (["erection", "--design-stage", "0.5", "--card", "nope"], "card"),
    (["erection", "--design-stage", "0.5", "--save-controller", "{tmp}"], "--save-controller"),
    (["erection", "--design-stage", "0.5", "--save-controller", "{tmp}/no/such/c.toml"],
     "--save-controller"),
])
def test_refused_in_one_line_before_any_work(tmp_path, capsys, argv, field):
    out = tmp_path / "out"
    out.mkdir()
    argv = [_card(tmp_path, a[6:-1]) if a.startswith("{card:") else a.replace("{tmp}", str(out))
            for a in argv]
    if argv[0] == "optimise":
        argv += ["--out", str(out / "opt")]
    rc = main(argv)
    cap = capsys.readouterr()
    lines = [x for x in cap.err.splitlines() if x.strip()]
    assert rc == 2, cap.err
    # one line, naming the field; no progress line before it (validation before the work)
    assert len(lines) == 1 and lines[0].startswith(f"bridgeflap: error: {field}:"), cap.err
    assert "Traceback" not in cap.err and cap.out == ""
    assert list(out.iterdir()) == []      # nothing written
