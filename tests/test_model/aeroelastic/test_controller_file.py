"""controller.toml records the loop it closes: the flap chord, width, strip
positions and edges, and the plant it was designed on (bridge, variant, name, sha256 of the
bridge file, design modes); ``--controller`` re-checks on the file's flaps, warns on another
bridge and exits 2 where the flaps do not fit (model/aeroelastic/control.py,
model/aeroelastic/controller_file.py,
design/cli/common.py)."""

import argparse
import json
from importlib import resources

import numpy as np
import pytest

from bridgeflap.design.cli.common import controller_from_args
from bridgeflap.design.cli.main import main
from bridgeflap.design.io.options import parse_range
from bridgeflap.design.studies.analyses import ANALYSES
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.aeroelastic.controller_file import (
    load_controller,
    plant_record,
    save_controller,
)
from bridgeflap.model.analysis import closed_loop_flutter
from bridgeflap.model.structure.loader import load_bridge

#: K(s) of ``bridgeflap optimise design/studies/humber_b1425_flaps5m.toml`` (built-in Humber,
#: b = 14.25 m, 25 touching 56.4 m flap pairs with 5 m chord; run 2026-12-03 on this branch,
#: converged, max gain 1.70, closed-loop governing speed 90.88 m/s, divergence, on the
#: stiffnesses before the VS1/TS1 model updating): a fixed compensator, so the test
#: needs no optimisation. On the updated bridge the same K gives 78.48 m/s (5 m) and
#: 73.03 m/s (3 m flaps), both flutter, 16 modes
K_5M = Compensator(-1.1668156764187112, -0.03901371153086817, -1.6746219244786549,
                   0.7122695359413691, 0.08664867156606472)
POSITIONS = tuple(56.4 * i for i in range(-12, 13))
SPEEDS = "0:120:0.5"       # past both loops' critical speeds (73.0 and 78.5 m/s)
COMPARED = ("critical_speed_m_s", "critical_mechanism", "divergence_speed_m_s",
            "flutter_speed_m_s", "divergence_static_speed_m_s")


def _controller(chord=5.0, bridge="humber", positions=POSITIONS):
    return Controller(K_5M, positions, 56.4, flap_chord_m=chord,
                      plant=plant_record(bridge, 16))


def _args(path, bridge="humber"):
    return argparse.Namespace(controller=str(path), bridge=bridge)


def test_round_trip_records_the_loop(tmp_path):
    # write -> load -> equal (floats round-trip exactly through tomli_w), every field present
    c = _controller()
    path = save_controller(c, tmp_path / "controller.toml")
    back = load_controller(path)
    assert back == c
    assert back.flap_chord_m == 5.0 and back.chord_m == 5.0
    assert back.flap_strip_positions_m == POSITIONS and back.flap_width_m == 56.4
    assert back.leading_edge and back.trailing_edge
    rec = back.plant
    assert (rec.bridge, rec.bridge_variant, rec.bridge_name, rec.design_modes) == \
        ("humber", "", "humber", 16)
    assert len(rec.bridge_sha256) == 64
    text = path.read_text()
    for key in ("flap_chord_m", "bridge", "bridge_variant", "bridge_name", "bridge_sha256",
                "design_modes"):
        assert f"\n{key} = " in text


def test_variant_record_and_partial_record_rejected(tmp_path):
    rec = plant_record("humber:box", 16)
    assert (rec.bridge, rec.bridge_variant) == ("humber", "box")
    assert rec.bridge_sha256 == plant_record("humber", 16).bridge_sha256  # same file
    path = save_controller(_controller(), tmp_path / "c.toml")
    path.write_text(path.read_text().replace("design_modes = 16\n", ""))
    from bridgeflap.model.errors import BridgeflapInputError

    with pytest.raises(BridgeflapInputError, match="design_modes"):
        load_controller(path)


