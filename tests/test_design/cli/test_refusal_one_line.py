"""A refusal prints exactly one line on stderr: no progress line, note or warning before it,
nothing on stdout, exit status 2.

Each case is one that printed more before it was fixed: the worst erection stage's open-loop
progress before "no stage has a critical speed", and the refusals of the robustness command
added with the shared bounds (a controller designed on another bridge gives a warning line
that must not precede the refusal). Further cases: a controller warning and a progress line
before a mode count the model does not have (erection with a controller, robustness: there it
ended as an internal error, the worker's refusal could not be unpickled), the stage-design line
before "no flap strip fits", a stage design that ran before its --modes was refused, a --lags
that ran for minutes, actuator records too long to hold in memory (an internal MemoryError
after a progress line), options that only apply to another mode of the command, a global
sensitivity whose every case failed on --modes, a batch's --workers beside a --scheduler that
decides them, --quiet, which hid the error line itself, and
options of the fresh variants that robustness --failures ignored.
No physics result is compared, so there are no tolerances.
"""

from __future__ import annotations

import pickle
import re
from importlib import resources

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
    # a screening on as many modes as the reference, or with no screening: ignored before
    (["robustness", "--controller", "{c}", "--modes", "16", "--screen-modes", "16"],
     "screen-modes"),
    (["robustness", "--controller", "{c}", "--method", "reference", "--screen-modes", "8"],
     "screen-modes"),
    # the controller's warning (designed on humber) and a progress line came first
    (["erection", "--controller", "{c}", "--bridge", "{coarse}", "--modes", "90",
      "--fractions", "0.5", "--speeds", "0:10:5"], "modes"),
    (["robustness", "--controller", "{c}", "--bridge", "{coarse}", "--modes", "90"], "modes"),
    (["erection", "--design-stage", "0.001"], "fraction"),
    (["erection", "--design-stage", "0.5", "--bridge", "{coarse}", "--modes", "90"], "modes"),
    (["erection", "--save-controller", "s.toml", "--fractions", "0.5"], "--save-controller"),
    (["erection", "--card", "nosuch.toml", "--fractions", "0.5"], "--card"),
    (["derivatives", "--lags", "1000"], "lags"),
    (["actuators", "--controller", "{c}", "--duration-s", "100000", "--records", "10000"],
     "records"),
    (["optimise", "--checks", "none", "--check-samples", "5", "--out", "o"], "check-samples"),
    (["sensitivity", "--global", "morris", "--bridge", "{coarse}", "--modes", "90", "--out",
      "g"], "modes"),
    (["--quiet", "flutter", "--modes", "0"], "modes"),
    # --workers with a scheduler, whose cluster decides (it was ignored and the batch ran)
    (["doe", "{doe}", "--scheduler", "serial", "--workers", "2"], "workers"),
    (["sensitivity", "--global", "morris", "--scheduler", "serial", "--workers", "2", "--out",
      "g"], "workers"),
    # options of the fresh variants that --failures ignored (it ran, and exited 1)
    *[(["robustness", "--controller", "{c}", "--bridge", "great-belt", "--failures", option,
        value], option.lstrip("-")) for option, value in (
        ("--method", "reference"), ("--screen-modes", "8"), ("--seed", "3"))],
]

HUMBER = resources.files("bridgeflap.model.bridges").joinpath("humber.toml").read_text("utf-8")
#: Humber on 140 m elements: 48 vertical and torsional modes (51 on the erected half)
COARSE = re.sub(r"^element_length_m = \{ value = [0-9.]+", "element_length_m = { value = 140.0",
                HUMBER, count=1, flags=re.M)


@pytest.mark.parametrize("argv, field", CASES,
                         ids=[f"{a[0] if a[0] != '--quiet' else 'quiet'}-{f}"
                              + ("-failures" if "--failures" in a else "") for a, f in CASES])
def test_a_refusal_prints_one_line(argv, field, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    c = save_controller(Controller(Compensator(0.0, 0.1, 0.5, 0.0, 0.1), (0.0,), 10.0,
                                   flap_chord_m=3.0, plant=plant_record("humber", 8)),
                        tmp_path / "c.toml")
    (tmp_path / "coarse.toml").write_text(COARSE, encoding="utf-8")
    doe = tmp_path / "doe.toml"     # (refused before it is read)
    doe.write_text('name = "d"\nanalysis = "flutter"\n', encoding="utf-8")
    rc = main([a.format(c=c, coarse=tmp_path / "coarse.toml", doe=doe) for a in argv])
    cap = capsys.readouterr()
    assert rc == 2 and cap.out == "", cap
    assert cap.err.splitlines() == [cap.err.rstrip("\n")], cap.err  # exactly one line
    assert cap.err.startswith(f"bridgeflap: error: {field}: "), cap.err
    # nothing written
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.toml", "coarse.toml", "doe.toml"]


@pytest.mark.parametrize("error", ["input", "type", "batch"])
def test_errors_cross_processes(error):
    """A worker's refusal reaches the parent as the same error (a process pool pickles it):
    its class, field and message."""
    from bridgeflap.model.errors import BatchFailedError, BridgeflapInputError, BridgeflapTypeError

    exc = {"input": BridgeflapInputError("modes", "too many"),
           "type": BridgeflapTypeError("bridge", "must be a name"),
           "batch": BatchFailedError(3, "/tmp/out", "modes: too many")}[error]
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is type(exc) and str(back) == str(exc)
    assert getattr(back, "field", None) == getattr(exc, "field", None)


def test_do_no_harm_refuses_modes_beyond_the_model(tmp_path):
    """The API's refusal of a mode count the model does not have comes before any work (it was
    a BrokenProcessPool from the first worker)."""
    from bridgeflap.design.assessment.harm import do_no_harm
    from bridgeflap.model.errors import BridgeflapInputError

    (tmp_path / "coarse.toml").write_text(COARSE, encoding="utf-8")
    c = save_controller(Controller(Compensator(0.0, 0.1, 0.5, 0.0, 0.1), (0.0,), 10.0,
                                   flap_chord_m=3.0, plant=plant_record("humber", 8)),
                        tmp_path / "c.toml")
    lines = []
    with pytest.raises(BridgeflapInputError, match=r"^n_modes: 90 requested"):
        do_no_harm(c, tmp_path / "coarse.toml", n_modes=90, workers=2, progress=lines.append)
    assert lines == []
