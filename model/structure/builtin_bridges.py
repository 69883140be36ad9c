"""The built-in bridges: their names and definition files under ``model/bridges/``.

``load_bridge("humber")`` (:func:`bridgeflap.model.structure.loader.load_bridge`) reads
``model/bridges/humber.toml``; files a built-in bridge refers to (modal data, derivative
tables) are relative to its own folder (:func:`builtin_folder`).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

__all__ = ["BUILTIN_BRIDGES", "BUILTIN_FILES", "builtin_folder"]

#: built-in bridge name -> definition file under model/bridges/
BUILTIN_FILES = {"humber": "humber.toml", "great-belt": "great_belt.toml",
                 "iabse-2a": "iabse/step2a_bridge.toml"}
BUILTIN_BRIDGES = tuple(BUILTIN_FILES)


def builtin_folder(origin: str) -> Path | None:
    """The folder of built-in bridge ``origin``'s definition file; None for any other origin."""
    if origin in BUILTIN_FILES:
        return Path(str(resources.files("bridgeflap.model.bridges").joinpath(
            BUILTIN_FILES[origin]))).parent
    return None
