"""More bad-input cases: each once ended in "internal error ... a bug" (exit 1).

Modal files with a wrong-typed ``units`` or holding just ``null``, a ``strip_length_m`` giving
1e12 strips, an ``.npz`` that is no zip, mode frequencies of 1e300 / 1e-300 Hz, controller
coefficients of 1e300, 300-character path components, ``derivatives --points 100000000``.

The contract is that of tests/test_bad_input.py: exit status 2, exactly one line
``bridgeflap: error: <field>: <reason>`` on stderr naming the field, no traceback, nothing on
stdout, nothing written (an earlier output left byte-identical). Tiny modal files (11
stations, 2 modes) keep every case to a fraction of a second.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bridgeflap.design.cli.main import main
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.structure.loader import load_bridge

UNITS_TOML = 'units = { frequency = "Hz", length = "m", rotation = "rad", mass = "kg" }\n'


def _arrays(**over) -> dict:
    x = np.linspace(0.0, 1000.0, 11)
    s = np.sin(np.pi * x / 1000.0)
    a = {"station_x": x, "frequency": np.array([0.1, 0.3]),
         "damping_ratio": np.array([0.005, 0.005]), "generalised_mass": np.array([1.0, 1.0]),
         "vertical": np.column_stack([s, 0 * s]), "torsional": np.column_stack([0 * s, s])}
    a.update(over)
    return a


def _lateral_1e300() -> dict:
    """Two deck modes and a lateral one at 1e300 Hz (once accepted)."""
    x = np.linspace(0.0, 1000.0, 11)
    s, z = np.sin(np.pi * x / 1000.0), np.zeros(11)
    return _arrays(frequency=np.array([0.1, 0.3, 1e300]), damping_ratio=np.full(3, 0.005),
                   generalised_mass=np.ones(3), vertical=np.column_stack([s, z, z]),
                   torsional=np.column_stack([z, s, z]), lateral=np.column_stack([z, z, s]))


def _json(arrays: dict, **extra) -> str:
    return json.dumps({**{k: v.tolist() for k, v in arrays.items()}, **extra})


_CTRL = ("b2 = 0.0\nb1 = 0.0\nb0 = {b0}\na2 = {a2}\na1 = 1.0\nflap_strip_positions_m = [0.0]\n"
         "flap_width_m = 50.0\n")
#: modal data and other input files: name -> bytes (the bridge file ``<stem>.toml`` points at each)
DATA = {
    "units5.json": _json(_arrays(), units=5).encode(),
    "null.json": b"null",
    "list.json": b"[1, 2, 3]",
    "notzip.npz": b"PK\x03\x04 this is not a zip archive",
    "empty.npz": b"",
    "study_ok.toml": b'name = "s"\nanalyses = ["modes"]\n',
    "ctrl_b0_1e300.toml": _CTRL.format(b0="1e300", a2="0.1").encode(),
    "ctrl_b0_int.toml": _CTRL.format(b0="1" + "0" * 400, a2="0.1").encode(),
    "ctrl_a2_1e-300.toml": _CTRL.format(b0="1.0", a2="1e-300").encode(),
}
#: npz modal files: name -> arrays
NPZ = {
    "ok.npz": _arrays(),
    "f_1e300.npz": _arrays(frequency=np.array([0.1, 1e300])),
    "f_1e-300.npz": _arrays(frequency=np.array([1e-300, 0.3])),
    "lateral_1e300.npz": _lateral_1e300(),
}
#: bridge files: name -> (data file, extra [structure] lines)
BRIDGES = {
    "units5": ("units5.json", ""), "null": ("null.json", ""), "list": ("list.json", ""),
    "notzip": ("notzip.npz", ""), "empty": ("empty.npz", ""), "npy": ("npy.npz", ""),
    "f_1e300": ("f_1e300.npz", ""), "f_1e-300": ("f_1e-300.npz", ""),
    "lateral_1e300": ("lateral_1e300.npz", ""),
    "strip_1e-9": ("ok.npz", "strip_length_m = 1e-9\n"),
    "long_modal": ("x" * 300 + ".npz", ""),
}
#: a path component beyond any file system's NAME_MAX (255 bytes)
LONG = "x" * 300


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("bad_input_more")
    for name, data in DATA.items():
        (d / name).write_bytes(data)
    for name, arrays in NPZ.items():
        np.savez(d / name, **arrays)
    with (d / "npy.npz").open("wb") as fh:  # one .npy array under an .npz name
        np.save(fh, np.arange(3.0))
    for name, (file, extra) in BRIDGES.items():
        (d / f"{name}.toml").write_text(
            f'name = "toy"\n[structure]\nkind = "modal"\nfile = "{file}"\n{UNITS_TOML}{extra}'
            '[deck]\nhalf_chord_m = { value = 10.0, source = "test" }\n', "utf-8")
    (d / "prev.npz").write_bytes(b"previous state space")
    return d


def _snapshot(folder: Path) -> dict:
    return {p.relative_to(folder): (p.stat().st_mtime_ns, p.read_bytes() if p.is_file() else None)
            for p in folder.rglob("*")}


B = "--bridge"
#: (id, argv, field named on stderr); ``{d}`` is the working folder
CASES = [
    # a wrong-typed units entry, a file holding just null (TypeError before)
    ("modal-units-int", ["flutter", B, "{d}/units5.toml"], "structure.units"),
    ("modal-json-null", ["flutter", B, "{d}/null.toml"], "structure.file"),
    ("modal-json-list", ["flutter", B, "{d}/list.toml"], "structure.file"),
    # 1e-9 m strips would be 1e12 strips (MemoryError before)
    ("modal-strip-1e-9", ["flutter", B, "{d}/strip_1e-9.toml"], "structure.strip_length_m"),
    # an npz that is no zip archive (BadZipFile before)
    ("modal-npz-not-zip", ["flutter", B, "{d}/notzip.toml"], "structure.file"),
    ("modal-npz-is-npy", ["flutter", B, "{d}/npy.toml"], "structure.file"),
    ("modal-npz-empty", ["flutter", B, "{d}/empty.toml"], "structure.file"),
    # implausible frequencies (ValueError / LinAlgError before; lateral accepted)
    ("modal-f-1e300", ["flutter", B, "{d}/f_1e300.toml"], "structure.frequency"),
    ("modal-f-1e-300", ["flutter", B, "{d}/f_1e-300.toml"], "structure.frequency"),
    ("modal-lateral-1e300", ["flutter", B, "{d}/lateral_1e300.toml"], "structure.frequency"),
    # controller coefficients beyond finite, plausible magnitudes (OverflowError)
    ("controller-b0-1e300", ["flutter", "--controller", "{d}/ctrl_b0_1e300.toml"],
     "controller.b0"),
    ("controller-b0-int-huge", ["flutter", "--controller", "{d}/ctrl_b0_int.toml"],
     "controller.b0"),
    ("controller-a2-1e-300", ["flutter", "--controller", "{d}/ctrl_a2_1e-300.toml"],
     "controller.a2"),
    ("controller-b0-1e300-ss", ["state-space", "--speed", "10", "--controller",
                                "{d}/ctrl_b0_1e300.toml", "--out", "{d}/prev.npz"],
     "controller.b0"),
    # an unbounded table (ran without limit)
    ("derivatives-points-1e8", ["derivatives", "--points", "100000000"], "points"),
    # a 300-character path component ("File name too long"; "a bug" before)
    ("long-bridge", ["modes", B, "{d}/{L}.toml"], "bridge"),
    ("long-ss-out", ["state-space", "--speed", "10", "--out", "{d}/{L}.npz"], "out"),
    ("long-ss-out-folder", ["state-space", "--speed", "10", "--out", "{d}/{L}/a.npz"], "out"),
    ("long-study-out", ["study", "{d}/study_ok.toml", "--out", "{d}/{L}"], "out"),
    ("long-study-file", ["study", "{d}/{L}.toml", "--out", "{d}/s_out"], "study"),
    ("long-plot", ["modes", "--plot", "{d}/{L}.png"], "plot"),
    ("long-plot-folder", ["modes", "--plot", "{d}/{L}/a.png"], "plot"),
    ("long-controller", ["flutter", "--controller", "{d}/{L}.toml"], "controller"),
    ("long-optimise-out", ["optimise", "--out", "{d}/{L}"], "out"),
    ("long-modal-file", ["flutter", B, "{d}/long_modal.toml"], "structure.file"),
    ("modal-f-1e300-ss", ["state-space", "--speed", "10", B, "{d}/f_1e300.toml", "--out",
                          "{d}/prev.npz"], "structure.frequency"),
]


@pytest.mark.parametrize("argv,field", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_more(capsys, monkeypatch, folder, argv, field):
    monkeypatch.chdir(folder)
    before = _snapshot(folder)
    rc = main([a.format(d=folder, L=LONG) for a in argv] + ["--json"])
    cap = capsys.readouterr()
    assert rc == 2, cap.err
    assert cap.out == ""
    assert cap.err.count("\n") == 1 and cap.err.endswith("\n"), cap.err
    assert cap.err.startswith("bridgeflap: error: "), cap.err
    assert "Traceback" not in cap.err and "bug" not in cap.err
    assert field in cap.err, cap.err
    assert _snapshot(folder) == before


@pytest.mark.parametrize("name,field", [("units5", "structure.units"),
                                        ("null", "structure.file"),
                                        ("strip_1e-9", "structure.strip_length_m"),
                                        ("notzip", "structure.file"),
                                        ("f_1e300", "structure.frequency")])
def test_api_raises_typed_error(folder, name, field):
    """The API gives the typed exception with the field, at load."""
    with pytest.raises(BridgeflapInputError) as exc:
        load_bridge(str(folder / f"{name}.toml"))
    assert exc.value.field == field


def test_bounds_are_stated(capsys, folder):
    """Resource and range limits state their bound."""
    main(["flutter", B, str(folder / "strip_1e-9.toml")])
    assert "100000" in capsys.readouterr().err
    main(["flutter", B, str(folder / "f_1e-300.toml")])
    assert "[0.0001, 1000] Hz" in capsys.readouterr().err
    main(["derivatives", "--points", "100000000"])
    assert "10000," in capsys.readouterr().err
    main(["modes", "--plot", str(folder / f"{LONG}.png")])
    err = capsys.readouterr().err
    assert err.startswith("bridgeflap: error: plot: ") and "File name too long" in err
    assert len(err) < 300  # the long name is shortened in the message


def test_api_long_bridge_path_is_typed(folder):
    with pytest.raises(BridgeflapInputError) as exc:
        load_bridge(str(folder / f"{LONG}.toml"))
    assert exc.value.field == "bridge" and "File name too long" in exc.value.reason


@pytest.mark.parametrize("name", ["robust_design_speeds_m_s", "robust_speeds_m_s"])
def test_empty_robust_speed_list_refused_before_the_design(tmp_path, capsys, name):
    """An empty robust speed list ran the design 30 s, then failed on a broadcast (exit 1)."""
    from importlib import resources as _res

    card = _res.files("bridgeflap.design.studies").joinpath("humber_flaps.toml").read_text("utf-8")
    import re as _re

    text, n = _re.subn(rf"^{name} = \[[^\]]*\]", f"{name} = []", card, flags=_re.M)
    assert n == 1
    (tmp_path / "card.toml").write_text(text, "utf-8")
    out = tmp_path / "opt"
    rc = main(["optimise", str(tmp_path / "card.toml"), "--out", str(out), "--json"])
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert rc == 2 and len(err) == 1 and name in err[0], err
    assert not out.exists() and not (tmp_path / ".opt.lock").exists()
