"""Plausible ranges and value checks of bridge inputs (used by
:mod:`bridgeflap.model.structure.spec`).

Every check raises :class:`~bridgeflap.model.errors.BridgeflapInputError` naming the field, so that
a value no bridge can have (1e300, NaN, a negative mass, a zero length) stops at load instead of
ending in an overflow or in "stiffness is not positive definite" naming no input.
"""

from __future__ import annotations

import math
from typing import Any

from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["MAX_ELEMENTS", "MAX_SECTION_COORDINATE_M", "MAX_STRIPS", "MIN_SAG_RATIO",
           "PLAUSIBLE_RANGES",
           "check_finite", "check_in_range", "check_nonnegative", "check_positive",
           "check_section_geometry", "to_float"]

#: Plausible ranges ``(low, high)`` [SI] of the bridge inputs: a value outside is rejected at
#: load with its field named (it would otherwise end in an overflow or in "stiffness is not
#: positive definite" naming no input). They are at least two orders of magnitude outside any
#: suspension bridge built (Humber: deck 12 t/m, GJ 5e11 N m2, cable 0.29 m2; Akashi Kaikyo:
#: 1991 m main span), so no real design is refused; the cable modulus reaches 1e22 Pa because
#: studies of the inextensible-cable limit use 1e20 (tests/test_structure.py).
PLAUSIBLE_RANGES: dict[str, tuple[float, float]] = {
    "length_m": (1.0, 1.0e5),
    "cable_area_m2": (1.0e-4, 1.0e2),
    "cable.area_m2": (1.0e-4, 1.0e2),
    "cable.modulus_pa": (1.0e3, 1.0e22),
    "cable.mass_kg_per_m": (1.0e-6, 1.0e6),
    "cable.spacing_m": (0.1, 1.0e3),
    "deck.mass_kg_per_m": (1.0e-3, 1.0e6),
    "deck.mass_inertia_kgm2_per_m": (1.0e-3, 1.0e11),
    "deck.ei_vertical_nm2": (0.0, 1.0e17),
    "deck.ei_lateral_nm2": (0.0, 1.0e17),
    "deck.gj_nm2": (0.0, 1.0e17),
    "deck.half_chord_m": (0.1, 200.0),
    "deck.hanger_length_midspan_m": (1.0e-3, 1.0e3),
    "aero.air_density_kg_m3": (1.0e-6, 100.0),
    "aero.deck_height_m": (0.1, 1.0e4),
    "aero.turbulence_intensity": (1.0e-6, 1.0),
    "aero.coherence_decay": (1.0e-6, 1.0e3),
    "aero.lift_slope_buffeting": (-100.0, 100.0),
    "aero.moment_slope_buffeting": (-100.0, 100.0),
}
#: smallest main-span sag as a fraction of the main span [-] (Humber: 1/12.3)
MIN_SAG_RATIO = 1.0e-4
#: most finite elements of a mesh: the families' matrices are dense and solved by a dense
#: eigh, O(n^3); 1000 elements give about 4000 lateral DOFs (Humber's 23.5 m mesh: 95 elements)
MAX_ELEMENTS = 1000
#: most aerodynamic strips of an imported modal deck (``structure.strip_length_m``): the strip
#: loads are (n_strip, n_modes) arrays per frequency and speed; 100000 strips are 2 cm strips
#: on the longest span built (1991 m), while Humber's 23.5 m strips give 95 and a few hundred
#: resolve any mode of interest. 1e-9 m strips would be 1e12 strips (terabytes)
MAX_STRIPS = 100_000


def to_float(field_name: str, raw: Any) -> float:
    """``raw`` as a float if it is a TOML number (not a bool) that a float can hold."""
    if isinstance(raw, bool) or not isinstance(raw, int | float):
        raise BridgeflapInputError(field_name, f"must be a number, got {raw!r}")
    try:
        return float(raw)
    except OverflowError:  # an integer beyond 1.8e308
        raise BridgeflapInputError(field_name, "number too large") from None


#: largest coordinate or width of a ``[[deck_section]]`` item [m]: no deck section is a
#: kilometre across, and ``r^2`` of 1e300 overflows
MAX_SECTION_COORDINATE_M = 1.0e3


def check_section_geometry(items: Any) -> None:
    """Bound the ``*_m`` values of ``[[deck_section]]`` items
    (:mod:`bridgeflap.model.structure.section_props` checks
    the rest: kinds, keys, finiteness, masses)."""
    if not isinstance(items, list):
        return
    for i, item in enumerate(items):
        if not isinstance(item, dict):
            continue
        where = f"deck_section.{item.get('name', i)}"
        for key, v in item.items():
            if key.endswith("_m") and not key.endswith("_per_m") and isinstance(v, int | float) \
                    and not isinstance(v, bool):
                if abs(to_float(f"{where}.{key}", v)) > MAX_SECTION_COORDINATE_M:
                    raise BridgeflapInputError(f"{where}.{key}", f"{v:g} m is beyond "
                                               f"+-{MAX_SECTION_COORDINATE_M:g} m")


def check_finite(field_name: str, v: float) -> None:
    if not isinstance(v, int | float) or not math.isfinite(v):
        raise BridgeflapInputError(field_name, f"must be a finite number, got {v!r}")


def check_in_range(field_name: str, v: float, key: str | None = None) -> None:
    """Raise unless ``v`` is a finite number in :data:`PLAUSIBLE_RANGES` (looked up by ``key``,
    default ``field_name``); a field without a range must be finite and positive."""
    check_finite(field_name, v)
    rng = PLAUSIBLE_RANGES.get(key or field_name)
    if rng is None:
        check_positive(field_name, v)
        return
    lo, hi = rng
    if lo == 0.0:
        check_nonnegative(field_name, v)
    elif lo > 0.0:
        check_positive(field_name, v)
    if not lo <= v <= hi:
        raise BridgeflapInputError(field_name, f"{v:g} is outside the plausible range "
                                               f"[{lo:g}, {hi:g}]")


def check_positive(field_name: str, v: float) -> None:
    check_finite(field_name, v)
    if v <= 0:
        raise BridgeflapInputError(field_name, f"must be positive, got {v}")


def check_nonnegative(field_name: str, v: float) -> None:
    check_finite(field_name, v)
    if v < 0:
        raise BridgeflapInputError(field_name, f"must not be negative, got {v}")
