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
from model.structure.limits import (
    MAX_ELEMENTS,
    MIN_SAG_RATIO,
    PLAUSIBLE_RANGES,
    check_section_geometry,
    to_float,
)
from model.structure.limits import check_finite as _finite
from model.structure.limits import check_in_range as _in_range
from model.structure.limits import check_nonnegative as _nonnegative
from model.structure.limits import check_positive as _positive
from model.structure.section_props import DeckSection, section_from_list

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

#: built-in bridge name -> definition file under model/bridges/
BUILTIN_FILES = {"humber": "humber.toml", "great-belt": "great_belt.toml",
                 "iabse-2a": "iabse/step2a_bridge.toml"}
BUILTIN_BRIDGES = tuple(BUILTIN_FILES)


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
    cable_area_m2 : float, optional
        Steel area of each cable in this span [m^2] when it differs from ``cable.area_m2``
        (extra wires in a side span); the cable mass per metre scales with it.
    """

    name: str
    length_m: float
    chord_rise_m: float = 0.0
    suspended_deck: bool = True
    cable_area_m2: float | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise BridgeflapInputError("spans.name", f"must be a string, got {self.name!r}")
        _in_range(f"spans.{self.name}.length_m", self.length_m, "length_m")
        _finite(f"spans.{self.name}.chord_rise_m", self.chord_rise_m)
        if not isinstance(self.suspended_deck, bool):
            raise BridgeflapInputError(f"spans.{self.name}.suspended_deck",
                                       f"must be true or false, got {self.suspended_deck!r}")
        if self.cable_area_m2 is not None:
            _in_range(f"spans.{self.name}.cable_area_m2", self.cable_area_m2, "cable_area_m2")
        if abs(self.chord_rise_m) >= self.length_m:
            raise BridgeflapInputError(
                f"spans.{self.name}.chord_rise_m", "chord steeper than 45 degrees is not supported"
            )


@dataclass(frozen=True)
class Cable:
    """Main cables (two, at +-spacing/2 from the deck centre line); per-cable values.

    ``mass_kg_per_m`` is per metre **of cable** (not per horizontal metre) for a cable of steel
    area ``area_m2``; in a span with its own ``cable_area_m2`` it scales with the area. The
    statics and the mass matrices apply it along the cable (``m_c ds/dx``,
    :mod:`model.structure.cable`).
    """

    area_m2: float
    modulus_pa: float
    mass_kg_per_m: float
    spacing_m: float
    main_sag_m: float

    def __post_init__(self):
        for name in ("area_m2", "modulus_pa", "mass_kg_per_m", "spacing_m", "main_sag_m"):
            _in_range(f"cable.{name}", getattr(self, name))


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
        for name in _DECK_KEYS:
            _in_range(f"deck.{name}", getattr(self, name))


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
        for f in dataclasses.fields(self):
            if f"aero.{f.name}" in PLAUSIBLE_RANGES:
                _in_range(f"aero.{f.name}", getattr(self, f.name))
        if not isinstance(self.added_inertia, bool):
            raise BridgeflapInputError("aero.added_inertia",
                                       f"must be true or false, got {self.added_inertia!r}")


@dataclass(frozen=True)
class Mesh:
    """Finite-element mesh: target element length [m]."""

    element_length_m: float = 25.0

    def __post_init__(self):
        _positive("mesh.element_length_m", self.element_length_m)


SIDE_SPAN_SEQUENCES = ("bare", "in_place", "with_main")


@dataclass(frozen=True)
class BridgeSpec:
    """A complete bridge definition, or one of its erection stages.

    ``erected_fraction`` is the fraction of the main span whose deck is in place, erected
    symmetrically from mid-span outwards (seed §4). ``joints_closed`` is False for every
    erection stage, including the closed deck at ``erected_fraction = 1`` before its joints are
    made permanent: the deck then has half its GJ and zero EI (temporary joints, seed §2 after
    Brancaleoni 1992). The completed bridge (:meth:`completed`) has ``erected_fraction = 1`` and
    ``joints_closed = True``. ``side_span_decks`` says where the side-span decks are while
    erecting: ``"bare"`` (not yet hung), ``"in_place"`` (hung throughout) or ``"with_main"``
    (erected over the same fraction as the main span, from the towers outwards).
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
    joints_closed: bool = True
    side_span_decks: str = "in_place"
    sources: dict = field(default_factory=dict, compare=False, hash=False)
    deck_section: DeckSection | None = field(default=None, compare=False, hash=False)
    #: flutter-derivative self-excited loads and static coefficients (model.structure.modal_import)
    derivatives: Any = None
    static_coefficients: Any = None

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
        if self.joints_closed and self.erected_fraction < 1.0:
            raise BridgeflapInputError("erected_fraction",
                                       "joints can be closed only on the complete deck (1)")
        if self.side_span_decks not in SIDE_SPAN_SEQUENCES:
            raise BridgeflapInputError("erection.side_spans",
                                       f"must be one of {SIDE_SPAN_SEQUENCES}, "
                                       f"got {self.side_span_decks!r}")
        names = [s.name for s in self.spans]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise BridgeflapInputError(f"spans.{dup[0]}", "duplicate span name")
        main = self.main_span
        if self.cable.main_sag_m >= 0.5 * main.length_m:
            raise BridgeflapInputError("cable.main_sag_m", "sag must be below half the span")
        if self.cable.main_sag_m < MIN_SAG_RATIO * main.length_m:
            raise BridgeflapInputError("cable.main_sag_m",
                                       f"below {MIN_SAG_RATIO:g} of the main span, got "
                                       f"{self.cable.main_sag_m}")
        self._check_mesh()

    def _check_mesh(self) -> None:
        """At least two elements per span (the torsion of a span needs an interior node), and
        at most :data:`MAX_ELEMENTS` in all."""
        le = self.mesh.element_length_m
        shortest = min(self.spans, key=lambda s: s.length_m)
        if le > 0.5 * shortest.length_m:
            raise BridgeflapInputError(
                "mesh.element_length_m", f"{le:g} m is longer than half the shortest span "
                f"({shortest.name}, {shortest.length_m:g} m): every span needs two elements")
        n = sum(math.ceil(s.length_m / le - 1e-9) for s in self.spans)
        if n > MAX_ELEMENTS:
            raise BridgeflapInputError(
                "mesh.element_length_m", f"{le:g} m gives {n} elements, more than the limit of "
                f"{MAX_ELEMENTS}")

    @property
    def main_span(self) -> Span:
        """The main span."""
        return self.spans[self.main_span_index]

    def erected(self, fraction: float, side_spans: str | None = None) -> BridgeSpec:
        """An erection stage: the main-span deck over ``fraction`` (0, 1], joints temporary.

        ``fraction = 1`` is the closed deck with temporary joints (half GJ, zero EI), not the
        completed bridge (:meth:`completed`). ``side_spans`` overrides the bridge file's
        side-span sequence (:data:`SIDE_SPAN_SEQUENCES`).
        """
        check_fraction(fraction)
        return dataclasses.replace(
            self, erected_fraction=float(fraction), joints_closed=False,
            side_span_decks=self.side_span_decks if side_spans is None else side_spans)

    def completed(self) -> BridgeSpec:
        """The completed bridge: every deck in place, joints closed (full GJ and EI)."""
        return dataclasses.replace(self, erected_fraction=1.0, joints_closed=True)

    def side_span_deck_fraction(self, span: int) -> float:
        """Fraction of side span ``span``'s deck in place at this stage [-]."""
        if self.joints_closed or self.side_span_decks == "in_place":
            return 1.0
        return 0.0 if self.side_span_decks == "bare" else self.erected_fraction

    def replace(self, **changes: Any) -> BridgeSpec:
        """Return a copy with dotted-path changes, e.g. ``replace(**{"deck.gj_nm2": 1e11})``."""
        spec = self
        for path, value in changes.items():
            spec = _replace_path(spec, path, value)
        return spec

    def span_cable_area_m2(self, span: int) -> float:
        """Steel area of one cable in ``span`` [m^2]."""
        a = self.spans[span].cable_area_m2
        return self.cable.area_m2 if a is None else a

    def span_cable_mass_kg_per_m(self, span: int) -> float:
        """Mass of one cable per metre of cable in ``span`` [kg/m] (scaled with its area)."""
        return self.cable.mass_kg_per_m * self.span_cable_area_m2(span) / self.cable.area_m2

    @property
    def is_erecting(self) -> bool:
        """True for every erection stage (temporary joints), False for the completed bridge."""
        return not self.joints_closed

    def to_toml(self) -> str:
        """This bridge as bridge-file text, sources kept
        (:func:`model.structure.spec_writer.to_toml`)."""
        from model.structure.spec_writer import to_toml

        return to_toml(self)


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
    "deck.mass_kg_per_m", "deck.mass_inertia_kgm2_per_m", "deck.ei_vertical_nm2",
    "deck.ei_lateral_nm2", "deck.gj_nm2", "deck.half_chord_m", "deck.hanger_length_midspan_m",
    "cable.area_m2", "cable.modulus_pa", "cable.mass_kg_per_m", "cable.spacing_m",
    "cable.main_sag_m", "damping.ratio", "aero.air_density_kg_m3", "aero.deck_height_m",
    "aero.turbulence_intensity", "aero.coherence_decay", "aero.lift_slope_buffeting",
    "aero.moment_slope_buffeting", "mesh.element_length_m",
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


