"""Code layout rules: file sizes, documented rooms, the public face, the
tests' mirror of the rooms, the CasADi boundary."""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("package", ["model", "design"])
def test_no_module_above_600_lines(package):
    # one job per file: 600 lines is the stated ceiling
    big = {str(p.relative_to(ROOT)): n for p in (ROOT / package).rglob("*.py")
           if (n := len(p.read_text().splitlines())) > 600}
    assert not big, big


def _subpackages(package):
    return sorted(p.parent for p in (ROOT / package).glob("*/__init__.py")
                  if p.parent.name != "bridges")


@pytest.mark.parametrize("package, least", [("model", 6), ("design", 6), ("design/control", 5)])
def test_every_room_says_what_lives_there_and_what_it_may_import(package, least):
    # a newcomer reads a room's __init__ docstring to know where code goes (design.control's
    # rooms as well)
    rooms = _subpackages(package)
    assert len(rooms) >= least, rooms
    for room in rooms:
        doc = ast.get_docstring(ast.parse((room / "__init__.py").read_text())) or ""
        assert "May import:" in doc, f"{room.name}: no 'May import:' line in its docstring"
        # every module of the room is named in that docstring
        missing = [m.stem for m in room.glob("*.py")
                   if m.stem != "__init__" and f"``{m.stem}``" not in doc]
        assert not missing, f"{package}.{room.name} does not describe {missing}"


@pytest.mark.parametrize("package", ["model", "design"])
def test_every_module_has_a_docstring(package):
    bare = [str(p.relative_to(ROOT)) for p in (ROOT / package).rglob("*.py")
            if "bridges" not in p.parts and not ast.get_docstring(ast.parse(p.read_text()))]
    assert not bare, bare


def test_tests_mirror_the_rooms():
    # tests/test_<package>/<room>/ for every room that has tests; a room's
    # tests live nowhere else but there or in tests/project (cross-cutting)
    for package in ("model", "design"):
        rooms = {r.name for r in _subpackages(package)}
        folders = {p.name for p in (ROOT / "tests" / f"test_{package}").iterdir() if p.is_dir()
                   and p.name != "__pycache__"}
        assert folders <= rooms, folders - rooms
        assert len(folders) >= len(rooms) - 1, rooms - folders
    loose = sorted(p.name for p in (ROOT / "tests").glob("test_*.py"))
    assert not loose, f"tests outside the rooms' mirror: {loose}"


@pytest.mark.parametrize("package", ["model", "design"])
def test_public_face_resolves_every_name(package):
    mod = importlib.import_module(f"bridgeflap.{package}")
    for name in mod.__all__:
        assert getattr(mod, name) is not None, name


def test_importing_the_packages_stays_light():
    # the public face is lazy: importing model and design loads neither CasADi nor matplotlib
    code = ("import sys, bridgeflap, bridgeflap.model, bridgeflap.design; "
            "print(sorted(m for m in ('casadi', 'matplotlib', 'dask') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "[]"


@pytest.mark.parametrize("package, least", [("model", 45), ("design", 45), ("design.control", 26)])
def test_an_old_flat_module_names_its_new_home(package, least):
    # a script written before the rooms gets one line saying where the module went; each new
    # home named exists, and no old name is still a module (the table would hide nothing)
    import importlib
    import re

    mod = importlib.import_module(f"bridgeflap.{package}")
    assert len(mod._MOVED) >= least  # 48 in model, 62 in design, 26 in design.control
    for old, new in mod._MOVED.items():
        with pytest.raises(ModuleNotFoundError, match=re.escape(f"moved to {new}")):
            importlib.import_module(f"bridgeflap.{package}.{old}")
        for target in re.findall(r"bridgeflap\.(?:model|design)(?:\.\w+)+", new):
            importlib.import_module(target)
    with pytest.raises(ModuleNotFoundError,
                       match="No module named 'bridgeflap.model.no_such_module'$"):
        importlib.import_module("bridgeflap.model.no_such_module")
