"""Reading what a user writes: grid text, definition files and option values.

The command line, study files and DOE files give wind-speed grids and erected fractions as text
(``start:stop:step`` or a comma list) and options as TOML values. This module turns them into
arrays and checked values; the grid reader itself is :mod:`bridgeflap.model.grid` (re-exported
here), the one that every ``speeds`` argument of :mod:`bridgeflap.model` goes through too.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from bridgeflap.model.arguments import (  # the checks of the API, shared so the messages match
    MAX_MODES,
    check_bool,
    check_choice,
    check_int,
    check_number,
)
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.grid import MAX_GRID_POINTS, MAX_GRID_VALUE, grid, parse_range

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["MAX_DOE_CASES", "MAX_GRID_POINTS", "MAX_GRID_VALUE", "MAX_MODES", "check_bool",
           "check_choice",
           "check_int", "check_keys", "check_number", "check_option_names", "grid",
           "parse_range", "plain_name", "read_definition", "read_toml", "resolve_bridge",
           "table"]

#: most cases of one DOE (a full factorial grows as levels^parameters): a case takes about a
#: second, so 100000 cases is already a day on one core
MAX_DOE_CASES = 100000


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
    in-memory :class:`~bridgeflap.model.structure.spec.BridgeSpec` as it is (a script's modified
    bridge).

    The bridge is loaded once here, so that bad input stops before anything is written.
    """
    from bridgeflap.model.structure.builtin_bridges import BUILTIN_BRIDGES
    from bridgeflap.model.structure.loader import _split_variant, load_bridge
    from bridgeflap.model.structure.spec import BridgeSpec

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
