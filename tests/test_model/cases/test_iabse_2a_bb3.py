"""IABSE TG3.1 step 2a with the measured "BB3" flutter derivatives: ``iabse-2a:bb3``.

The bridge file's ``[variants.bb3.derivatives]`` section (model/bridges/iabse/
step2a_bridge.toml, :class:`bridgeflap.model.structure.modal_import.DerivativeLoads`) drives the
self-excited loads from the shipped BB3 PoliMi tables (step2a_bb3_derivatives.json) through a 3-lag
Roger RFA on all 12 modes with the lateral DOF
(:func:`bridgeflap.model.aeroelastic.derivative_system.derivative_bridge_system`, the hook of
:func:`bridgeflap.model.analysis.bridge_system`); the exact p-k on the interpolated tables is the
cross-check. Reference: 69.8 m/s (wawi tests/test_IABSE_step2a.py, "reference value from
paper", 3 figures); the independent wawi-style p-k of tests/test_modal_import.py gives 69.855
m/s with the lateral DOF and 68.31 m/s without.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from bridgeflap.model.aeroelastic.derivative_system import DerivativeSystem
from bridgeflap.model.analysis import bridge_system, flutter
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.stability import sweeps as stability
from bridgeflap.model.structure.loader import load_bridge
from bridgeflap.model.structure.modal_import import derivatives_from_dict

SPEEDS = np.arange(0.0, 100.01, 0.5)
PK_SPEEDS = np.arange(1.0, 100.0, 1.0)   # p-k continued from still air
REFERENCE_M_S = 69.8
WAWI_STYLE_M_S = 69.855                  # tests/test_modal_import.py, lateral DOF included
WAWI_STYLE_NO_LATERAL_M_S = 68.31


@pytest.fixture(scope="module")
def bb3():
    spec = load_bridge("iabse-2a:bb3")
    _, system = bridge_system(spec, 30)
    return spec, system


def test_bb3_system_is_the_derivative_state_space_on_12_modes(bb3):
    spec, system = bb3
    assert isinstance(system, DerivativeSystem)
    assert system.basis.n == 12                  # 6 vertical + 3 torsional... all 12, lateral too
    assert system.rfa.n_lags == 3 and system.n_states == 12 * (2 + 3)
    assert system.extras["lateral_dof"] is True
    assert np.all(system.rfa.poles > 0)          # stable lag states


def test_bb3_rfa_flutter_within_2_percent_of_the_reference(bb3):
    """2 %. What it covers: the reference is given to 3 figures (0.07 %);
    the RFA's load error near the flutter reduced frequency (K = 0.45-0.75) is at most 3.8 %
    of the largest term of each load (1.7 % at K = 0.61), A2 within 1.3 %, and gives 0.3 %
    against the exact p-k below; the strip (12 m) vs node (trapezoid) integration 0.1 % (the
    p-k against the wawi-style p-k). Measured: 69.74 m/s, -0.09 %."""
    spec, _ = bb3
    r = flutter(spec, SPEEDS).summary()
    assert r["flutter_status"] == "converged"
    assert r["flutter_speed_m_s"] == pytest.approx(REFERENCE_M_S, rel=0.02)
    # the benchmark's flutter frequency is not published as a number; wawi's 0.2175 Hz
    assert r["flutter_frequency_hz"] == pytest.approx(0.2175, rel=0.02)
    assert r["modes_retained"] == 12 and r["rfa"].startswith("roger3")
    # TS1 drives it, coupled with VS1 (the tracked label may swap with VA4 where they cross)
    part = r["critical_participation"]
    assert max(part, key=part.get) == "TS1" and part["VS1"] > 0.3


def test_bb3_exact_pk_and_rfa_agree(bb3):
    """Exact p-k on the interpolated tables (bridgeflap.model.stability.sweeps.pk_sweep on
    ``frozen()``).

    Against the wawi-style p-k on the file's nodes: 0.5 %, the strip vs trapezoid integration
    of piecewise-linear shapes (0.25 % on the flat plate, test_modal_import.py); measured
    0.11 %. RFA vs p-k: 1 %, the RFA's load error near flutter (3.8 % of the largest term at
    worst, mostly in H4 and A1 which enter weakly); measured 0.28 %."""
    spec, system = bb3
    pk = stability.pk_sweep(system, PK_SPEEDS)
    assert pk.flutter.status == "converged"
    assert pk.flutter.speed == pytest.approx(WAWI_STYLE_M_S, rel=5e-3)
    assert pk.flutter.speed == pytest.approx(REFERENCE_M_S, rel=0.02)
    r = flutter(spec, SPEEDS).summary()
    assert r["flutter_speed_m_s"] == pytest.approx(pk.flutter.speed, rel=0.01)
    assert r["flutter_frequency_hz"] == pytest.approx(pk.flutter.frequency_hz, rel=0.01)


def test_bb3_without_the_lateral_dof_is_2_percent_low(bb3):
    """``lateral = false``: vertical and torsional modes only (9), no P derivatives; the
    wawi-style p-k gives 68.31 m/s. 0.5 % as above (measured: RFA 68.31, p-k 68.39)."""
    spec, _ = bb3
    vt = dataclasses.replace(spec, derivatives=dataclasses.replace(spec.derivatives,
                                                                   lateral=False))
    r = flutter(vt, SPEEDS).summary()
    assert r["modes_retained"] == 9
    assert r["flutter_speed_m_s"] == pytest.approx(WAWI_STYLE_NO_LATERAL_M_S, rel=5e-3)
    assert r["flutter_speed_m_s"] < 0.985 * REFERENCE_M_S


def test_flat_plate_iabse_2a_is_unchanged():
    """The flat-plate definition keeps the Theodorsen path; its numbers are the golden case
    flutter_iabse_2a (1e-9, the golden test's tolerance)."""
    spec = load_bridge("iabse-2a")
    assert spec.derivatives is None
    _, system = bridge_system(spec, 30)
    assert not isinstance(system, DerivativeSystem) and system.basis.n == 9
    gold = json.loads((Path(__file__).resolve().parents[2] / "golden" / "flutter_iabse_2a.json")
                      .read_text("utf-8"))
    gold = gold["stdout"]
    # the golden case is the CLI's flutter, whose default is the fast sweep
    r = flutter(spec, np.arange(0.0, 85.01, 0.5), sweep_method="fast").summary()
    assert r["flutter_speed_m_s"] == pytest.approx(gold["flutter_speed_m_s"], rel=1e-9)
    assert r["rfa"] == "rfa4"


@pytest.mark.parametrize("over, field", [
    ({"file": 3}, "derivatives.file"),
    ({"form": "csv"}, "derivatives.form"),
    ({"fit_k_range": [1.0, 0.5]}, "derivatives.fit_k_range"),
    ({"n_lags": -1}, "derivatives.n_lags"),
    ({"weighting": "x"}, "derivatives.weighting"),
    ({"lateral": "yes"}, "derivatives.lateral"),
    ({"poles": [1]}, "derivatives.poles"),
])
def test_bad_derivatives_section_names_the_field(over, field):
    table = {"file": "step2a_bb3_derivatives.json", **over}
    with pytest.raises(BridgeflapInputError) as e:
        derivatives_from_dict(table, Path("."))
    assert e.value.field == field


def test_bad_derivative_file_names_the_field(tmp_path):
    src = Path(load_bridge("iabse-2a:bb3").derivatives.file)
    d = json.loads(src.read_text("utf-8"))
    d["polimi"]["a"][2][1] = float("nan")
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(d), "utf-8")
    loads = derivatives_from_dict({"file": str(bad)}, tmp_path)
    with pytest.raises(BridgeflapInputError) as e:
        loads.table(31.0)
    assert e.value.field == "derivatives.polimi.a"
    d = json.loads(src.read_text("utf-8"))
    d["v_pitch"] = d["v_pitch"][::-1]
    bad.write_text(json.dumps(d), "utf-8")
    with pytest.raises(BridgeflapInputError) as e:
        derivatives_from_dict({"file": str(bad)}, tmp_path).table(31.0)
    assert e.value.field == "derivatives.v_pitch"


