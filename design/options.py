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

__all__ = ["MAX_DOE_CASES", "MAX_GRID_POINTS", "MAX_GRID_VALUE", "MAX_MODES", "check_bool",
           "check_choice",
           "check_int", "check_keys", "check_number", "check_option_names", "grid",
           "parse_range", "plain_name", "read_definition", "read_toml", "resolve_bridge",
           "table"]

#: most points of one grid: a flutter sweep costs about 1 ms per point at 16 modes (an
#: eigenvalue problem of 96 states), so 20000 points is already half a minute
MAX_GRID_POINTS = 20000
_MAX_POINTS = MAX_GRID_POINTS  # former name
#: largest grid value: no wind speed [m/s] (and no fraction) comes near it; far below the
#: overflow of U^2 terms
MAX_GRID_VALUE = 1.0e4
#: most retained vertical + torsional modes: the state grows by 6 per mode (2 structural and
#: 4 aerodynamic lags), and one eigenvalue problem at 100 modes (about 600 states) takes 0.1 s,
#: so a 171-point sweep about 20 s; the truncation study (bench/stability.py) converged at 16-24
MAX_MODES = 100
#: most cases of one DOE (a full factorial grows as levels^parameters): a case takes about a
#: second, so 100000 cases is already a day on one core
MAX_DOE_CASES = 100000


def parse_range(text: str, field: str, minimum: float | None = None,
                maximum: float | None = MAX_GRID_VALUE) -> np.ndarray:
    """Parse ``start:stop:step`` (inclusive of ``stop``) or a comma list into an array.

    Parameters
    ----------
    text : str
        ``"0:85:0.5"`` (start, stop, step; ``stop`` included when on the grid) or ``"1,2,5"``.
    field : str
        Name of the input, used in the error message.
    minimum : float, optional
        Smallest allowed value.
    maximum : float, optional
        Largest allowed value (default :data:`MAX_GRID_VALUE`).

    Returns
    -------
    numpy.ndarray
        The values, ``start + step * arange(n)`` for a range.

    Raises
    ------
    BridgeflapInputError
        Not a number grid, an empty grid or one of more than :data:`MAX_GRID_POINTS`
        points, non-finite values or values outside ``[minimum, maximum]``.
    """
    if not isinstance(text, str):
        raise BridgeflapInputError(field, f"must be grid text such as '0:85:0.5' or '1,2,5', "
                                          f"got {text!r}")
    if len(text) > 20 * MAX_GRID_POINTS:
        raise BridgeflapInputError(field, f"grid text too long (at most {MAX_GRID_POINTS} "
                                          "points)")
    try:
        if ":" in text:
            parts = [float(p) for p in text.split(":")]
            if len(parts) != 3:
                raise ValueError
            start, stop, step = parts
            if not all(np.isfinite(parts)):
                raise BridgeflapInputError(field, f"start, stop and step must be finite, "
                                                  f"got {text!r}")
            if not step > 0 or stop < start:
                raise BridgeflapInputError(
                    field, f"empty grid {text!r} (need start <= stop, step > 0)")
            n = (stop - start) / step + 1e-9
            if not n < MAX_GRID_POINTS:  # also catches an overflow to inf
                raise BridgeflapInputError(field, f"grid {text!r} has more than the limit of "
                                                  f"{MAX_GRID_POINTS} points")
            values = start + step * np.arange(int(np.floor(n)) + 1)
        else:
            values = np.array([float(p) for p in text.split(",") if p.strip()])
    except BridgeflapInputError:
        raise
    except ValueError:
        raise BridgeflapInputError(field, f"not a number grid: {text!r}") from None
    return _check_values(values, field, minimum, maximum)


def _check_values(values: np.ndarray, field: str, minimum, maximum) -> np.ndarray:
    if values.size == 0:
        raise BridgeflapInputError(field, "empty grid")
    if values.size > MAX_GRID_POINTS:
        raise BridgeflapInputError(field, f"{values.size} points, more than the limit of "
                                          f"{MAX_GRID_POINTS}")
    if not np.all(np.isfinite(values)):
        raise BridgeflapInputError(field, "values must be finite")
    if minimum is not None and np.any(values < minimum):
        raise BridgeflapInputError(field, f"values must be >= {minimum} (got {values.min()})")
    if maximum is not None and np.any(values > maximum):
        raise BridgeflapInputError(field, f"values must be <= {maximum:g} (got "
                                          f"{values.max():g})")
    return values


