"""Bridge definition: frozen, validated dataclasses and the TOML loader.

A bridge file is TOML. Every physical value is either a bare number or a table
``{ value = ..., source = "..." }``; built-in bridges give a source for every value (data-sheet
tag, or ``ESTIMATE: reasoning``). Conventions: see :mod:`model`.

Example
-------
>>> spec = load_bridge("humber")            # doctest: +SKIP
>>> spec.erected(0.6).deck.half_chord_m      # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
import math
import sys
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from model.errors import BridgeflapInputError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

BUILTIN_BRIDGES = ("humber",)


@dataclass(frozen=True)
class Span:
    """One cable span between supports (north to south).

    Parameters
    ----------
    name : str
        Label, e.g. ``"hessle"``, ``"main"``, ``"barton"``.
    length_m : float
        Horizontal span [m].
    chord_rise_m : float
        Rise of the cable chord across the span, from its lower to its upper support [m]
        (0 for the level main span; side spans rise from the anchorage to the saddle).
    suspended_deck : bool
        Whether a deck hangs from this span when the bridge is complete.
    """

    name: str
    length_m: float
    chord_rise_m: float = 0.0
    suspended_deck: bool = True

    def __post_init__(self):
        _positive(f"spans.{self.name}.length_m", self.length_m)
        _finite(f"spans.{self.name}.chord_rise_m", self.chord_rise_m)
        if abs(self.chord_rise_m) >= self.length_m:
            raise BridgeflapInputError(
                f"spans.{self.name}.chord_rise_m", "chord steeper than 45 degrees is not supported"
            )


@dataclass(frozen=True)
class Cable:
    """Main cables (two, at +-spacing/2 from the deck centre line); per-cable values."""

    area_m2: float
    modulus_pa: float
    mass_kg_per_m: float
    spacing_m: float
    main_sag_m: float

    def __post_init__(self):
        for name in ("area_m2", "modulus_pa", "mass_kg_per_m", "spacing_m", "main_sag_m"):
            _positive(f"cable.{name}", getattr(self, name))


@dataclass(frozen=True)
class Deck:
    """Deck girder per unit length (complete bridge values)."""

    mass_kg_per_m: float
    mass_inertia_kgm2_per_m: float
    ei_vertical_nm2: float
    ei_lateral_nm2: float
    gj_nm2: float
    half_chord_m: float
    hanger_length_midspan_m: float

    def __post_init__(self):
        for name in ("mass_kg_per_m", "mass_inertia_kgm2_per_m", "half_chord_m",
                     "hanger_length_midspan_m"):
            _positive(f"deck.{name}", getattr(self, name))
        for name in ("ei_vertical_nm2", "ei_lateral_nm2", "gj_nm2"):
            _nonnegative(f"deck.{name}", getattr(self, name))


@dataclass(frozen=True)
class Damping:
    """Rayleigh damping: ``ratio`` in the first vertical and first torsional modes."""

    ratio: float = 0.01

    def __post_init__(self):
        _nonnegative("damping.ratio", self.ratio)
        if self.ratio >= 1.0:
            raise BridgeflapInputError("damping.ratio", "must be below 1 (critical damping)")


@dataclass(frozen=True)
class Aero:
    """Aerodynamic and wind-field inputs."""

    air_density_kg_m3: float = 1.225
    deck_height_m: float = 30.0
    turbulence_intensity: float = 0.07
    coherence_decay: float = 8.0
    lift_slope_buffeting: float = 2.5
    moment_slope_buffeting: float = math.pi / 2
    added_inertia: bool = True

    def __post_init__(self):
        for name in ("air_density_kg_m3", "deck_height_m", "turbulence_intensity",
                     "coherence_decay"):
            _positive(f"aero.{name}", getattr(self, name))
        _finite("aero.lift_slope_buffeting", self.lift_slope_buffeting)
        _finite("aero.moment_slope_buffeting", self.moment_slope_buffeting)


@dataclass(frozen=True)
class Mesh:
    """Finite-element mesh: target element length [m]."""

    element_length_m: float = 25.0

    def __post_init__(self):
        _positive("mesh.element_length_m", self.element_length_m)


@dataclass(frozen=True)
class BridgeSpec:
    """A complete bridge definition.

    ``erected_fraction`` is the fraction of the main span whose deck is in place, erected
    symmetrically from mid-span outwards (1 = complete bridge). While erecting (fraction < 1)
    the deck has half its GJ and zero EI (temporary joints, seed paper §2 after Brancaleoni);
    side-span decks are taken as in place throughout (see README, "Erection").
    """

    name: str
    spans: tuple[Span, ...]
    main_span_index: int
    cable: Cable
    deck: Deck
    damping: Damping = field(default_factory=Damping)
    aero: Aero = field(default_factory=Aero)
    mesh: Mesh = field(default_factory=Mesh)
    erected_fraction: float = 1.0
    sources: dict = field(default_factory=dict, compare=False, hash=False)

    def __post_init__(self):
        if not self.spans:
            raise BridgeflapInputError("spans", "at least one span is required")
        if not 0 <= self.main_span_index < len(self.spans):
            raise BridgeflapInputError("main_span", "does not name one of the spans")
        if not self.spans[self.main_span_index].suspended_deck:
            raise BridgeflapInputError("main_span", "the main span must carry the deck")
        if abs(self.spans[self.main_span_index].chord_rise_m) > 0:
            raise BridgeflapInputError("spans.main.chord_rise_m", "the main span must be level")
        check_fraction(self.erected_fraction)
        main = self.main_span
        if self.cable.main_sag_m >= 0.5 * main.length_m:
            raise BridgeflapInputError("cable.main_sag_m", "sag must be below half the span")

    @property
    def main_span(self) -> Span:
        """The main span."""
        return self.spans[self.main_span_index]

    def erected(self, fraction: float) -> BridgeSpec:
        """Return a copy with the main-span deck erected over ``fraction`` (0, 1]."""
        check_fraction(fraction)
        return dataclasses.replace(self, erected_fraction=float(fraction))

    def replace(self, **changes: Any) -> BridgeSpec:
        """Return a copy with dotted-path changes, e.g. ``replace(**{"deck.gj_nm2": 1e11})``."""
        spec = self
        for path, value in changes.items():
            spec = _replace_path(spec, path, value)
        return spec

    @property
    def is_erecting(self) -> bool:
        """True while the main-span deck is incomplete."""
        return self.erected_fraction < 1.0


def check_fraction(fraction: float) -> float:
    """Validate an erected fraction in (0, 1]."""
    try:
        f = float(fraction)
    except (TypeError, ValueError):
        raise BridgeflapInputError("erected_fraction", f"not a number: {fraction!r}") from None
    if not (math.isfinite(f) and 0.0 < f <= 1.0):
        raise BridgeflapInputError("erected_fraction", f"must be in (0, 1], got {fraction}")
    return f


# Parameters a designer may vary (dotted paths into BridgeSpec), used by sensitivity and DOE.
PARAMETER_PATHS = (
    "deck.mass_kg_per_m",
    "deck.mass_inertia_kgm2_per_m",
    "deck.ei_vertical_nm2",
    "deck.ei_lateral_nm2",
    "deck.gj_nm2",
    "deck.half_chord_m",
    "deck.hanger_length_midspan_m",
    "cable.area_m2",
    "cable.modulus_pa",
    "cable.mass_kg_per_m",
    "cable.spacing_m",
    "cable.main_sag_m",
    "damping.ratio",
    "aero.air_density_kg_m3",
    "aero.deck_height_m",
    "aero.turbulence_intensity",
    "aero.coherence_decay",
    "aero.lift_slope_buffeting",
    "aero.moment_slope_buffeting",
    "mesh.element_length_m",
)


def get_path(spec: BridgeSpec, path: str) -> float:
    """Value of a dotted parameter path such as ``"deck.gj_nm2"``."""
    if path not in PARAMETER_PATHS:
        raise BridgeflapInputError("parameter", f"unknown parameter {path!r}")
    group, name = path.split(".")
    return getattr(getattr(spec, group), name)


def _replace_path(spec: BridgeSpec, path: str, value: Any) -> BridgeSpec:
    if path not in PARAMETER_PATHS:
        raise BridgeflapInputError("parameter", f"unknown parameter {path!r}")
    group, name = path.split(".")
    sub = dataclasses.replace(getattr(spec, group), **{name: float(value)})
    return dataclasses.replace(spec, **{group: sub})


# ----------------------------------------------------------------------------- loading


def load_bridge(name_or_path: str | Path) -> BridgeSpec:
    """Load a built-in bridge by name or a TOML bridge file by path.

    Raises
    ------
    BridgeflapInputError
        Unknown name, missing file, malformed TOML, missing or non-physical field.
    """
    text, origin = _read_source(name_or_path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise BridgeflapInputError("bridge", f"malformed TOML in {origin}: {exc}") from None
    return spec_from_dict(data, origin)


def _read_source(name_or_path: str | Path) -> tuple[str, str]:
    s = str(name_or_path)
    if s in BUILTIN_BRIDGES:
        return resources.files("model.bridges").joinpath(f"{s}.toml").read_text("utf-8"), s
    path = Path(s)
    if path.suffix.lower() != ".toml":
        raise BridgeflapInputError(
            "bridge", f"unknown bridge {s!r} (built-in: {', '.join(BUILTIN_BRIDGES)}; "
            "or a path to a .toml file)")
    if not path.is_file():
        raise BridgeflapInputError("bridge", f"file not found: {path}")
    try:
        return path.read_text("utf-8"), str(path)
    except (OSError, UnicodeDecodeError) as exc:
        raise BridgeflapInputError("bridge", f"cannot read {path}: {exc}") from None


def spec_from_dict(data: dict, origin: str = "<dict>") -> BridgeSpec:
    """Build a :class:`BridgeSpec` from parsed TOML, recording each value's source."""
    sources: dict[str, str] = {}

    def value(table: dict, group: str, key: str, default: Any = _MISSING) -> Any:
        path = f"{group}.{key}"
        if key not in table:
            if default is _MISSING:
                raise BridgeflapInputError(path, "missing")
            return default
        raw = table[key]
        if isinstance(raw, dict):
            if "value" not in raw:
                raise BridgeflapInputError(path, "table given without 'value'")
            sources[path] = str(raw.get("source", "not stated"))
            raw = raw["value"]
        else:
            sources[path] = "not stated"
        if isinstance(raw, bool) or not isinstance(raw, int | float):
            if default is not _MISSING and isinstance(default, bool) and isinstance(raw, bool):
                return raw
            raise BridgeflapInputError(path, f"must be a number, got {raw!r}")
        return float(raw)

    def group(name: str, required: bool = True) -> dict:
        g = data.get(name)
        if g is None:
            if required:
                raise BridgeflapInputError(name, "missing section")
            return {}
        if not isinstance(g, dict):
            raise BridgeflapInputError(name, "must be a table")
        return g

    name = data.get("name")
    if not isinstance(name, str) or not name:
        raise BridgeflapInputError("name", "missing or not a string")
    raw_spans = data.get("spans")
    if not isinstance(raw_spans, list) or not raw_spans:
        raise BridgeflapInputError("spans", "missing: give an array of [[spans]] tables")
    spans = []
    for i, s in enumerate(raw_spans):
        if not isinstance(s, dict) or not isinstance(s.get("name"), str):
            raise BridgeflapInputError(f"spans[{i}].name", "missing or not a string")
        sname = s["name"]
        spans.append(Span(
            name=sname,
            length_m=value(s, f"spans.{sname}", "length_m"),
            chord_rise_m=value(s, f"spans.{sname}", "chord_rise_m", 0.0),
            suspended_deck=bool(s.get("suspended_deck", True)),
        ))
    main_name = data.get("main_span")
    names = [s.name for s in spans]
    if main_name not in names:
        raise BridgeflapInputError("main_span", f"must name one of the spans {names}")
    c, d = group("cable"), group("deck")
    cable = Cable(**{k: value(c, "cable", k) for k in
                     ("area_m2", "modulus_pa", "mass_kg_per_m", "spacing_m", "main_sag_m")})
    deck = Deck(**{k: value(d, "deck", k) for k in
                   ("mass_kg_per_m", "mass_inertia_kgm2_per_m", "ei_vertical_nm2",
                    "ei_lateral_nm2", "gj_nm2", "half_chord_m", "hanger_length_midspan_m")})
    dg = group("damping", required=False)
    damping = Damping(ratio=value(dg, "damping", "ratio", 0.01))
    ag = group("aero", required=False)
    defaults = Aero()
    aero_kwargs = {}
    for f in dataclasses.fields(Aero):
        if f.name == "added_inertia":
            aero_kwargs[f.name] = bool(ag.get("added_inertia", True))
        else:
            aero_kwargs[f.name] = value(ag, "aero", f.name, getattr(defaults, f.name))
    aero = Aero(**aero_kwargs)
    mg = group("mesh", required=False)
    mesh = Mesh(element_length_m=value(mg, "mesh", "element_length_m", 25.0))
    unknown = set(data) - {"name", "description", "spans", "main_span", "cable", "deck",
                           "damping", "aero", "mesh"}
    if unknown:
        raise BridgeflapInputError(sorted(unknown)[0], "unknown section")
    return BridgeSpec(name=name, spans=tuple(spans), main_span_index=names.index(main_name),
                      cable=cable, deck=deck, damping=damping, aero=aero, mesh=mesh,
                      sources=sources)


class _Missing:
    pass


_MISSING = _Missing()


def _finite(field_name: str, v: float) -> None:
    if not isinstance(v, int | float) or not math.isfinite(v):
        raise BridgeflapInputError(field_name, f"must be a finite number, got {v!r}")


def _positive(field_name: str, v: float) -> None:
    _finite(field_name, v)
    if v <= 0:
        raise BridgeflapInputError(field_name, f"must be positive, got {v}")


def _nonnegative(field_name: str, v: float) -> None:
    _finite(field_name, v)
    if v < 0:
        raise BridgeflapInputError(field_name, f"must not be negative, got {v}")
