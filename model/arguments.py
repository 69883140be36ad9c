"""The checks at the door of every public function (and of the CLI, which shares them).

Each check takes a value and the name of the argument (or field) and returns the value,
normalised, or raises a typed error whose one-line message names the argument and the reason:
:class:`~bridgeflap.model.errors.BridgeflapTypeError` for the wrong type or kind,
:class:`~bridgeflap.model.errors.BridgeflapInputError` for a value out of its stated range. Nothing
is truncated (``n_modes=2.5`` is refused, not run with 2 modes) and no negative count slips into a
slice.

:func:`checked` decorates a public function with the rules of its arguments: the vocabulary's
names (:data:`RULES`: ``n_modes``, ``speed``, ``workers``, ...) are checked wherever they appear,
and a function adds or overrides rules by keyword (``@checked(controller=as_controller)``).
Arguments are checked before any work, so nothing is computed or written for a refused call.
"""

from __future__ import annotations

import functools
import inspect
import math
import os
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from bridgeflap.model.errors import BridgeflapInputError, BridgeflapTypeError
from bridgeflap.model.vocabulary import check_renamed

__all__ = ["MAX_GRID_VALUE", "MAX_MODES", "MAX_MODES_PER_FAMILY", "MAX_WORKERS", "RULES",
           "argv_list", "cases_list", "check_bool", "check_callable", "check_choice", "check_int",
           "check_mapping", "check_number", "check_path", "check_strings", "check_text",
           "checked", "count", "counts", "describe", "flag", "instance_or_path", "number",
           "numbers", "one_of", "optional"]

#: most retained vertical + torsional modes: the state grows by 6 per mode (2 structural and
#: 4 aerodynamic lags), and one eigenvalue problem at 100 modes (about 600 states) takes 0.1 s,
#: so a 171-point sweep about 20 s; the truncation study (bench/stability.py) converged at 16-24
MAX_MODES = 100
#: most modes kept of each family by ``modes_per_family``: the Humber FE model has 662 modes in
#: all (about 220 a family), so 1000 keeps every mode of any built-in bridge
MAX_MODES_PER_FAMILY = 1000
#: largest grid value: no wind speed [m/s] (and no fraction) comes near it; far below the
#: overflow of U^2 terms (:mod:`model.grid` reads grids with it)
MAX_GRID_VALUE = 1.0e4
#: most worker processes (the CLI's ``--workers`` bound too)
MAX_WORKERS = 1024


def describe(value: Any) -> str:
    """``value`` for a one-line message: its repr, shortened, with its type when not obvious."""
    text = repr(value).replace("\n", " ")
    if len(text) > 60:
        text = text[:57] + "..."
    if isinstance(value, str | int | float | bool | type(None)):
        return text
    return f"{text} ({type(value).__name__})"


def _is_int(value: Any) -> bool:
    return not isinstance(value, bool | np.bool_) and isinstance(value, int | np.integer)


def check_int(value: Any, field: str, minimum: int = 1, maximum: int | None = None) -> int:
    """``value`` if it is an integer (not a bool, not 2.5) in ``[minimum, maximum]``."""
    bounds = f">= {minimum}" if maximum is None else f"in [{minimum}, {maximum}]"
    if not _is_int(value):
        raise BridgeflapTypeError(field, f"must be an integer {bounds}, got {describe(value)}")
    if value < minimum:
        raise BridgeflapInputError(field, f"must be an integer {bounds}, got {value!r}")
    if maximum is not None and value > maximum:
        raise BridgeflapInputError(field, f"{value} is more than the limit of {maximum}")
    return int(value)


def check_number(value: Any, field: str, minimum: float | None = None,
                 maximum: float | None = None, strict: bool = False) -> float:
    """``value`` as a float if it is a finite number (not a bool) in range.

    ``strict``: ``minimum`` itself is excluded (``value > minimum``).
    """
    if isinstance(value, bool | np.bool_) or not isinstance(
            value, int | float | np.integer | np.floating):
        raise BridgeflapTypeError(field, f"must be a number, got {describe(value)}")
    v = float(value)
    if not math.isfinite(v):
        raise BridgeflapInputError(field, f"must be finite, got {value!r}")
    if minimum is not None and (v <= minimum if strict else v < minimum):
        raise BridgeflapInputError(field, f"must be {'>' if strict else '>='} {minimum:g}, "
                                          f"got {value!r}")
    if maximum is not None and v > maximum:
        raise BridgeflapInputError(field, f"must be <= {maximum:g}, got {value!r}")
    return v