def grid(value: Any, field: str, minimum: float | None = None,
         maximum: float | None = MAX_GRID_VALUE) -> np.ndarray:
    """An array from grid text (:func:`parse_range`) or from a list of numbers (checked alike)."""
    if isinstance(value, str):
        return parse_range(value, field, minimum, maximum)
    if isinstance(value, np.ndarray) and value.dtype.kind in "fiu":
        values = value.astype(float).ravel()
    elif isinstance(value, list | tuple) and all(
            isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool)
            for v in value):
        values = np.asarray(value, dtype=float).ravel()
    else:
        raise BridgeflapInputError(field, f"must be grid text such as '0:85:0.5' or a list of "
                                          f"numbers, got {value!r}")
    return _check_values(values, field, minimum, maximum)


def check_int(value: Any, field: str, minimum: int = 1, maximum: int | None = None) -> int:
    """``value`` if it is an integer (not a bool) in ``[minimum, maximum]``."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise BridgeflapInputError(field, f"must be an integer >= {minimum}, got {value!r}")
    if maximum is not None and value > maximum:
        raise BridgeflapInputError(field, f"{value} is more than the limit of {maximum}")
    return int(value)


def check_number(value: Any, field: str, minimum: float | None = None,
                 maximum: float | None = None, strict: bool = False) -> float:
    """``value`` as a float if it is a finite number (not a bool) in range.

    ``strict``: ``minimum`` itself is excluded (``value > minimum``).
    """
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise BridgeflapInputError(field, f"must be a number, got {value!r}")
    v = float(value)
    if not np.isfinite(v):
        raise BridgeflapInputError(field, f"must be finite, got {value!r}")
    if minimum is not None and (v <= minimum if strict else v < minimum):
        raise BridgeflapInputError(field, f"must be {'>' if strict else '>='} {minimum:g}, "
                                          f"got {value!r}")
    if maximum is not None and v > maximum:
        raise BridgeflapInputError(field, f"must be <= {maximum:g}, got {value!r}")
    return v


def check_bool(value: Any, field: str) -> bool:
    """``value`` if it is true or false (TOML booleans; no strings, no numbers)."""
    if not isinstance(value, bool | np.bool_):
        raise BridgeflapInputError(field, f"must be true or false, got {value!r}")
    return bool(value)


def check_choice(value: Any, field: str, choices) -> str:
    """``value`` if it is one of ``choices``."""
    if not isinstance(value, str) or value not in choices:
        raise BridgeflapInputError(field, f"must be one of {', '.join(map(repr, choices))}, "
                                          f"got {value!r}")
    return value


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
    try:  # an OSError of is_file too: a name beyond the file system's NAME_MAX
        if not path.is_file():
            raise BridgeflapInputError(field_name, f"file not found: {path}")
        return tomllib.loads(path.read_text("utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
        raise BridgeflapInputError(field_name, f"cannot read {path}: {why}") from None
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


def resolve_bridge(bridge: Any, base: Path, field_name: str = "bridge") -> Any:
    """A built-in bridge name, or the absolute path of a bridge TOML relative to ``base``; an
    in-memory :class:`~model.spec.BridgeSpec` as it is (a script's modified bridge).

    The bridge is loaded once here, so that bad input stops before anything is written.
    """
    from model.spec import BUILTIN_BRIDGES, BridgeSpec, _split_variant, load_bridge

    if isinstance(bridge, BridgeSpec):
        return bridge
    if isinstance(bridge, Path):
        bridge = str(bridge)
    if not isinstance(bridge, str) or not bridge:
        raise BridgeflapInputError(field_name, "missing, or not a built-in name, a bridge .toml "
                                               "path or a BridgeSpec")
    head, variant = _split_variant(bridge)  # "humber:box", "my.toml:variant"
    if head not in BUILTIN_BRIDGES:
        p = Path(head)
        head = str(p if p.is_absolute() else (base / p).resolve())
    bridge = head if variant is None else f"{head}:{variant}"
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
