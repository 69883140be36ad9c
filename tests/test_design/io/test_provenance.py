"""Provenance: version and commit recorded at build time, in every manifest."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from bridgeflap.design.io.manifest import UNKNOWN, build_info, build_manifest, provenance

ROOT = Path(__file__).resolve().parents[3]


def test_manifest_takes_the_build_commit_outside_a_checkout(tmp_path):
    record = tmp_path / "_build_info.json"
    record.write_text(json.dumps({"version": "9.9.9", "commit": "abc123", "dirty": False,
                                  "built_utc": "2026-01-01T00:00:00+00:00"}))
    not_a_checkout = tmp_path / "site-packages"
    not_a_checkout.mkdir()
    p = provenance(not_a_checkout, record)
    assert p["commit"] == "abc123" and p["source"] == "build" and p["dirty"] is False
    assert p["built_utc"].startswith("2026")
    assert p["version"] != UNKNOWN
    # neither a checkout nor a build record: unknown, and it says so
    q = provenance(not_a_checkout, tmp_path / "missing.json")
    assert q["commit"] == UNKNOWN and q["source"] == UNKNOWN
    assert build_info(tmp_path / "missing.json") is None


def test_manifest_names_version_and_commit():
    import bridgeflap.design.io.manifest

    m = build_manifest({})
    assert m["bridgeflap"]["version"] != UNKNOWN
    # where the imported package lives decides: a checkout (worktrees have a .git file), or an
    # installed wheel (CI: built from this clone, so its record names this clone's HEAD)
    package_root = Path(bridgeflap.design.io.manifest.__file__).resolve().parents[2]
    if (package_root / ".git").exists():
        assert m["git"]["source"] == "checkout" and m["git"]["commit"] != UNKNOWN
        assert m["bridgeflap"]["commit"] == m["git"]["commit"]
    else:
        assert m["git"]["source"] == "build", m["git"]
        assert m["bridgeflap"]["commit"] == m["git"]["commit"] != UNKNOWN
        if (ROOT / ".git").exists() and shutil.which("git") is not None:
            head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True,
                                  text=True, check=True).stdout.strip()
            assert m["git"]["commit"] == head


@pytest.mark.slow
def test_built_wheel_carries_the_commit(tmp_path):
    # a clone of the committed tree (HEAD), built without isolation (no downloads)
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs a git checkout")
    src = tmp_path / "src"
    subprocess.run(["git", "clone", "-q", "--no-hardlinks", str(ROOT), str(src)], check=True,
                   timeout=60)
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=src, capture_output=True,
                          text=True, check=True).stdout.strip()
    try:  # a wheel needs bdist_wheel (setuptools >= 70.1 or the wheel package)
        import importlib.util

        has_wheel = importlib.util.find_spec("wheel") is not None
    except ImportError:
        has_wheel = False
    if has_wheel:
        subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps",
                        "--no-build-isolation", "-w", str(tmp_path / "dist"), str(src)],
                       check=True, timeout=120, capture_output=True)
        wheel = next((tmp_path / "dist").glob("bridgeflap-*.whl"))
        with zipfile.ZipFile(wheel) as z:
            info = json.loads(z.read("bridgeflap/model/_build_info.json"))
    else:  # the build step every wheel build runs, which writes the record
        subprocess.run([sys.executable, "setup.py", "-q", "build_py", "-d",
                        str(tmp_path / "lib")], cwd=src, check=True, timeout=120,
                       capture_output=True)
        info = json.loads((
            tmp_path / "lib" / "bridgeflap" / "model" / "_build_info.json").read_text())
    assert info["commit"] == head and info["dirty"] is False
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib
    assert info["version"] == tomllib.loads((src / "pyproject.toml").read_text())["project"][
        "version"]
    assert not (src / "model" / "_build_info.json").exists()  # nothing written into the source


def test_manifest_says_not_installed_for_a_missing_optional_package(monkeypatch):
    """An optional package that is absent (python-control) is "not installed", not "unknown"."""
    import importlib.metadata

    import bridgeflap.design.io.manifest as manifest

    real = importlib.metadata.version

    def version(name):
        if name == "control":
            raise importlib.metadata.PackageNotFoundError(name)
        return real(name)

    monkeypatch.setattr(importlib.metadata, "version", version)
    versions = manifest.package_versions()
    assert versions["control"] == manifest.NOT_INSTALLED == "not installed"
    assert versions["numpy"] not in (manifest.UNKNOWN, manifest.NOT_INSTALLED)
    assert build_manifest({})["packages"]["control"] == "not installed"