def test_old_file_loads_with_default_chord_and_one_line(tmp_path, capsys):
    # a file written before the geometry was recorded: read as before (3 m chord), one line
    path = save_controller(Controller(K_5M, POSITIONS, 56.4), tmp_path / "old.toml")
    data = path.read_text().split("\n\n", 1)[1]   # after the comment header
    assert "flap_chord_m" not in data and "bridge" not in data
    c = controller_from_args(_args(path))
    assert c.flap_chord_m is None and c.chord_m == 3.0 and c.plant is None
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no geometry record" in err[0] and "3 m" in err[0]


def test_same_bridge_is_silent_another_bridge_warns(tmp_path, capsys):
    path = save_controller(_controller(), tmp_path / "c.toml")
    controller_from_args(_args(path))
    assert capsys.readouterr().err == ""
    # humber:box (b = 11 m): the 5 m flaps fit, but it is not the bridge designed on
    controller_from_args(_args(path, "humber:box"))
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bridgeflap: warning:")
    assert "designed on bridge humber" in err[0] and "bridge_variant" in err[0]
    # a bridge file with other content under the same name: the hash differs
    other = tmp_path / "humber_copy.toml"
    src = resources.files("bridgeflap.model.bridges").joinpath("humber.toml").read_text("utf-8")
    other.write_text(src + "\n# edited\n")
    rec = _controller().plant
    assert load_bridge(str(other)).name == rec.bridge_name
    controller_from_args(_args(path, str(other)))
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bridge_sha256" in err[0]


@pytest.mark.parametrize("chord, positions, bridge, field", [
    (15.0, POSITIONS, "humber", "controller.flap_chord_m"),       # b = 14.25 m
    (12.0, POSITIONS, "humber:box", "controller.flap_chord_m"),   # fits humber, not b = 11 m
    (5.0, (0.0, 700.0), "humber", "controller.flap_strip_positions_m"),  # 705 m half span
])
def test_flaps_that_do_not_fit_exit_2(tmp_path, capsys, chord, positions, bridge, field):
    path = save_controller(_controller(chord, positions=positions), tmp_path / "c.toml")
    rc = main(["flutter", "--bridge", bridge, "--controller", str(path), "--modes", "2",
               "--speeds", "0:10:5", "--json"])
    out = capsys.readouterr()
    assert rc == 2 and out.out == ""
    err = [ln for ln in out.err.strip().splitlines() if "warning" not in ln]
    assert len(err) == 1 and err[0].startswith(f"bridgeflap: error: {field}:")


def test_cli_recheck_uses_the_files_5m_flaps(tmp_path, capsys):
    # `bridgeflap flutter --controller` on the 5 m file gives the in-process closed loop on the
    # 5 m flap plant; the same K on the default 3 m flaps is another (78.5 m/s) loop.
    # Tolerance: the CLI runs the same function (model.analysis.closed_loop_flutter) on the
    # same spec, grid, mode count and sweep method with the coefficients read back bit for bit
    # (tomli_w writes repr floats), so the numbers agree to round-off; rel 1e-9 leaves room
    # only for a different BLAS summation order, far below the 12 m/s between the plants.
    path = save_controller(_controller(), tmp_path / "controller.toml")
    # --modes 16: the design model of the K
    assert main(["flutter", "--controller", str(path), "--speeds", SPEEDS, "--modes", "16",
                 "--json"]) == 0
    out = capsys.readouterr()
    assert out.err == ""    # designed on this bridge: no warning
    cli = json.loads(out.out)
    spec = load_bridge("humber")
    u = parse_range(SPEEDS, "speeds", 0.0)
    method = ANALYSES["flutter"].defaults["sweep"]
    c = _controller()
    five = closed_loop_flutter(spec, c, u, 16, flap_chord_m=5.0, sweep_method=method).summary()
    three = closed_loop_flutter(spec, c, u, 16, flap_chord_m=3.0,
                                sweep_method=method).summary()
    for key in COMPARED:
        if isinstance(five[key], float):   # NaN (none found on the grid) is JSON null
            got = np.nan if cli[key] is None else cli[key]
            assert got == pytest.approx(five[key], rel=1e-9, nan_ok=True), key
        else:
            assert cli[key] == five[key], key
    # the values of this K on the updated bridge (measured, above); 0.01 m/s: 10x the
    # refinement tolerance of the crossing (1e-3 m/s)
    assert cli["critical_speed_m_s"] == pytest.approx(78.48, abs=0.01)
    assert three["critical_speed_m_s"] == pytest.approx(73.03, abs=0.01)
    assert cli["critical_speed_m_s"] - three["critical_speed_m_s"] > 5.0
    assert np.isfinite(cli["divergence_static_speed_m_s"])