def load_bridge(name_or_path: str | Path | BridgeSpec) -> BridgeSpec:
    """Load a built-in bridge by name or a TOML bridge file by path; a :class:`BridgeSpec` is
    returned as it is (so every function that takes a bridge takes a name, a file or a spec).

    ``"name:variant"`` (or ``"file.toml:variant"``) applies the file's ``[variants.variant]``
    table: dotted parameter paths with ``{ value, source }``, an alternative reading of the
    sources kept next to the default one (e.g. ``humber:box``, the 22 m steel box as chord).

    Raises
    ------
    BridgeflapInputError
        Unknown name or variant, missing file, malformed TOML, missing, unknown or
        non-physical field.
    """
    if isinstance(name_or_path, BridgeSpec):
        return name_or_path
    if not isinstance(name_or_path, str | Path) or not str(name_or_path):
        raise BridgeflapInputError("bridge", "must be a built-in name, a bridge .toml path or "
                                             f"a BridgeSpec, got {name_or_path!r:.60}")
    base, variant = _split_variant(str(name_or_path))
    text, origin = _read_source(base)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise BridgeflapInputError("bridge", f"malformed TOML in {origin}: {exc}") from None
    spec = spec_from_dict(data, origin, variant=variant)
    loads = spec.derivatives
    if loads is not None and hasattr(loads, "table"):
        # the derivative table is read (and checked: finite, increasing) at load, so that a
        # study or DOE on a bridge with a bad table is refused before it writes (issue 30)
        loads.table(2.0 * spec.deck.half_chord_m)
    return spec


