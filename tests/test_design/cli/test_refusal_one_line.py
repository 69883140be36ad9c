"""A refusal prints exactly one line on stderr: no progress line, note or warning before it,
nothing on stdout, exit status 2.

Each case is one that printed more before it was fixed: the worst erection stage's open-loop
progress before "no stage has a critical speed", and the refusals of the robustness command
added with the shared bounds (a controller designed on another bridge gives a warning line
that must not precede the refusal). No physics result is compared, so there are no tolerances.
"""

from __future__ import annotations

import pytest

from bridgeflap.design.cli.main import main
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.aeroelastic.controller_file import plant_record, save_controller

CASES = [
    (["erection", "--design-stage", "worst", "--speeds", "0:5:1", "--fractions", "0.5",
      "--modes", "4"], "--design-stage"),
    (["robustness", "--controller", "{c}", "--bridge", "great-belt", "--samples", "100001"],
     "samples"),
    (["robustness", "--controller", "{c}", "--bridge", "great-belt", "--speed-max", "1e6"],
     "speed-max"),
    (["robustness", "--controller", "{c}", "--bridge", "great-belt", "--failures",
      "--scheduler", "local"], "scheduler"),
    (["robustness", "--controller", "{c}", "--bridge", "great-belt", "--seed", "-1"], "seed"),
]


@pytest.mark.parametrize("argv, field", CASES, ids=[f"{a[0]}-{f}" for a, f in CASES])
def test_a_refusal_prints_one_line(argv, field, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    c = save_controller(Controller(Compensator(0.0, 0.1, 0.5, 0.0, 0.1), (0.0,), 10.0,
                                   flap_chord_m=3.0, plant=plant_record("humber", 8)),
                        tmp_path / "c.toml")
    rc = main([a.format(c=c) for a in argv])
    cap = capsys.readouterr()
    assert rc == 2 and cap.out == "", cap
    assert cap.err.splitlines() == [cap.err.rstrip("\n")], cap.err  # exactly one line
    assert cap.err.startswith(f"bridgeflap: error: {field}: "), cap.err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.toml"]  # nothing written
