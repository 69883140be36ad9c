"""Grid text and number grids: the one reader of ``speeds`` (docs/api_vocabulary.md).

The command line, study and DOE files and scripts give wind-speed grids (and erected
fractions) as text (``start:stop:step``, ``stop`` included when on the grid, or a comma list)
or as numbers; :func:`parse_range` reads the text, :func:`grid` either form, and
:func:`speed_grid` is what every public function taking ``speeds`` [m/s] calls.
:mod:`bridgeflap.design.io.options` re-exports the first two.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bridgeflap.model.arguments import (  # MAX_GRID_VALUE: the checks' bound, stated there
    MAX_GRID_VALUE,
    check_text,
    checked,
    number,
    optional,
)
from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["MAX_GRID_POINTS", "MAX_GRID_VALUE", "grid", "parse_range", "speed_grid"]

#: most points of one grid: a flutter sweep costs about 1 ms per point at 16 modes (an
#: eigenvalue problem of 96 states), so 20000 points is already half a minute
MAX_GRID_POINTS = 20000
@checked(field=check_text, minimum=optional(number()), maximum=optional(number()))
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

    Examples
    --------
    >>> from bridgeflap import design
    >>> design.parse_range("0:10:2.5", "speeds")
    array([ 0. ,  2.5,  5. ,  7.5, 10. ])
    >>> design.parse_range("1,2,5", "speeds")
    array([1., 2., 5.])
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


def speed_grid(speeds: Any, field: str = "speeds", min_points: int = 1,
               positive: bool = False, increasing: bool = False) -> np.ndarray:
    """A wind-speed grid [m/s] from any accepted form, checked (docs/api_vocabulary.md).

    Parameters
    ----------
    speeds : str, sequence or numpy.ndarray
        ``"lo:hi:step"`` or ``"20,40,60"`` text (:func:`parse_range`), or numbers [m/s].
    field : str
        Name of the input, used in the error message.
    min_points : int
        Fewest speeds allowed.
    positive : bool
        Speeds must be ``> 0`` (else ``>= 0``).
    increasing : bool
        Speeds must be strictly increasing.

    Raises
    ------
    BridgeflapInputError
        Not numeric, too few points, non-finite, negative (or zero with ``positive``) or, with
        ``increasing``, not strictly increasing speeds.
    """
    if isinstance(speeds, str):
        u = parse_range(speeds, field, 0.0)
    else:
        try:
            u = np.atleast_1d(np.asarray(speeds, dtype=float)).ravel()
        except (TypeError, ValueError):
            raise BridgeflapInputError(field, "not numeric") from None
    if u.size < min_points:
        raise BridgeflapInputError(field, "the grid needs at least two speeds" if min_points == 2
                                   else f"needs at least {min_points} speed(s)")
    if not np.all(np.isfinite(u)):
        raise BridgeflapInputError(field, "must be finite")
    if positive and np.any(u <= 0):
        raise BridgeflapInputError(field, "need finite mean wind speeds > 0 [m/s]")
    if np.any(u < 0):
        raise BridgeflapInputError(field, f"must not be negative (min {u.min()})")
    if increasing and np.any(np.diff(u) <= 0):
        raise BridgeflapInputError(field, "must be strictly increasing")
    return u