def _split_variant(s: str) -> tuple[str, str | None]:
    head, sep, tail = s.rpartition(":")
    if sep and tail and (head in BUILTIN_BRIDGES or head.lower().endswith(".toml")):
        return head, tail
    return s, None


def _read_source(name_or_path: str | Path) -> tuple[str, str]:
    s = str(name_or_path)
    if s in BUILTIN_BRIDGES:
        return resources.files("model.bridges").joinpath(BUILTIN_FILES[s]).read_text("utf-8"), s
    path = Path(s)
    if path.suffix.lower() != ".toml":
        raise BridgeflapInputError(
            "bridge", f"unknown bridge {s!r} (built-in: {', '.join(BUILTIN_BRIDGES)}; "
            "or a path to a .toml file)")
    try:  # an OSError of is_file too: a name beyond the file system's NAME_MAX
        if not path.is_file():
            raise BridgeflapInputError("bridge", f"file not found: {path}")
        return path.read_text("utf-8"), str(path)
    except (OSError, UnicodeDecodeError) as exc:
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
        raise BridgeflapInputError("bridge", f"cannot read {path}: {why}") from None


_SPAN_KEYS = {"name", "length_m", "chord_rise_m", "suspended_deck", "cable_area_m2"}
_CABLE_KEYS = ("area_m2", "modulus_pa", "mass_kg_per_m", "spacing_m", "main_sag_m")
_DECK_KEYS = ("mass_kg_per_m", "mass_inertia_kgm2_per_m", "ei_vertical_nm2", "ei_lateral_nm2",
              "gj_nm2", "half_chord_m", "hanger_length_midspan_m")