def check_bool(value: Any, field: str) -> bool:
    """``value`` if it is true or false (no strings, no numbers)."""
    if not isinstance(value, bool | np.bool_):
        raise BridgeflapTypeError(field, f"must be true or false, got {describe(value)}")
    return bool(value)


def check_choice(value: Any, field: str, choices) -> str:
    """``value`` if it is one of ``choices``."""
    if not isinstance(value, str) or value not in choices:
        cls = BridgeflapInputError if isinstance(value, str) else BridgeflapTypeError
        raise cls(field, f"must be one of {', '.join(map(repr, choices))}, "
                         f"got {describe(value)}")
    return value


def check_text(value: Any, field: str) -> str:
    """``value`` if it is a non-empty string."""
    if not isinstance(value, str):
        raise BridgeflapTypeError(field, f"must be a string, got {describe(value)}")
    if not value.strip():
        raise BridgeflapInputError(field, "must not be empty")
    return value


def check_path(value: Any, field: str) -> str | os.PathLike:
    """``value`` if it can name a file: a non-empty ``str`` or :class:`os.PathLike` (no NUL)."""
    if not isinstance(value, str | os.PathLike):
        raise BridgeflapTypeError(field, f"must be a file path (str or pathlib.Path), got "
                                         f"{describe(value)}")
    text = os.fspath(value)
    if not isinstance(text, str):
        raise BridgeflapTypeError(field, f"must be a text path, got {describe(value)}")
    if not text.strip():
        raise BridgeflapInputError(field, "must not be an empty path")
    if "\0" in text:
        raise BridgeflapInputError(field, "a path cannot hold a NUL character")
    return value


def check_strings(value: Any, field: str) -> tuple[str, ...]:
    """``value`` as a tuple if it is a non-empty sequence of strings (a lone string is not)."""
    if isinstance(value, str | bytes | Mapping) or not isinstance(
            value, list | tuple | np.ndarray | set | frozenset):
        raise BridgeflapTypeError(field, f"must be a list of names, got {describe(value)}")
    out = tuple(value)
    if not out:
        raise BridgeflapInputError(field, "must name at least one entry")
    for v in out:
        if not isinstance(v, str):
            raise BridgeflapTypeError(field, f"must be a list of names, holds {describe(v)}")
    return out


def check_mapping(value: Any, field: str) -> Mapping:
    """``value`` if it is a mapping (a dict)."""
    if not isinstance(value, Mapping):
        raise BridgeflapTypeError(field, f"must be a mapping (dict), got {describe(value)}")
    return value


def check_callable(value: Any, field: str) -> Callable:
    """``value`` if it can be called."""
    if not callable(value):
        raise BridgeflapTypeError(field, f"must be callable, got {describe(value)}")
    return value


# ------------------------------------------------------------------ rule factories
def count(minimum: int = 1, maximum: int | None = None) -> Callable:
    """Rule: an integer in ``[minimum, maximum]``."""
    return lambda value, field: check_int(value, field, minimum, maximum)


def number(minimum: float | None = None, maximum: float | None = None,
           strict: bool = False) -> Callable:
    """Rule: a finite number in range."""
    return lambda value, field: check_number(value, field, minimum, maximum, strict)


def one_of(*choices: str) -> Callable:
    """Rule: one of ``choices``."""
    return lambda value, field: check_choice(value, field, choices)


def flag(value: Any, field: str) -> bool:
    """Rule: true or false."""
    return check_bool(value, field)


def instance_or_path(cls: type, what: str) -> Callable:
    """Rule: a ``cls`` (``what`` names its reader) or a path to read one from."""

    def rule(value, field):
        if isinstance(value, cls):
            return value
        if isinstance(value, str | os.PathLike):
            return check_path(value, field)
        raise BridgeflapTypeError(field, f"must be a {cls.__name__} ({what}) or a file path, "
                                         f"got {describe(value)}")

    return rule


