"""Deck mass and mass moment of inertia from a lumped cross-section (``[[deck_section]]``).

Each item of a bridge file's ``[[deck_section]]`` array is one lumped part of the deck cross
section with its mass per unit length and its geometry, placed symmetrically about the deck
centre line (a part at lateral offset ``x_m > 0`` stands for two halves at ``+-x_m``). The deck
rotates about its centre point (the paper, §2), taken here at mid-depth on the centre line;
``y_m`` is the height above that point. The radius of gyration of each kind, ``r^2`` [m^2]:

``plate``   a horizontal strip of total width ``width_m`` centred at ``(+-x_m, y_m)``:
            ``r^2 = x^2 + w^2/12 + y^2`` (``x_m = 0`` for a strip across the centre line)
``line``    a straight plate (web) from ``(x1_m, y1_m)`` to ``(x2_m, y2_m)``, mirrored:
            ``r^2 = |centroid|^2 + l^2/12``
``point``   a lumped mass at ``(+-x_m, y_m)``: ``r^2 = x^2 + y^2``
``area``    mass spread uniformly over a symmetric trapezoid (diaphragms) of width
            ``top_width_m`` at ``y_top_m`` and ``bottom_width_m`` at ``y_bottom_m``:
            ``r^2 = (int (x^2 + y^2) dA) / A`` by Gauss-Legendre in ``y`` (exact: polynomial)

and the deck values are ``m = sum m_i`` and ``I = sum m_i r_i^2``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bridgeflap.model.errors import BridgeflapInputError

KINDS = ("plate", "line", "point", "area")
_GEOMETRY = {
    "plate": ("width_m", "x_m", "y_m"),
    "line": ("x1_m", "y1_m", "x2_m", "y2_m"),
    "point": ("x_m", "y_m"),
    "area": ("top_width_m", "bottom_width_m", "y_top_m", "y_bottom_m"),
}
_OPTIONAL_ZERO = {"x_m"}


@dataclass(frozen=True)
class SectionItem:
    """One lumped part of the deck section (module docstring)."""

    name: str
    kind: str
    mass_kg_per_m: float
    geometry: tuple
    source: str = "not stated"

    def radius_sq_m2(self) -> float:
        """Squared radius of gyration about the deck centre point [m^2]."""
        g = dict(zip(_GEOMETRY[self.kind], self.geometry, strict=True))
        if self.kind == "plate":
            return g["x_m"] ** 2 + g["width_m"] ** 2 / 12.0 + g["y_m"] ** 2
        if self.kind == "point":
            return g["x_m"] ** 2 + g["y_m"] ** 2
        if self.kind == "line":
            cx, cy = 0.5 * (g["x1_m"] + g["x2_m"]), 0.5 * (g["y1_m"] + g["y2_m"])
            l2 = (g["x2_m"] - g["x1_m"]) ** 2 + (g["y2_m"] - g["y1_m"]) ** 2
            return cx * cx + cy * cy + l2 / 12.0
        # area: half-width h(y) linear between the two levels
        yt, yb = g["y_top_m"], g["y_bottom_m"]
        ht, hb = 0.5 * g["top_width_m"], 0.5 * g["bottom_width_m"]
        t, w = np.polynomial.legendre.leggauss(6)
        y = 0.5 * (yt - yb) * t + 0.5 * (yt + yb)
        h = hb + (ht - hb) * (y - yb) / (yt - yb)
        area = np.sum(w * 2 * h)
        second = np.sum(w * (2 * h ** 3 / 3 + 2 * h * y * y))
        return float(second / area)

    @property
    def inertia_kgm2_per_m(self) -> float:
        """Mass moment of inertia of the item about the deck centre point [kg m^2/m]."""
        return self.mass_kg_per_m * self.radius_sq_m2()


@dataclass(frozen=True)
class DeckSection:
    """The lumped deck section: items and their sums."""

    items: tuple

    @property
    def mass_kg_per_m(self) -> float:
        """Total deck mass per unit length [kg/m]."""
        return float(sum(i.mass_kg_per_m for i in self.items))

    @property
    def inertia_kgm2_per_m(self) -> float:
        """Total mass moment of inertia about the centre point [kg m^2/m]."""
        return float(sum(i.inertia_kgm2_per_m for i in self.items))

    def table(self) -> list[dict]:
        """One row per item: name, kind, mass, radius of gyration, inertia, source."""
        return [{"name": i.name, "kind": i.kind, "mass_kg_per_m": i.mass_kg_per_m,
                 "radius_of_gyration_m": float(np.sqrt(i.radius_sq_m2())),
                 "inertia_kgm2_per_m": i.inertia_kgm2_per_m, "source": i.source}
                for i in self.items]


def _number(raw, field: str) -> float:
    if isinstance(raw, bool) or not isinstance(raw, int | float) or not np.isfinite(raw):
        raise BridgeflapInputError(field, f"must be a finite number, got {raw!r}")
    return float(raw)


def section_from_list(raw_items) -> DeckSection:
    """Parse a bridge file's ``[[deck_section]]`` array (module docstring for the keys)."""
    if not isinstance(raw_items, list) or not raw_items:
        raise BridgeflapInputError("deck_section", "must be a non-empty array of tables")
    items, names = [], set()
    for k, raw in enumerate(raw_items):
        if not isinstance(raw, dict):
            raise BridgeflapInputError(f"deck_section[{k}]", "must be a table")
        name = raw.get("name")
        if not isinstance(name, str) or not name:
            raise BridgeflapInputError(f"deck_section[{k}].name", "missing or not a string")
        if name in names:
            raise BridgeflapInputError(f"deck_section.{name}", "duplicate item name")
        names.add(name)
        field = f"deck_section.{name}"
        kind = raw.get("kind")
        if kind not in KINDS:
            raise BridgeflapInputError(f"{field}.kind", f"must be one of {KINDS}, got {kind!r}")
        allowed = {"name", "kind", "mass_kg_per_m", "source", *_GEOMETRY[kind]}
        unknown = sorted(set(raw) - allowed)
        if unknown:
            raise BridgeflapInputError(f"{field}.{unknown[0]}", f"unknown key for kind {kind!r}")
        if "mass_kg_per_m" not in raw:
            raise BridgeflapInputError(f"{field}.mass_kg_per_m", "missing")
        mass = _number(raw["mass_kg_per_m"], f"{field}.mass_kg_per_m")
        if mass < 0:
            raise BridgeflapInputError(f"{field}.mass_kg_per_m", "must not be negative")
        geometry = []
        for key in _GEOMETRY[kind]:
            if key not in raw and key not in _OPTIONAL_ZERO:
                raise BridgeflapInputError(f"{field}.{key}", "missing")
            geometry.append(_number(raw.get(key, 0.0), f"{field}.{key}"))
        g = dict(zip(_GEOMETRY[kind], geometry, strict=True))
        if kind == "plate" and g["width_m"] < 0:
            raise BridgeflapInputError(f"{field}.width_m", "must not be negative")
        if kind == "area":
            if g["y_top_m"] <= g["y_bottom_m"]:
                raise BridgeflapInputError(f"{field}.y_top_m", "must be above y_bottom_m")
            if min(g["top_width_m"], g["bottom_width_m"]) < 0:
                raise BridgeflapInputError(f"{field}.top_width_m", "widths must not be negative")
        source = raw.get("source", "not stated")
        if not isinstance(source, str):
            raise BridgeflapInputError(f"{field}.source", "must be a string")
        items.append(SectionItem(name, kind, mass, tuple(geometry), source))
    return DeckSection(tuple(items))
