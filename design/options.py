"""Reading what a user writes: grid text, definition files and option values.

The command line, study files and DOE files give wind-speed grids and erected fractions as text
(``start:stop:step`` or a comma list) and options as TOML values. This module turns them into
arrays and checked values; :mod:`model` only ever sees arrays.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from model.errors import BridgeflapInputError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["check_int", "check_keys", "check_option_names", "grid", "parse_range", "plain_name",
           "read_definition", "read_toml", "resolve_bridge", "table"]

_MAX_POINTS = 100000


def parse_range(text: str, field: str, minimum: float | None = None) -> np.ndarray:
    """Parse ``start:stop:step`` (inclusive of ``stop``) or a comma list into an array.

    Parameters
    ----------
    text : str
        ``"0:85:0.5"`` (start, stop, step; ``stop`` included when on the grid) or ``"1,2,5"``.
    field : str
        Name of the input, used in the error message.
    minimum : float, optional
        Smallest allowed value.

    Returns
    -------
    numpy.ndarray
        The values, ``start + step * arange(n)`` for a range.

    Raises
    ------
    BridgeflapInputError
        Not a number grid, an empty or oversized grid, non-finite values or values below
        ``minimum``.
    """
    try:
        if ":" in str(text):
            parts = [float(p) for p in str(text).split(":")]
            if len(parts) != 3:
                raise ValueError
            start, stop, step = parts
            if not (np.isfinite(step) and step > 0) or stop < start:
                raise BridgeflapInputError(
                    field, f"empty grid {text!r} (need start <= stop, step > 0)")
            n = int(np.floor((stop - start) / step + 1e-9)) + 1
            if n > _MAX_POINTS:
                raise BridgeflapInputError(field, f"grid {text!r} has too many points")
            values = start + step * np.arange(n)
        else:
            values = np.array([float(p) for p in str(text).split(",") if p.strip()])
    except BridgeflapInputError:
        raise
    except ValueError:
        raise BridgeflapInputError(field, f"not a number grid: {text!r}") from None
    if values.size == 0:
        raise BridgeflapInputError(field, "empty grid")
    if not np.all(np.isfinite(values)):
        raise BridgeflapInputError(field, "values must be finite")
    if minimum is not None and np.any(values < minimum):
        raise BridgeflapInputError(field, f"values must be >= {minimum} (got {values.min()})")
    return values


def grid(value: Any, field: str, minimum: float | None = None) -> np.ndarray:
    """An array from grid text (:func:`parse_range`) or from numbers (passed through)."""
    if isinstance(value, str):
        return parse_range(value, field, minimum)
    return np.asarray(value, dtype=float)


def check_int(value: Any, field: str, minimum: int = 1) -> int:
    """``value`` if it is an integer (not a bool) of at least ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise BridgeflapInputError(field, f"must be an integer >= {minimum}, got {value!r}")
    return int(value)


def check_option_names(kind: str, names, allowed: tuple | None, what: str) -> None:
    """Raise unless every option name is in ``allowed`` (``None``: anything goes)."""
    if allowed is None:
        return
    for key in names:
        if key not in allowed:
            raise BridgeflapInputError(f"{what}.{key}", f"not an option of {kind} "
                                                        f"(known: {', '.join(allowed)})")


def read_toml(path: Path, field_name: str) -> dict:
    """Parsed TOML of ``path``; a missing, unreadable or malformed file is bad input."""
    if not path.is_file():
        raise BridgeflapInputError(field_name, f"file not found: {path}")
    try:
        return tomllib.loads(path.read_text("utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise BridgeflapInputError(field_name, f"cannot read {path}: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise BridgeflapInputError(field_name, f"malformed TOML in {path}: {exc}") from None


def read_definition(path: Path, field_name: str) -> tuple[dict, Path, str]:
    """A definition file's parsed TOML, its folder (relative paths) and its name (source)."""
    return read_toml(path, field_name), path.parent, str(path)


def check_keys(data: Mapping, allowed, what: str, known: str = "") -> None:
    """Raise on the first key of ``data`` not in ``allowed`` (``what``: which file)."""
    unknown = set(data) - set(allowed)
    if unknown:
        raise BridgeflapInputError(sorted(unknown)[0], f"unknown key in the {what} file"
                                                      + (f" ({known})" if known else ""))


def resolve_bridge(bridge: Any, base: Path, field_name: str = "bridge") -> str:
    """A built-in bridge name, or the absolute path of a bridge TOML relative to ``base``.

    The bridge is loaded once here, so that bad input stops before anything is written.
    """
    from model.spec import BUILTIN_BRIDGES, load_bridge

    if not isinstance(bridge, str) or not bridge:
        raise BridgeflapInputError(field_name, "missing or not a string")
    if bridge not in BUILTIN_BRIDGES:
        p = Path(bridge)
        bridge = str(p if p.is_absolute() else (base / p).resolve())
    load_bridge(bridge)
    return bridge


def plain_name(value: Any, field_name: str = "name") -> str:
    """``value`` if it can name a folder (no separators, no leading dot)."""
    if not isinstance(value, str) or not value or any(c in value for c in "/\\") \
            or value.startswith("."):
        raise BridgeflapInputError(field_name, f"must be a plain folder name, got {value!r}")
    return value


def table(data: Mapping, key: str) -> dict:
    """``data[key]`` as a dict (missing: empty); anything else is bad input."""
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise BridgeflapInputError(key, "must be a table of options")
    return dict(value)