def argv_list(value: Any, field: str) -> list:
    """Rule: a list of command-line words (a lone string is not one)."""
    if isinstance(value, str | bytes) or not isinstance(value, list | tuple):
        raise BridgeflapTypeError(field, "must be a list of command-line words such as "
                                         f"['flutter', 'humber'], got {describe(value)}")
    return list(value)


def cases_list(value: Any, field: str) -> list:
    """Rule: a sequence of cases, each a mapping of parameter names to values."""
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, list | tuple):
        raise BridgeflapTypeError(field, f"must be a list of dicts, got {describe(value)}")
    for case in value:
        if not isinstance(case, Mapping):
            raise BridgeflapTypeError(field, f"must be a list of dicts, holds {describe(case)}")
    return value


def numbers(value: Any, field: str) -> tuple[float, ...]:
    """Rule: a sequence of finite numbers (a lone number or a string is not one)."""
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, list | tuple | np.ndarray):
        raise BridgeflapTypeError(field, f"must be a list of numbers, got {describe(value)}")
    return tuple(check_number(v, field) for v in value)


def counts(minimum: int = 1, maximum: int | None = None) -> Callable:
    """Rule: a non-empty sequence of integers in ``[minimum, maximum]``."""

    def rule(value, field):
        if isinstance(value, str | bytes | Mapping) or not isinstance(
                value, list | tuple | range | np.ndarray):
            raise BridgeflapTypeError(field, f"must be a list of integers, got {describe(value)}")
        if len(value) == 0:
            raise BridgeflapInputError(field, "must hold at least one integer")
        return tuple(check_int(v, field, minimum, maximum) for v in value)

    return rule


def optional(rule: Callable) -> Callable:
    """Rule: ``None`` or what ``rule`` accepts."""
    return lambda value, field: None if value is None else rule(value, field)


#: rules of the vocabulary's names, wherever a :func:`checked` function takes them
RULES: dict[str, Callable] = {
    "n_modes": count(1, MAX_MODES),
    "modes_per_family": optional(count(1, MAX_MODES_PER_FAMILY)),
    "speed": number(0.0, MAX_GRID_VALUE),
    "workers": count(1, MAX_WORKERS),
    "speed_tol": number(0.0, 1.0e3, strict=True),
    "flap_chord_m": optional(number(0.0, 1.0e3, strict=True)),
    "sweep_method": one_of("dense", "fast"),
    "critical_only": flag,
    "verify_static": flag,
    "out_dir": check_path,
    "progress": optional(check_callable),
    "path": check_path,
}


def checked(**rules: Callable | None) -> Callable:
    """Decorate a public function: its arguments pass :data:`RULES` and ``rules`` first.

    A rule is ``rule(value, name) -> value``; ``name=None`` drops a rule of :data:`RULES` for
    this function. A call that does not fit the signature (a missing or unexpected argument) is
    a :class:`~bridgeflap.model.errors.BridgeflapTypeError` naming the function, and a former
    keyword name raises naming the new one (:func:`bridgeflap.model.vocabulary.check_renamed`).
    """

    def decorate(fn: Callable) -> Callable:
        signature = inspect.signature(fn)
        parameters = tuple(signature.parameters)
        every = {name: rule for name, rule in {**RULES, **rules}.items() if rule is not None}
        table = {name: rule for name, rule in every.items() if name in signature.parameters}
        extra = next((name for name, p in signature.parameters.items()
                      if p.kind is inspect.Parameter.VAR_KEYWORD), None)

        @functools.wraps(fn)
        def wrapper(*args, **kwargs):
            check_renamed(fn.__name__, parameters, kwargs)
            try:
                bound = signature.bind(*args, **kwargs)
            except TypeError as exc:
                raise BridgeflapTypeError(fn.__name__, str(exc)) from None
            given = bound.arguments
            for name, rule in table.items():
                if name in given and given[name] is not signature.parameters[name].default:
                    given[name] = rule(given[name], name)
            if extra is not None and given.get(extra):  # **options: the same names, same rules
                given[extra] = {k: every[k](v, k) if k in every and v is not None else v
                                for k, v in given[extra].items()}
            return fn(*bound.args, **bound.kwargs)

        wrapper.checked_arguments = tuple(table)  # read by the API matrix of tests/
        return wrapper

    return decorate