def test_state_space_and_buffeting_use_the_files_chord(tmp_path, capsys):
    # the other --controller commands close the same 5 m loop: state-space's A equals the
    # in-process closed loop on 5 m flaps bit for bit (same function, same inputs) and differs
    # from the 3 m one; buffeting's RMS equals the in-process 5 m value to round-off (rel 1e-9,
    # as above) and is not the 3 m one (1 % apart). 4 modes for state-space, 6 for buffeting
    # (the first four are vertical: no pitch, no flap action on the RMS), one speed: seconds.
    from bridgeflap.model.aeroelastic.control_plant import closed_loop_plant
    from bridgeflap.model.response.buffeting import buffeting

    path = save_controller(_controller(), tmp_path / "c.toml")
    out = tmp_path / "cl.npz"
    assert main(["state-space", "--speed", "30", "--modes", "4", "--controller", str(path),
                 "--out", str(out), "--json"]) == 0
    capsys.readouterr()
    spec, c = load_bridge("humber"), _controller()
    a_cli = np.load(out)["A"]
    np.testing.assert_array_equal(a_cli, closed_loop_plant(spec, c, 30.0, 4, 5.0).A)
    assert not np.allclose(a_cli, closed_loop_plant(spec, c, 30.0, 4, 3.0).A)
    assert main(["buffeting", "--speeds", "20", "--modes", "6", "--controller", str(path),
                 "--json"]) == 0
    rms = json.loads(capsys.readouterr().out)["rms_vertical_m"]
    kw = dict(spectrum="busch-panofsky", admittance=None, coherence_decay=None, n_modes=6,
              method="spectral", turbulence_intensity=None, allow_unstable=False,
              mc_records=16, mc_seed=0, loads=None)
    five = buffeting(spec, np.array([20.0]), controller=c, **kw).summary()["rms_vertical_m"]
    three = buffeting(spec, np.array([20.0]), controller=Controller(K_5M, POSITIONS, 56.4),
                      **kw).summary()["rms_vertical_m"]
    assert rms == pytest.approx(five, rel=1e-9)
    assert rms != pytest.approx(three, rel=1e-3)


def test_default_bridge_is_the_files(tmp_path, capsys):
    """Without --bridge a controller is re-checked on the bridge it was designed on (the
    default card designs on humber:box), with one note line; --bridge still wins."""
    from bridgeflap.design.cli.common import default_bridge

    path = save_controller(_controller(chord=3.0, bridge="humber:box"),
                           tmp_path / "controller.toml")
    args = argparse.Namespace(bridge=None, controller=str(path))
    assert default_bridge(args) == "humber:box"
    assert capsys.readouterr().err.count("\n") == 1
    assert default_bridge(argparse.Namespace(bridge="great-belt", controller=str(path))) == \
        "great-belt"
    assert default_bridge(argparse.Namespace(bridge=None, controller=None)) == "humber"
    assert main(["flutter", "--controller", str(path), "--speeds", "0:40:5", "--modes", "6",
                 "--json"]) == 0
    err = capsys.readouterr().err
    assert "humber:box" in err and "warning" not in err, err  # checked on its own bridge
