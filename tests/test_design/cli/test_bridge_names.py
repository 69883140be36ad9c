"""Every bridge name that the CLI takes is taken in study and DOE files too:
built-in names with a variant (``humber:box``, ``iabse-2a:bb3``), built-ins whose
file name differs from their name (``great-belt``, ``iabse-2a``), and a TOML path with a
variant; and a parameter the bridge cannot take is refused when the file is loaded."""

from __future__ import annotations

from pathlib import Path

import pytest

from bridgeflap.design.studies.experiments import doe_fingerprint, doe_from_dict
from bridgeflap.design.studies.study import load_study
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.structure.loader import load_bridge

ROOT = Path(__file__).resolve().parents[3]


def _doe(bridge: str, param: str = "aero.air_density_kg_m3") -> dict:
    return {"name": "t", "bridge": bridge, "analysis": "flutter",
            "design": {"kind": "full-factorial", "levels": 2},
            "parameters": {param: [1.2, 1.25]}}


@pytest.mark.parametrize("bridge", ["humber", "humber:box", "great-belt", "iabse-2a",
                                    "iabse-2a:bb3"])
def test_doe_takes_every_builtin_name(bridge):
    cfg = doe_from_dict(_doe(bridge))
    assert cfg.bridge == bridge
    fp = doe_fingerprint(cfg)  # reads the built-in file by its own file name
    assert bridge in fp and "bridge_sha256" in fp


def test_doe_and_study_take_a_path_with_variant(tmp_path):
    src = ROOT / "model" / "bridges" / "humber.toml"
    (tmp_path / "my.toml").write_text(src.read_text("utf-8"), "utf-8")
    cfg = doe_from_dict(_doe("my.toml:box"), base=tmp_path)
    assert cfg.bridge == f"{tmp_path / 'my.toml'}:box"
    assert load_bridge(cfg.bridge).deck.half_chord_m == load_bridge("humber:box").deck.half_chord_m
    text = (ROOT / "runs" / "humber" / "study.toml").read_text("utf-8")
    study = tmp_path / "study.toml"
    study.write_text(text.replace('bridge = "humber"', 'bridge = "humber:box"', 1), "utf-8")
    assert load_study(study).bridge == "humber:box"


def test_fe_parameter_on_a_modal_bridge_refused_at_load():
    with pytest.raises(BridgeflapInputError) as err:
        doe_from_dict(_doe("iabse-2a", "deck.gj_nm2") | {"parameters": {"deck.gj_nm2": [1, 2]}})
    assert err.value.field == "parameters.deck.gj_nm2"
    assert "cable/FE model" in err.value.reason


def _always_fails(params):
    raise RuntimeError("this case cannot run")


def test_batch_where_every_case_fails_raises(tmp_path):
    from bridgeflap.design.batch.runner import run_batch
    from bridgeflap.model.errors import BatchFailedError

    cases = [{"case_id": f"c{i}", "x": float(i)} for i in range(3)]
    with pytest.raises(BatchFailedError) as err:
        run_batch(_always_fails, cases, tmp_path / "b", scheduler="serial", progress=False)
    assert err.value.cases == 3 and "cannot run" in err.value.first_error
    # the per-case records stay for the diagnosis (a complete folder, not a half-written one)
    assert sorted(p.name for p in (tmp_path / "b" / "cases").iterdir()) == [
        "c0.json", "c1.json", "c2.json"]


def test_global_sensitivity_of_fe_parameters_on_modal_bridge_refused(tmp_path, capsys):
    from bridgeflap.design.cli.main import main

    out = tmp_path / "g"
    rc = main(["sensitivity", "--bridge", "iabse-2a", "--global", "morris", "--out", str(out),
               "--json"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "parameters.deck." in err[0], err
    assert not out.exists()


@pytest.mark.parametrize("analysis", ["erection", "frequency_ratio"])
def test_study_of_fe_analysis_on_modal_bridge_refused(tmp_path, capsys, analysis):
    from bridgeflap.design.cli.main import main

    study = tmp_path / "study.toml"
    study.write_text(f'name = "s"\nbridge = "iabse-2a"\nanalyses = ["{analysis}"]\n', "utf-8")
    out = tmp_path / "out"
    rc = main(["study", str(study), "--out", str(out), "--json"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "structure" in err[0] and analysis in err[0], err
    assert not out.exists()
