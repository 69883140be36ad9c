"""The lazy public face of a package (PEP 562): names resolve on first use.

``import model`` and ``import design`` then stay light (no CasADi, matplotlib or Dask) while a
script can still write ``from model import load_bridge, flutter``.
"""

from __future__ import annotations

import importlib


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
