"""Build hook: record the package version and the git commit it was built from.

Everything else about the build is in ``pyproject.toml``. ``build_py`` writes
``bridgeflap/model/_build_info.json`` (``version``, ``commit``, ``dirty``, ``built_utc``) into the
build tree, so every wheel says which source it came from; ``sdist`` writes the same file into the
source archive, so a wheel built from the sdist (no ``.git``) still knows the commit.
:func:`bridgeflap.design.io.manifest.build_info` reads it and every run manifest records it.
"""

from __future__ import annotations

import datetime as _dt
import json
import subprocess
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py
from setuptools.command.sdist import sdist

ROOT = Path(__file__).resolve().parent
INFO = Path("model") / "_build_info.json"  # in the source tree (and an sdist)
BUILT_INFO = Path("bridgeflap") / INFO  # in the build tree (and a wheel)


def _git(*args: str) -> str | None:
    try:
        done = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True,
                              timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def build_info(version: str) -> dict:
    """``{"version", "commit", "dirty", "built_utc"}`` of the source tree at ``ROOT``.

    Outside a git checkout (a build from an sdist) the commit recorded in the sdist's own
    ``model/_build_info.json`` is kept; ``"unknown"`` only when neither exists.
    """
    top = _git("rev-parse", "--show-toplevel")
    commit = _git("rev-parse", "HEAD") if top and Path(top).resolve() == ROOT else None
    if commit:
        status = _git("status", "--porcelain", "--untracked-files=no")
        dirty = None if status is None else bool(status)
    else:
        try:
            old = json.loads((ROOT / INFO).read_text())
        except (OSError, ValueError):
            old = {}
        commit, dirty = old.get("commit", "unknown"), old.get("dirty")
    return {"version": version, "commit": commit, "dirty": dirty,
            "built_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")}


def _write(folder: str | Path, info: dict, name: Path = INFO) -> None:
    target = Path(folder) / name
    target.parent.mkdir(parents=True, exist_ok=True)
    if target.exists():  # sdist release trees hard-link the sources: never write through
        target.unlink()
    target.write_text(json.dumps(info, indent=1) + "\n")


def packages() -> list[str]:
    """``bridgeflap`` and every package under ``model/`` and ``design/`` as
    ``bridgeflap.model...`` / ``bridgeflap.design...`` (the folders stay at the root; the
    mapping is ``[tool.setuptools] package-dir`` in pyproject.toml)."""
    out = ["bridgeflap"]
    for top in ("model", "design"):
        for init in sorted((ROOT / top).rglob("__init__.py")):
            if "__pycache__" not in init.parts:
                out.append(".".join(("bridgeflap", *init.parent.relative_to(ROOT).parts)))
    return out


class BuildPyWithInfo(build_py):
    """``build_py`` that also writes ``bridgeflap/model/_build_info.json`` into the build tree."""

    def run(self):
        super().run()
        if not self.dry_run:
            _write(self.build_lib, build_info(self.distribution.get_version()), BUILT_INFO)


class SdistWithInfo(sdist):
    """``sdist`` that also writes ``model/_build_info.json`` into the archive."""

    def make_release_tree(self, base_dir, files):
        super().make_release_tree(base_dir, files)
        _write(base_dir, build_info(self.distribution.get_version()))


setup(packages=packages(), cmdclass={"build_py": BuildPyWithInfo, "sdist": SdistWithInfo})