def test_cli_flutter_bb3_has_the_humber_keys_and_pk(capsys):
    from bridgeflap.design.cli.main import main

    rc = main(["flutter", "--bridge", "iabse-2a:bb3", "--json", "--pk"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0
    rc = main(["flutter", "--bridge", "iabse-2a", "--json"])
    ref = json.loads(capsys.readouterr().out)
    pk_keys = {"pk_flutter_speed_m_s", "pk_flutter_frequency_hz", "pk_flutter_status",
               "pk_critical_branch_label"}
    assert rc == 0 and set(out) == set(ref) | pk_keys
    assert out["bridge"] == "iabse-2a:bb3" and out["modes_retained"] == 12
    assert out["truncation_status"] == "all_modes_retained"
    # 1 % as in test_bb3_exact_pk_and_rfa_agree (the CLI grid 0-85 m/s)
    assert out["pk_flutter_status"] == "converged"
    assert out["pk_flutter_speed_m_s"] == pytest.approx(out["flutter_speed_m_s"], rel=0.01)


def test_cli_derivatives_reports_the_bb3_fit(capsys):
    from bridgeflap.design.cli.main import main

    rc = main(["derivatives", "--bridge", "iabse-2a:bb3", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0
    assert out["derivatives"] == "step2a_bb3_derivatives" and out["n_lags"] == 3
    assert out["fit_k_min"] == pytest.approx(0.1) and "P1" in out["fit_relative_error"]
