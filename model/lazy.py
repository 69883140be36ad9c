"""The lazy public face of a package (PEP 562): names resolve on first use.

``from bridgeflap import model`` and ``from bridgeflap import design`` then stay light (no CasADi,
matplotlib or Dask) while a script can still write ``from bridgeflap.model import load_bridge,
flutter``.
"""

from __future__ import annotations

import importlib
import importlib.abc
import sys
import types


def public_face(package: str, names: dict):
    """``(__all__, __getattr__, __dir__)`` for ``package`` exposing ``names`` (name -> module)."""
    public = sorted(names)

    def __getattr__(name):
        if name in names:
            return getattr(importlib.import_module(names[name]), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__():
        return public

    return public, __getattr__, __dir__


class _PublicModule(types.ModuleType):
    """A package whose public functions are not replaced by submodules of the same name.

    Importing ``bridgeflap.model.response.buffeting`` (the module) sets the attribute ``buffeting``
    of ``model``; here that assignment is dropped when ``buffeting`` is a public name of another
    module, so ``bridgeflap.model.response.buffeting`` stays the function the docs promise (resolved
    by ``__getattr__``). The submodule stays in :data:`sys.modules`: ``from
    bridgeflap.model.response.buffeting import BuffetingResult`` and
    :func:`importlib.import_module` work as before.
    """

    def __setattr__(self, name, value):
        names = self.__dict__.get("_PUBLIC", {})
        if (isinstance(value, types.ModuleType) and name in names
                and value.__name__ == f"{self.__name__}.{name}"):
            return
        super().__setattr__(name, value)


def keep_public_names(package: str) -> None:
    """Make ``package`` (its ``_PUBLIC`` table) a :class:`_PublicModule`; see its docstring."""
    module = sys.modules[package]
    for name in module._PUBLIC:  # a submodule imported already
        if isinstance(module.__dict__.get(name), types.ModuleType):
            del module.__dict__[name]
    module.__class__ = _PublicModule


class _MovedFinder(importlib.abc.MetaPathFinder):
    """Last on :data:`sys.meta_path`: a module no finder found that is in ``moved`` (old name ->
    new home) is refused in one line that names where it went."""

    def __init__(self, package: str, moved: dict):
        self.package, self.moved = package, moved

    def find_spec(self, fullname, path=None, target=None):
        head, _, rest = fullname.rpartition(".")  # package "bridgeflap.model"
        if head != self.package or rest not in self.moved:
            return None
        raise ModuleNotFoundError(
            f"No module named {fullname!r}: it moved to {self.moved[rest]} when the package was "
            f"split into rooms (docs/background/architecture.md, 'Module map')", name=fullname)


def moved_modules(package: str, moved: dict) -> None:
    """Name the new home of ``package``'s old flat modules when a script imports one."""
    if not any(isinstance(f, _MovedFinder) and f.package == package for f in sys.meta_path):
        sys.meta_path.append(_MovedFinder(package, moved))
