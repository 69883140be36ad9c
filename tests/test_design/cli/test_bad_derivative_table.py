"""A bridge whose flutter-derivative table holds a NaN is refused at load: `flutter`,
a study and a DOE on it exit 2 in one line naming the field, and nothing is written."""

from __future__ import annotations

import json
from importlib import resources

import pytest

from bridgeflap.design.cli.main import main


@pytest.fixture()
def nan_bridge(tmp_path):
    bridges = resources.files("bridgeflap.model.bridges")
    table = json.loads(bridges.joinpath("iabse/step2a_bb3_derivatives.json").read_text("utf-8"))
    table["v_heave"][0] = float("nan")
    (tmp_path / "bad.json").write_text(json.dumps(table), "utf-8")
    text = bridges.joinpath("great_belt.toml").read_text("utf-8").replace(
        'file = "iabse/step2a_bb3_derivatives.json"', f'file = "{tmp_path / "bad.json"}"')
    (tmp_path / "gb.toml").write_text(text, "utf-8")
    return f"{tmp_path / 'gb.toml'}:bb3"


@pytest.mark.parametrize("kind", ["flutter", "study", "doe"])
def test_nan_in_a_derivative_table_is_refused_before_writing(tmp_path, capsys, nan_bridge, kind):
    out = tmp_path / "out"
    if kind == "flutter":
        argv = ["flutter", "--bridge", nan_bridge, "--modes", "4"]
    else:
        f = tmp_path / f"{kind}.toml"
        body = ('analyses = ["flutter"]\n' if kind == "study" else 'analysis = "flutter"\n')
        f.write_text(f'name = "nan"\nbridge = "{nan_bridge}"\n{body}', "utf-8")
        argv = [kind, str(f), "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "derivatives.v_heave" in err[0], err
    assert not out.exists()
