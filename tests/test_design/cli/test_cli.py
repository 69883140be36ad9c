"""The ``bridgeflap`` command line: JSON contracts, output files and bad-input behaviour.

Commands run in-process through :func:`bridgeflap.design.cli.main.main` (stdout/stderr captured by
capsys) and once through the installed console script in a subprocess. The contract
(design/cli/main.py): ``--json`` prints exactly one JSON object on stdout; bad input gives exit
status 2, one line ``bridgeflap: error: <field>: <reason>`` on stderr, nothing on stdout and no file
written.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from importlib import resources

import numpy as np
import pytest
import scipy.io

from bridgeflap.design.cli.main import main
from bridgeflap.design.io.options import parse_range
from bridgeflap.design.studies.analyses import DEFAULT_SPEEDS
from bridgeflap.model.analysis import DEFAULT_MODES, bridge_system, flutter
from bridgeflap.model.structure.loader import load_bridge

FLUTTER_KEYS = {"flutter_speed_m_s", "flutter_frequency_hz", "flutter_status",
                "divergence_speed_m_s", "divergence_status", "critical_branch"}
STATUSES = {"converged", "no_crossing_in_range", "bracket_failed"}
SECTION_ARGS = ["--mass", "12460", "--inertia", "9.56e5", "--f-heave", "0.1166",
                "--f-torsion", "0.2979", "--half-chord", "11", "--speeds", "0:120:1"]


def _run(capsys, *argv):
    """(exit status, stdout, stderr) of an in-process ``bridgeflap`` call."""
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def _one_json(rc, out, err) -> dict:
    """Exit 0 and exactly one JSON object (one line) on stdout."""
    assert rc == 0, err
    lines = out.splitlines()
    assert len(lines) == 1, out
    obj = json.loads(lines[0])
    assert isinstance(obj, dict)
    return obj


def _snapshot(folder):
    """Names, sizes, mtimes and bytes of every file below ``folder`` (hidden temp files too)."""
    return {p.relative_to(folder): (p.stat().st_mtime_ns, p.read_bytes())
            for p in folder.rglob("*") if p.is_file()}


# ------------------------------------------------------------------------- contracts


def test_modes_json(capsys):
    m = _one_json(*_run(capsys, "modes", "--json", "--count", "12"))
    assert {"bridge", "erected_fraction", "modes"} <= m.keys()
    assert m["bridge"] == "humber" and m["erected_fraction"] == 1.0
    assert len(m["modes"]) == 12
    for mode in m["modes"]:
        assert {"family", "symmetry", "frequency_hz", "damping_ratio"} <= mode.keys()
        assert mode["family"] in ("vertical", "torsional", "lateral")
        assert mode["symmetry"] in ("symmetric", "antisymmetric")
        assert mode["frequency_hz"] > 0 and 0 <= mode["damping_ratio"] < 1
    f = [mode["frequency_hz"] for mode in m["modes"]]
    assert f == sorted(f)
    # Rayleigh damping is fitted to 1 % in the first vertical and first torsional modes
    # (seed §2); the fit is exact, so only roundoff remains
    first_v = next(x for x in m["modes"] if x["family"] == "vertical")
    assert first_v["damping_ratio"] == pytest.approx(0.01, rel=1e-9)


def test_frequency_ratio_json(capsys):
    r = _one_json(*_run(capsys, "frequency-ratio", "--json", "--fractions", "0.5:1.0:0.5"))
    assert "stages" in r
    assert [s["erected_fraction"] for s in r["stages"]] == [0.5, 1.0]
    for s in r["stages"]:
        assert {"erected_fraction", "ratio_full_gj", "ratio_half_gj"} <= s.keys()
        assert s["ratio_full_gj"] > 1 and s["ratio_half_gj"] > 1  # torsion above bending


def test_flutter_json_matches_library(capsys):
    r = _one_json(*_run(capsys, "flutter", "--json"))
    assert FLUTTER_KEYS <= r.keys()
    assert {"family", "symmetry", "frequency_hz"} <= r["critical_branch"].keys()
    assert r["flutter_status"] in STATUSES and r["divergence_status"] in STATUSES
    assert r["flutter_status"] == "converged"
    assert r["critical_branch"]["family"] == "torsional"
    # the CLI is a thin layer over model.analysis.flutter with the same defaults: the same
    # deterministic computation, so the same number to roundoff (JSON keeps 17 digits)
    lib = flutter(load_bridge("humber"), parse_range(DEFAULT_SPEEDS, "speeds"),
                  sweep_method="fast").summary()  # the CLI's default sweep
    assert r["flutter_speed_m_s"] == pytest.approx(lib["flutter_speed_m_s"], rel=1e-12)
    assert r["divergence_speed_m_s"] == pytest.approx(lib["divergence_speed_m_s"], rel=1e-12)


def test_flutter_json_nan_is_null(capsys):
    """No crossing in the range: status and ``null`` (strict JSON has no NaN)."""
    r = _one_json(*_run(capsys, "flutter", "--json", "--speeds", "0:30:1", "--modes", "6"))
    assert r["flutter_status"] == "no_crossing_in_range"
    assert r["flutter_speed_m_s"] is None and r["divergence_speed_m_s"] is None


def test_erection_json(capsys):
    r = _one_json(*_run(capsys, "erection", "--json", "--fractions", "0.5,1.0"))
    assert len(r["stages"]) == 2
    for s in r["stages"]:
        assert {"erected_fraction", "flutter_speed_m_s", "flutter_status",
                "divergence_speed_m_s", "divergence_status"} <= s.keys()
        for what in ("flutter", "divergence"):
            assert s[f"{what}_status"] in STATUSES
            assert (s[f"{what}_speed_m_s"] is None) == (s[f"{what}_status"] != "converged")


def test_section_json(capsys):
    r = _one_json(*_run(capsys, "section", "--json", *SECTION_ARGS))
    assert {"flutter_speed_m_s", "flutter_frequency_hz", "flutter_status",
            "divergence_speed_m_s", "divergence_status", "aero",
            "selberg_flutter_speed_m_s"} <= r.keys()
    assert r["aero"] == "rfa4" and r["flutter_status"] == "converged"


@pytest.mark.parametrize("ext", [".npz", ".mat"])
def test_state_space_file(capsys, tmp_path, ext):
    out = tmp_path / f"ss{ext}"
    r = _one_json(*_run(capsys, "state-space", "--json", "--speed", "40", "--out", out))
    assert out.is_file()
    assert [p.name for p in tmp_path.iterdir()] == [out.name]  # no temp file left behind
    if ext == ".npz":
        with np.load(out) as d:
            data = {k: d[k] for k in ("A", "B", "C", "D", "state_names")}
        names = [str(s) for s in data["state_names"]]
    else:
        data = scipy.io.loadmat(out)
        names = [str(c[0]) for c in data["state_names"].ravel()]  # a cell array
    _, system = bridge_system(load_bridge("humber"), DEFAULT_MODES)
    # same assembly and the same float64 numbers through a lossless file format
    np.testing.assert_allclose(data["A"], system.A(40.0), rtol=1e-12, atol=0)
    np.testing.assert_allclose(data["B"], system.B_gust(40.0), rtol=1e-12, atol=0)
    np.testing.assert_array_equal(data["C"], system.C_out)
    assert data["D"].shape == (system.C_out.shape[0], data["B"].shape[1])
    assert not np.any(data["D"])
    assert names == list(system.index.names)
    assert r["states"] == system.n_states == data["A"].shape[0]


def test_console_script_subprocess(tmp_path):
    """The installed ``bridgeflap`` script: one JSON object, and exit 2 on bad input."""
    exe = shutil.which("bridgeflap")
    assert exe is not None, "the bridgeflap console script is not installed"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    ok = subprocess.run([exe, "modes", "--json", "--count", "5"], capture_output=True,
                        text=True, env=env, cwd=tmp_path, timeout=300)
    assert ok.returncode == 0, ok.stderr
    m = json.loads(ok.stdout)
    assert len(ok.stdout.splitlines()) == 1 and len(m["modes"]) == 5
    bad = subprocess.run([exe, "flutter", "--json", "--erection", "1.5"], capture_output=True,
                         text=True, env=env, cwd=tmp_path, timeout=300)
    assert bad.returncode == 2
    assert bad.stdout == ""
    assert bad.stderr.count("\n") == 1 and "erected_fraction" in bad.stderr
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------- bad input


@pytest.fixture
def bad_files(tmp_path):
    """A malformed TOML file and a humber copy with a negative deck-plate mass."""
    (tmp_path / "malformed.toml").write_text("[deck\nmass = \n", encoding="utf-8")
    text = resources.files("bridgeflap.model.bridges").joinpath("humber.toml").read_text("utf-8")
    head, tail = text.split("[[deck_section]]", 1)
    tail, n = re.subn(r"(mass_kg_per_m\s*=\s*)([0-9.eE+]+)", r"\1-\2", tail, count=1)
    assert n == 1
    (tmp_path / "negative_mass.toml").write_text(head + "[[deck_section]]" + tail,
                                                 encoding="utf-8")
    return tmp_path


BAD_CASES = [
    # (id, argv with {tmp} placeholders, field named on stderr)
    ("unknown-bridge", ["flutter", "--bridge", "nosuchbridge"], "bridge"),
    ("missing-file", ["flutter", "--bridge", "{tmp}/missing.toml"], "bridge"),
    ("malformed-toml", ["flutter", "--bridge", "{tmp}/malformed.toml"], "bridge"),
    ("negative-deck-mass", ["flutter", "--bridge", "{tmp}/negative_mass.toml"],
     "deck_section.deck_plate.mass_kg_per_m"),
    ("erection-0", ["flutter", "--erection", "0"], "erected_fraction"),
    ("erection-1.5", ["flutter", "--erection", "1.5"], "erected_fraction"),
    ("negative-speed", ["flutter", "--speeds=-5:10:1"], "speeds"),
    # argparse reads "-5:10:1" after a space as an option, but still names the field
    ("negative-speed-spaced", ["flutter", "--speeds", "-5:10:1"], "speeds"),
    ("empty-grid", ["flutter", "--speeds", "5:1:1"], "speeds"),
    ("non-numeric-speed", ["flutter", "--speeds", "fast"], "speeds"),
    ("single-speed", ["flutter", "--speeds", "5"], "speeds"),
    ("erection-fractions", ["erection", "--fractions", "0:1:0.5"], "erected_fraction"),
    ("ratio-fraction", ["frequency-ratio", "--fractions", "1.5"], "erected_fraction"),
    ("zero-modes", ["flutter", "--modes", "0"], "modes"),
    ("modes-count", ["modes", "--count", "0"], "count"),
    ("unknown-subcommand", ["frobnicate"], "command"),
    ("section-negative-mass", ["section", "--mass", "-1", "--inertia", "1", "--f-heave", "0.1",
                               "--f-torsion", "0.2", "--half-chord", "1"], "mass"),
    ("ss-negative-speed", ["state-space", "--speed", "-1", "--out", "{tmp}/x.npz"], "speed"),
    ("ss-nan-speed", ["state-space", "--speed", "nan", "--out", "{tmp}/x.npz"], "speed"),
    ("ss-no-folder", ["state-space", "--speed", "10", "--out", "{tmp}/nodir/x.npz"], "out"),
    ("ss-extension", ["state-space", "--speed", "10", "--out", "{tmp}/x.txt"], "out"),
    ("ss-bad-bridge", ["state-space", "--speed", "10", "--bridge",
                       "{tmp}/negative_mass.toml", "--out", "{tmp}/x.npz"],
     "deck_section.deck_plate.mass_kg_per_m"),
]


@pytest.mark.parametrize("argv,field", [c[1:] for c in BAD_CASES], ids=[c[0] for c in BAD_CASES])
def test_bad_input(capsys, bad_files, argv, field):
    before = _snapshot(bad_files)
    rc, out, err = _run(capsys, *[a.format(tmp=bad_files) for a in argv], "--json")
    assert rc == 2
    assert out == ""
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert err.startswith("bridgeflap: error: ")
    assert field in err
    assert _snapshot(bad_files) == before  # nothing created, nothing touched


@pytest.mark.parametrize("argv", [["--speed", "-1"], ["--speed", "10", "--bridge", "nosuch"],
                                  ["--speed", "10", "--modes", "0"]],
                         ids=["negative-speed", "unknown-bridge", "zero-modes"])
def test_state_space_failure_keeps_existing_file(capsys, tmp_path, argv):
    out = tmp_path / "existing.npz"
    out.write_bytes(b"previous result")
    before = _snapshot(tmp_path)
    rc, stdout, err = _run(capsys, "state-space", *argv, "--out", out, "--json")
    assert rc == 2 and stdout == "" and err.count("\n") == 1
    assert _snapshot(tmp_path) == before


def test_state_space_parent_is_a_file(capsys, tmp_path):
    (tmp_path / "afile").write_text("x")
    rc, out, err = _run(capsys, "state-space", "--speed", "1", "--out",
                        tmp_path / "afile" / "x.npz", "--json")
    assert rc == 2 and out == "" and "out" in err and err.count("\n") == 1


def test_flutter_pk_check_agrees_with_the_rfa_state_space(capsys):
    """``flutter --pk``: the exact-Theodorsen p-k on the same 8 modes. The 4-lag RFA's C(k) error
    is at most 1.5e-3 (``bridgeflap rfa``), which moves the flutter speed by a few 0.1 %
    (72.18 vs 72.04 m/s on the default 30 modes): 1 % is the bound."""
    r = _one_json(*_run(capsys, "flutter", "--json", "--pk", "--modes", "8",
                        "--speeds", "50:80:1", "--no-truncation-check"))
    assert r["flutter_status"] == r["pk_flutter_status"] == "converged"
    assert abs(r["pk_flutter_speed_m_s"] / r["flutter_speed_m_s"] - 1) < 0.01
    assert "truncation_status" not in r


def test_version_flag(capsys):
    """``bridgeflap --version``: one line naming the package, exit 0."""
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and out[0].startswith("bridgeflap ")
