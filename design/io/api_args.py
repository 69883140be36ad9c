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

from bridgeflap.model.arguments import (
    MAX_MODES,
    MAX_WORKERS,
    check_bool,
    check_callable,
    check_choice,
    check_int,
    check_mapping,
    check_number,
    describe,
)
from bridgeflap.model.errors import BridgeflapInputError, BridgeflapTypeError

__all__ = ["MAX_DESIGN_SPEED_M_S", "MAX_SEED", "MAX_VARIANTS", "check_accept_args",
           "check_design_args", "check_design_speed", "check_harm_args", "check_model_modes",
           "check_load_settings_args", "check_scheduler", "check_seed", "check_settings",
           "check_variants"]

# ------------------------------------------------------------ one bound per quantity
# The CLI's options and the API's arguments of the same quantity are checked by the same
# function below, so a value the one refuses the other refuses too, with the same limit.

#: most fresh variants of one do-no-harm check (``bridgeflap robustness --samples``,
#: ``bridgeflap optimise --check-samples``, ``do_no_harm(count=)``, ``accept(samples=)``): a
#: million rows would take days on a workstation
MAX_VARIANTS = 100_000
#: highest design speed [m/s] (``--speed-max``, ``speed_max_m_s``): the sweeps run to 1.5 times
#: it, which keeps them far inside the grids' bound (model.arguments.MAX_GRID_VALUE); no wind
#: comes near it
MAX_DESIGN_SPEED_M_S = 1000.0
#: highest seed (``--seed``, ``seed=``): numpy's SeedSequence takes non-negative integers, and
#: 32 bits are what the CLI has always taken
MAX_SEED = 2 ** 32 - 1


def check_variants(value: Any, field: str = "count") -> int:
    """A count of fresh variants in ``[1, MAX_VARIANTS]``."""
    return check_int(value, field, 1, MAX_VARIANTS)


def check_seed(value: Any, field: str = "seed") -> int:
    """A seed in ``[0, MAX_SEED]``."""
    return check_int(value, field, 0, MAX_SEED)


def check_design_speed(value: Any, field: str = "speed_max_m_s") -> float:
    """A design speed [m/s] in ``(0, MAX_DESIGN_SPEED_M_S]``."""
    return check_number(value, field, 0.0, MAX_DESIGN_SPEED_M_S, strict=True)


def check_scheduler(value: Any, field: str = "scheduler") -> str | None:
    """None, ``"local"`` or a Dask scheduler address (its form only: it is reached later,
    before any work, by :func:`bridgeflap.design.batch.cluster.connect_scheduler`)."""
    if value is None:
        return None
    if not isinstance(value, str):
        raise BridgeflapTypeError(field, "must be 'local' or a Dask scheduler address such as "
                                         f"tcp://host:8786, got {describe(value)}")
    if not value.strip():
        raise BridgeflapInputError(field, "must be 'local' or a Dask scheduler address such "
                                          "as tcp://host:8786, got an empty string")
    return value

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


def check_harm_args(controller, bridge, count, seed, n_modes, speed_max_m_s, speeds, ranges,
                    fixed, workers, progress, method, screen_modes, sampling, scheduler,
                    methods, samplings):
    """The arguments of :func:`bridgeflap.design.assessment.harm.do_no_harm`, checked before
    any work (one line each, with the CLI's bounds). Returns ``(controller, spec, speeds)``:
    a controller file's path is read, a bridge name or path loaded, a speed grid parsed."""
    from bridgeflap.model.aeroelastic.controller_file import as_controller
    from bridgeflap.model.grid import speed_grid
    from bridgeflap.model.structure.bridge_arg import as_bridge
    from bridgeflap.model.structure.spec import BridgeSpec

    check_variants(count, "count")
    check_seed(seed, "seed")
    check_int(n_modes, "n_modes", 1, MAX_MODES)
    check_design_speed(speed_max_m_s, "speed_max_m_s")
    check_int(workers, "workers", 1, MAX_WORKERS)
    if progress is not None:
        check_callable(progress, "progress")
    check_choice(method, "method", methods)
    check_choice(sampling, "sampling", samplings)
    if screen_modes is not None:
        check_int(screen_modes, "screen_modes", 1, MAX_MODES)
    check_scheduler(scheduler)
    if ranges is not None:
        check_mapping(ranges, "ranges")
    if isinstance(fixed, str | bytes) or not isinstance(fixed, Sequence | set | frozenset):
        raise BridgeflapTypeError("fixed", f"must be a list of input names, got "
                                           f"{describe(fixed)}")
    grid = None if speeds is None else speed_grid(speeds, "speeds", min_points=2,
                                                  increasing=True)
    controller = as_controller(controller, "controller")
    spec = as_bridge(bridge, "bridge")
    if not isinstance(spec, BridgeSpec):
        raise BridgeflapTypeError("bridge", "must be a built-in bridge name, a bridge .toml "
                                            f"path or a BridgeSpec, got {describe(bridge)}")
    check_model_modes(spec, n_modes, "n_modes")
    return controller, spec, grid


def check_model_modes(spec, n_modes: int, field: str = "n_modes") -> None:
    """Raise naming ``field`` when the model of ``spec`` has fewer vertical and torsional
    modes than ``n_modes``: checked before any work or progress line (its modal model is
    solved here, a fraction of a second), not by each worker once the variants run."""
    from bridgeflap.model.analysis import modal_model

    if getattr(spec, "structure", None) is not None:  # imported modal data: checked on use
        return
    try:
        modal_model(spec).structural_basis(int(n_modes))
    except BridgeflapInputError as exc:
        if exc.field != "modes":
            raise
        raise BridgeflapInputError(field, exc.reason) from None


def check_accept_args(seed=None, quick=False, quick_field: str = "quick") -> None:
    """``seed`` (the CLI's bound) and ``quick`` (true or false, not a string) of
    :func:`bridgeflap.design.accept` and :func:`bridgeflap.design.design` (``quick_checks``)."""
    if seed is not None:
        check_seed(seed, "seed")
    check_bool(quick, quick_field)
