"""Start-up stays lean: a command imports only what it uses.

Each command runs in a fresh interpreter (a subprocess, so that nothing the test session has
already imported counts) and reports which heavy packages ended up in ``sys.modules``. No
timings: the import list is what start-up time follows, and it is deterministic.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: packages only some commands need: symbolic design (CasADi), figures, batches, global
#: sensitivity and tables
HEAVY = ("casadi", "matplotlib", "dask", "distributed", "SALib", "pandas", "xarray")

_PROBE = f"""
import json, sys
from bridgeflap.design.cli.main import main
rc = main(sys.argv[1:])
print(json.dumps({{"rc": rc, "loaded": sorted(m for m in {HEAVY!r} if m in sys.modules)}}))
"""


def _loaded(*argv: str) -> dict:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1"}
    p = subprocess.run([sys.executable, "-c", _PROBE, *argv], capture_output=True, text=True,
                       cwd=ROOT, env=env, timeout=300)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("argv", [
    ("modes", "--json", "--count", "3"),
    ("flutter", "--json", "--speeds", "0:100:5", "--modes", "6"),
    ("rfa", "--json"),
])
def test_light_commands_import_no_heavy_package(argv):
    out = _loaded(*argv)
    assert out["rc"] == 0
    assert out["loaded"] == [], f"{argv[0]} imported {out['loaded']}"


def test_probe_sees_a_heavy_import(tmp_path):
    """The probe can fail: the same command asked for a figure does load matplotlib."""
    out = _loaded("modes", "--json", "--count", "3", "--plot", str(tmp_path / "modes.png"))
    assert out["rc"] == 0
    assert "matplotlib" in out["loaded"]


def test_import_of_the_packages_is_light():
    code = ("import sys, bridgeflap, bridgeflap.design.cli.main; "
            f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                       env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=300)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "[]"
