"""The checks at the door of the design API whose functions live above this room.

:func:`bridgeflap.design.design`, :func:`bridgeflap.design.quick_settings` and
:func:`bridgeflap.design.load_settings` call one of these on their first line, so a wrong argument
is a typed one-line error naming it (:mod:`bridgeflap.model.arguments`, the checks the CLI shares)
before any work. This module sits in
:mod:`bridgeflap.design.io`, below :mod:`bridgeflap.design.control`, so it recognises a
:class:`~bridgeflap.design.control.settings.DesignSettings` by its class's module and name rather
than by importing it (tests/project/test_layering.py).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from bridgeflap.model.arguments import check_bool, check_callable, describe
from bridgeflap.model.errors import BridgeflapTypeError

__all__ = ["check_design_args", "check_load_settings_args", "check_settings"]

_SETTINGS_CLASS = ("bridgeflap.design.control.settings", "DesignSettings")


def check_settings(settings: Any, field: str = "settings") -> Any:
    """``settings`` if it is a :class:`~bridgeflap.design.control.settings.DesignSettings`."""
    cls = type(settings)
    if (cls.__module__, cls.__name__) == _SETTINGS_CLASS:
        return settings
    if isinstance(settings, str | os.PathLike):
        raise BridgeflapTypeError(field, f"must be DesignSettings, got the path {settings!r}: "
                                         "read a card with design.load_settings(path)")
    if isinstance(settings, Mapping):
        raise BridgeflapTypeError(field, "must be DesignSettings, got a dict: give its keys to "
                                         "design.load_settings(None, **values)")
    raise BridgeflapTypeError(field,
                              f"must be DesignSettings (bridgeflap.design.load_settings), got "
                                     f"{describe(settings)}")


def _warm_start(value: Any, field: str = "warm_start") -> None:
    from bridgeflap.model.aeroelastic.control import Compensator, Controller

    if isinstance(value, Controller | Compensator):
        return
    if isinstance(value, str | os.PathLike):
        raise BridgeflapTypeError(field, f"must be a Controller, a Compensator or numbers, got "
                                         f"the path {value!r}: read it with "
                                         "model.load_controller(path)")
    if isinstance(value, list | tuple | np.ndarray):
        try:
            theta = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            theta = None
        if theta is not None and theta.ndim == 1 and theta.size and np.isfinite(theta).all():
            return
    raise BridgeflapTypeError(field, "must be a Controller, a Compensator or a list of finite "
                                     f"numbers, got {describe(value)}")


def check_design_args(settings, progress=None, bridge=None, warm_start=None,
                      progress_bar=None, records=None) -> None:
    """The arguments of :func:`bridgeflap.design.design`, checked before any work (one line
    each)."""
    from bridgeflap.model.structure.bridge_arg import as_bridge

    check_settings(settings)
    if progress is not None:
        check_callable(progress, "progress")
    if bridge is not None:
        as_bridge(bridge)  # a name or a file is read now: a bad one stops before the design
    if warm_start is not None:
        _warm_start(warm_start)
    if progress_bar is not None:
        check_bool(progress_bar, "progress_bar")
    if records is not None and (isinstance(records, str | bytes | Mapping)
                                or not isinstance(records, Sequence)):
        raise BridgeflapTypeError("records", "must be a sequence of start records, got "
                                             f"{describe(records)}")


def check_load_settings_args(path: Any, overrides: Mapping) -> None:
    """The arguments of :func:`bridgeflap.design.load_settings`: a card path, ``"default"`` or
    ``None``, and keyword overrides (their values are checked with the card's own rules)."""
    if path is not None and not isinstance(path, str | os.PathLike):
        raise BridgeflapTypeError("path", "must be a design card path, 'default' or None, got "
                                          f"{describe(path)}")
