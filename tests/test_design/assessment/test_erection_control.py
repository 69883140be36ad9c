"""Erection with flaps: each stage's closed loop with the controller's flap
strips that lie on its erected deck (design/assessment/erection_control.py, `bridgeflap erection
--controller`)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bridgeflap.design.assessment.erection_control import erection_closed_loop, flaps_on_deck
from bridgeflap.design.cli.main import main
from bridgeflap.design.io.files import to_jsonable
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.aeroelastic.controller_file import save_controller
from bridgeflap.model.analysis import closed_loop_flutter
from bridgeflap.model.structure.loader import load_bridge

#: the default card's K (tests/test_harm.py) on its 18 placed strips (+-225.6 .. 676.8 m)
K = Compensator(-1.0520215923792988, 0.724204088492299, -4.9906722869878095,
                0.24572479364985136, 0.19628837741003988)
POSITIONS = tuple(56.4 * i for i in range(-12, 13) if abs(i) >= 4)
U = np.arange(0.0, 120.0 + 1e-9, 2.0)


@pytest.fixture(scope="module")
def humber():
    return load_bridge("humber").replace(**{"mesh.element_length_m": 47.0})


def test_strips_on_the_erected_deck(humber):
    c = Controller(K, POSITIONS, 56.4, flap_chord_m=3.0)
    # 1410 m main span: 20 % is +-141 m (no strip), 50 % +-352.5 m (strips to 338.4 +- 28.2 m
    # fit: 225.6, 282.0; 338.4 + 28.2 = 366.6 does not)
    assert flaps_on_deck(c, humber, 0.2) == ()
    assert sorted(abs(x) for x in flaps_on_deck(c, humber, 0.5)) == pytest.approx(
        [225.6, 225.6, 282.0, 282.0])
    assert flaps_on_deck(c, humber, 1.0) == POSITIONS


def test_stages_without_flaps_are_open_loop_and_the_completed_bridge_is_the_closed_loop(humber):
    c = Controller(K, POSITIONS, 56.4, flap_chord_m=3.0)
    res = erection_closed_loop(humber, c, [0.2], U, 6)
    first, done = res.rows[0], res.rows[-1]
    assert first["flap_strips_on_deck"] == 0 and first["loop"].startswith("open")
    assert first["closed_loop_critical_speed_m_s"] == first["open_loop_critical_speed_m_s"]
    # the completed bridge row is model.analysis.closed_loop_flutter itself (same function,
    # spec, grid and modes: equal to round-off)
    ref = closed_loop_flutter(humber.completed(), c, U, 6)
    assert done["closed_loop_critical_speed_m_s"] == pytest.approx(
        ref.base.summary()["critical_speed_m_s"], rel=1e-12)
    assert done["open_loop_critical_speed_m_s"] == pytest.approx(
        ref.open_loop.summary()["critical_speed_m_s"], rel=1e-12)
    # the designed K lifts the completed bridge (88 m/s against 69 m/s on 30 modes)
    assert done["closed_over_open"] > 1.0
    s = res.summary()
    json.dumps(to_jsonable(s), allow_nan=False)     # NaN (no crossing) -> null, as the CLI
    assert s["worst_stage_erected_fraction"] == 0.2


def test_cli_erection_with_controller(tmp_path, capsys):
    path = save_controller(Controller(K, POSITIONS, 56.4, flap_chord_m=3.0),
                           tmp_path / "c.toml")
    assert main(["erection", "--controller", str(path), "--fractions", "0.6:0.6:0.1",
                 "--speeds", "0:120:2", "--modes", "6", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [r["erected_fraction"] for r in out["stages"]] == [0.6, 1.0]
    assert out["stages"][0]["flap_strips_on_deck"] == 8


def test_stage_flap_count_is_the_strips_that_fit(humber):
    from bridgeflap.design.assessment.erection_control import stage_flap_count

    # 20 % of 1410 m = 282 m = 5 x 56.4 m exactly (the edge case: 1e-9 slack); 10 %: 2.5 -> 2
    assert stage_flap_count(humber, 0.2, 56.4) == 5
    assert stage_flap_count(humber, 0.1, 56.4) == 2
    assert stage_flap_count(humber, 0.03, 56.4) == 0
    c = Controller(K, tuple((np.arange(5) - 2.0) * 56.4), 56.4, flap_chord_m=3.0)
    assert len(flaps_on_deck(c, humber, 0.2)) == 5  # the stage layout lies on its deck


def test_design_stage_bad_input_is_one_line(capsys):
    assert main(["erection", "--design-stage", "early", "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--design-stage" in err[0] and "worst" in err[0]
    assert main(["erection", "--design-stage", "0.03"]) == 2  # no strip fits on 42 m
    assert "no 56.4 m flap strip fits" in capsys.readouterr().err


@pytest.mark.slow
def test_a_stage_design_lifts_its_stage(humber):
    # the 20 % stage (open loop 32.6 m/s on 30 modes) on a 6-mode model: the stage design's
    # closed-loop critical speed lies above the stage's open-loop one (measured 30 modes:
    # 55 m/s against 32.6 m/s, README)
    from bridgeflap.design.assessment.erection_control import design_for_stage

    res = design_for_stage(humber, 0.2, n_modes=6, verification_modes=6,
                           fresh_variant_modes=6)
    assert res.status == "converged" and res.controller is not None
    assert len(res.controller.flap_strip_positions_m) == 5
    lim = res.extras["closed_loop_limits"]
    ol = min(lim["open_loop_flutter_speed_m_s"], lim["open_loop_divergence_speed_m_s"])
    assert lim["governing_speed_m_s"] > 1.2 * ol  # 20 %: a lift far above the RFA/grid noise