_SECTION_KEYS = ("mass_kg_per_m", "mass_inertia_kgm2_per_m")
_TOP_KEYS = {"name", "description", "spans", "main_span", "cable", "deck", "deck_section",
             "damping", "aero", "mesh", "variants", "erection", "derivatives",
             "static_coefficients"}
_TABLE_PATHS = ("derivatives", "static_coefficients")  # whole tables, in variants too


def _check_keys(table: dict, allowed, where: str) -> None:
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise BridgeflapInputError(f"{where}.{unknown[0]}", "unknown key")


def spec_from_dict(data: dict, origin: str = "<dict>", variant: str | None = None) -> BridgeSpec:
    """Build a :class:`BridgeSpec` from parsed TOML, recording each value's source.

    Unknown sections and keys, non-boolean switches and duplicate span names are rejected with
    the field named. A ``[[deck_section]]`` array (:mod:`model.structure.section_props`) gives the
    deck mass and mass moment of inertia as sums of lumped items; ``[deck]`` then must not repeat
    them. ``variant`` applies ``[variants.<variant>]`` (see :func:`load_bridge`).
    """
    if isinstance(data, dict) and "structure" in data:  # imported modal model
        from model.structure.modal_import import modal_spec_from_dict

        return modal_spec_from_dict(data, origin, variant)
    sources: dict[str, str] = {}

    def value(table: dict, group: str, key: str, default: Any = _MISSING) -> Any:
        path = f"{group}.{key}"
        if key not in table:
            if default is _MISSING:
                raise BridgeflapInputError(path, "missing")
            return default
        raw = table[key]
        if isinstance(raw, dict):
            _check_keys(raw, ("value", "source"), path)
            if "value" not in raw:
                raise BridgeflapInputError(path, "table given without 'value'")
            sources[path] = str(raw.get("source", "not stated"))
            raw = raw["value"]
        else:
            sources[path] = "not stated"
        return to_float(path, raw)

    def switch(table: dict, path: str, default: bool) -> bool:
        raw = table.get(path.rsplit(".", 1)[1], default)
        if not isinstance(raw, bool):
            raise BridgeflapInputError(path, f"must be true or false, got {raw!r}")
        return raw

    def group(name: str, required: bool = True) -> dict:
        g = data.get(name)
        if g is None:
            if required:
                raise BridgeflapInputError(name, "missing section")
            return {}
        if not isinstance(g, dict):
            raise BridgeflapInputError(name, "must be a table")
        return g

    if not isinstance(data, dict):
        raise BridgeflapInputError("bridge", "must be a table")
    unknown = sorted(set(data) - _TOP_KEYS)
    if unknown:
        raise BridgeflapInputError(unknown[0], "unknown section")
    name = data.get("name")
    if not isinstance(name, str) or not name:
        raise BridgeflapInputError("name", "missing or not a string")
    if not isinstance(data.get("description", ""), str):
        raise BridgeflapInputError("description", "must be a string")
    raw_spans = data.get("spans")
    if not isinstance(raw_spans, list) or not raw_spans:
        raise BridgeflapInputError("spans", "missing: give an array of [[spans]] tables")
    spans = []
    for i, s in enumerate(raw_spans):
        if not isinstance(s, dict) or not isinstance(s.get("name"), str):
            raise BridgeflapInputError(f"spans[{i}].name", "missing or not a string")
        sname = s["name"]
        where = f"spans.{sname}"
        _check_keys(s, _SPAN_KEYS, where)
        area = value(s, where, "cable_area_m2", None) if "cable_area_m2" in s else None
        spans.append(Span(
            name=sname,
            length_m=value(s, where, "length_m"),
            chord_rise_m=value(s, where, "chord_rise_m", 0.0),
            suspended_deck=switch(s, f"{where}.suspended_deck", True),
            cable_area_m2=area,
        ))
    main_name = data.get("main_span")
    names = [s.name for s in spans]
    if main_name not in names:
        raise BridgeflapInputError("main_span", f"must name one of the spans {names}")
    c, d = group("cable"), group("deck")
    _check_keys(c, _CABLE_KEYS, "cable")
    _check_keys(d, _DECK_KEYS, "deck")
    cable = Cable(**{k: value(c, "cable", k) for k in _CABLE_KEYS})
    section = None
    deck_values = {k: value(d, "deck", k) for k in _DECK_KEYS
                   if k not in _SECTION_KEYS or "deck_section" not in data}
    if "deck_section" in data:
        for k in _SECTION_KEYS:
            if k in d:
                raise BridgeflapInputError(f"deck.{k}", "given by [[deck_section]]: remove it")
        check_section_geometry(data["deck_section"])
        section = section_from_list(data["deck_section"])
        deck_values["mass_kg_per_m"] = section.mass_kg_per_m
        deck_values["mass_inertia_kgm2_per_m"] = section.inertia_kgm2_per_m
        items = ", ".join(i.name for i in section.items)
        for k in _SECTION_KEYS:
            sources[f"deck.{k}"] = f"sum over the [[deck_section]] items ({items})"
    deck = Deck(**deck_values)
    dg = group("damping", required=False)
    _check_keys(dg, ("ratio",), "damping")
    damping = Damping(ratio=value(dg, "damping", "ratio", 0.01))
    ag = group("aero", required=False)
    _check_keys(ag, [f.name for f in dataclasses.fields(Aero)], "aero")
    defaults = Aero()
    aero_kwargs = {}
    for f in dataclasses.fields(Aero):
        if f.name == "added_inertia":
            aero_kwargs[f.name] = switch(ag, "aero.added_inertia", True)
        else:
            aero_kwargs[f.name] = value(ag, "aero", f.name, getattr(defaults, f.name))
    aero = Aero(**aero_kwargs)
    mg = group("mesh", required=False)
    _check_keys(mg, ("element_length_m",), "mesh")
    mesh = Mesh(element_length_m=value(mg, "mesh", "element_length_m", 25.0))
    eg = group("erection", required=False)
    _check_keys(eg, ("side_spans",), "erection")
    side = eg.get("side_spans", "in_place")
    if isinstance(side, dict):
        _check_keys(side, ("value", "source"), "erection.side_spans")
        sources["erection.side_spans"] = str(side.get("source", "not stated"))
        side = side.get("value")
    if not isinstance(side, str):
        raise BridgeflapInputError("erection.side_spans", f"must be a string, got {side!r}")
    spec = BridgeSpec(name=name, spans=tuple(spans), main_span_index=names.index(main_name),
                      cable=cable, deck=deck, damping=damping, aero=aero, mesh=mesh,
                      side_span_decks=side, sources=sources, deck_section=section)
    from model.structure.modal_import import aero_sections  # lazy: modal_import imports this module

    spec = dataclasses.replace(spec, **aero_sections(data, origin))
    return _apply_variant(spec, group("variants", required=False), variant, origin)


