"""Compensator design (design/problem.py): settings, constraints, a real Humber solve (slow)."""

import numpy as np
import pytest

from design.problem import DesignProblem, _build_model, load_settings
from model.errors import BridgeflapInputError


def test_settings_reject_bad_gain_bound(tmp_path):
    f = tmp_path / "d.toml"
    f.write_text("[constraints]\ngain_limit = 0.0\n")
    with pytest.raises(BridgeflapInputError, match="gain_limit"):
        load_settings(f)
    f.write_text("nonsense = 1\n")
    with pytest.raises(BridgeflapInputError, match="nonsense"):
        load_settings(f)


def test_cli_optimise_bad_input_writes_nothing(tmp_path):
    from design.cli import main

    f = tmp_path / "d.toml"
    f.write_text("gain_limit = -1.0\n")
    out = tmp_path / "out"
    assert main(["optimise", str(f), "--out", str(out), "--json"]) == 2
    assert not out.exists()


def test_packaged_definition_loads():
    from pathlib import Path

    s = load_settings(Path(__file__).resolve().parents[1] / "runs" / "humber_flaps.toml")
    assert s.flap_count == 25 and s.gain_limit == 15.0
    assert s.flap_count * s.flap_width_m == pytest.approx(1410.0)


@pytest.mark.slow
def test_humber_design_solve():
    # One real Humber solve (12 modes, 5 m/s design grid, cutting planes, 0.25 m/s check).
    s = load_settings(starts=1, cutting_plane_rounds=2)
    _, model = _build_model(s)
    prob = DesignProblem(s, model)
    th0 = np.array([0.0, 0.5, -1.0, 0.05, 0.5])
    res = prob.solve_with_cuts(th0)
    assert isinstance(res["status"], str)          # every solve reports its Ipopt status
    assert res["success"], res["status"]
    ver = res["verification"]
    # closed loop stable at every speed 0..85 m/s on the 0.25 m/s grid, with the decay rate
    assert ver["stable_everywhere"] and ver["stable_to_m_s"] == 85.0
    assert ver["max_violation"] <= 1e-6
    assert ver["max_gain"] <= s.gain_limit * (1 + 1e-6)
    # the dense check reproduces the optimiser's constraint values at the optimum: same
    # matrices, same eig; only Ipopt's scaling differs (1e-9 1/s of ~1e-2 values)
    speeds = np.array(res["design_speeds"])
    dense = prob.constraint_values(res["theta"], speeds).ravel()
    np.testing.assert_allclose(dense, res["constraints_eig"], atol=1e-9)
    # open loop flutters at ~66 m/s in this model: the design really changes the answer
    ol = prob.verify(np.array([0.0, 0.0, 0.0, 1.0, 1.0]))
    assert ol["stable_to_m_s"] < 70.0