def _apply_variant(spec: BridgeSpec, variants: dict, variant: str | None,
                   origin: str = "<dict>") -> BridgeSpec:
    """Apply ``[variants.<variant>]``: dotted parameter paths with ``{ value, source }``."""
    for vname, table in variants.items():
        if not isinstance(table, dict):
            raise BridgeflapInputError(f"variants.{vname}", "must be a table")
        for path in table:
            if path not in ("description", *_TABLE_PATHS) and path not in PARAMETER_PATHS:
                raise BridgeflapInputError(f"variants.{vname}.{path}", "unknown parameter")
    if variant is None:
        return spec
    if variant not in variants:
        raise BridgeflapInputError(
            "bridge", f"unknown variant {variant!r} of {spec.name!r} "
            f"(variants: {', '.join(variants) or 'none'})")
    sources = dict(spec.sources)
    changes = {}
    for path, raw in variants[variant].items():
        if path in _TABLE_PATHS:
            from model.structure.modal_import import aero_sections

            spec = dataclasses.replace(spec, **aero_sections({path: raw}, origin,
                                                              f"variants.{variant}."))
        if path == "description" or path in _TABLE_PATHS:
            continue
        if isinstance(raw, dict):
            _check_keys(raw, ("value", "source"), f"variants.{variant}.{path}")
            sources[path] = f"variant {variant}: {raw.get('source', 'not stated')}"
            raw = raw.get("value")
        changes[path] = to_float(f"variants.{variant}.{path}", raw)
    out = spec.replace(**changes)
    return dataclasses.replace(out, name=f"{spec.name}:{variant}", sources=sources)


_MISSING = object()  # a value() without default
