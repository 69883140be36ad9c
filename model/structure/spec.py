"""Bridge definition: frozen, validated dataclasses (spans, cable, deck, damping, aero, mesh).

:class:`BridgeSpec` is a whole bridge or one of its erection stages; :data:`PARAMETER_PATHS`
are the dotted paths a study may vary (:meth:`BridgeSpec.replace`, :func:`get_path`). Reading a
bridge file (TOML, every value with its source) is :mod:`bridgeflap.model.structure.loader`; writing
one is :mod:`bridgeflap.model.structure.spec_writer`. Conventions: see :mod:`bridgeflap.model`.

Example
-------
>>> from bridgeflap.model.structure.loader import load_bridge      # doctest: +SKIP
>>> spec = load_bridge("humber")            # doctest: +SKIP
>>> spec.erected(0.6).deck.half_chord_m      # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.structure.limits import (
    MAX_ELEMENTS,
    MIN_SAG_RATIO,
    PLAUSIBLE_RANGES,
)
from bridgeflap.model.structure.limits import check_finite as _finite
from bridgeflap.model.structure.limits import check_in_range as _in_range
from bridgeflap.model.structure.limits import check_nonnegative as _nonnegative
from bridgeflap.model.structure.limits import check_positive as _positive
from bridgeflap.model.structure.section_props import DeckSection


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
    :mod:`bridgeflap.model.structure.cable`).
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
    symmetrically from mid-span outwards (the paper, §4). ``joints_closed`` is False for every
    erection stage, including the closed deck at ``erected_fraction = 1`` before its joints are
    made permanent: the deck then has half its GJ and zero EI (temporary joints, the paper, §2 after
    Brancaleoni 1992). The completed bridge (:meth:`completed`) has ``erected_fraction = 1`` and
    ``joints_closed = True``. ``side_span_decks`` says where the side-span decks are while
    erecting: ``"bare"`` (not yet hung), ``"in_place"`` (hung throughout) or ``"with_main"``
    (erected over the same fraction as the main span, from the towers outwards).

    Parameters
    ----------
    name : str
        The bridge's name.
    spans : tuple of Span
        The spans in order along the bridge (lengths [m], chord rises [m], which carry the deck).
    main_span_index : int
        Index of the main span in ``spans``.
    cable : Cable
        Main cables: area [m^2], modulus [Pa], mass [kg/m], spacing [m], main-span sag [m].
    deck : Deck
        Deck: mass [kg/m], torsional mass moment of inertia [kg m^2/m], bending and torsional
        stiffness [N m^2], half-chord ``b`` [m], hanger length at mid-span [m].
    damping : Damping, optional
        Rayleigh damping ratio [-] (default 1 %).
    aero : Aero, optional
        Air density [kg/m^3], deck height [m], turbulence and buffeting inputs.
    mesh : Mesh, optional
        Finite-element length [m].
    erected_fraction : float, default 1.0
        Fraction [-] of the main-span deck in place.
    joints_closed : bool, default True
        False for every erection stage (temporary joints).
    side_span_decks : {"in_place", "bare", "with_main"}, default "in_place"
        The side-span decks while erecting.
    sources : dict, optional
        Dotted path -> source note of each value (not compared by ``==``).
    deck_section : DeckSection, optional
        The lumped deck items whose sums give the deck mass and inertia.
    derivatives, static_coefficients : optional
        Measured flutter derivatives and static coefficients (tables), when the bridge file
        gives them.

    See Also
    --------
    load_bridge : read one from a name or a file.
    BridgeSpec.replace : change inputs by their dotted paths.

    Examples
    --------
    >>> from bridgeflap import model
    >>> spec = model.load_bridge("humber")
    >>> stage = spec.erected(0.5)
    >>> stage.is_erecting, stage.erected_fraction
    (True, 0.5)
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

        Parameters
        ----------
        fraction : float
            Erected fraction of the main span [-], in (0, 1], placed symmetrically about
            mid-span.
        side_spans : {"bare", "in_place", "with_main"}, optional
            The side-span decks while erecting (default: the bridge file's).

        Returns
        -------
        BridgeSpec
            The stage (this bridge is unchanged).

        Raises
        ------
        BridgeflapInputError
            ``erected_fraction``: ``fraction`` outside (0, 1].
        """
        check_fraction(fraction)
        return dataclasses.replace(
            self, erected_fraction=float(fraction), joints_closed=False,
            side_span_decks=self.side_span_decks if side_spans is None else side_spans)

    def completed(self) -> BridgeSpec:
        """The completed bridge: every deck in place, joints closed (full GJ and EI).

        Returns
        -------
        BridgeSpec
            The completed bridge (this one is unchanged).
        """
        return dataclasses.replace(self, erected_fraction=1.0, joints_closed=True)

    def side_span_deck_fraction(self, span: int) -> float:
        """Fraction of side span ``span``'s deck in place at this stage [-].

        Parameters
        ----------
        span : int
            Index of the span in ``spans`` (main and side spans, in the file's order).

        Returns
        -------
        float
            0 (bare), the main span's erected fraction (with_main) or 1 (in place, or the
            completed bridge).
        """
        if self.joints_closed or self.side_span_decks == "in_place":
            return 1.0
        return 0.0 if self.side_span_decks == "bare" else self.erected_fraction

    def replace(self, **changes: Any) -> BridgeSpec:
        """A copy with numeric inputs changed by their dotted paths.

        Every changed value's source note becomes ``"user-set value (was: <old source>)"``
        (:func:`user_set_source`), so :meth:`to_toml` and
        :func:`~bridgeflap.model.save_bridge` write where each value came from. Derived values
        do not follow: changing ``deck.mass_kg_per_m`` leaves
        ``deck.mass_inertia_kgm2_per_m`` (the torsional mass moment of inertia) as it was;
        change both when the mass you add is spread across the deck. A deck whose mass and
        inertia were the sums of its ``[[deck_section]]`` items no longer writes those items
        once either is changed.

        Parameters
        ----------
        **changes : float
            ``path=value`` pairs, a path from :data:`PARAMETER_PATHS` (units in its name, e.g.
            ``"deck.gj_nm2"`` [N m^2]); pass them as ``**{"deck.gj_nm2": 7e11}``.

        Returns
        -------
        BridgeSpec
            The changed bridge (this one is unchanged), validated as on loading.

        Raises
        ------
        BridgeflapInputError
            ``parameter`` for an unknown path; the path's name for a value out of range.

        Examples
        --------
        >>> from bridgeflap import model
        >>> spec = model.load_bridge("humber")
        >>> heavy = spec.replace(**{"deck.mass_kg_per_m": 11000.0})
        >>> heavy.deck.mass_kg_per_m, heavy.sources["deck.mass_kg_per_m"][:30]
        (11000.0, 'user-set value (was: sum over ')
        >>> heavy.deck.mass_inertia_kgm2_per_m == spec.deck.mass_inertia_kgm2_per_m
        True
        """
        spec = self
        for path, value in changes.items():
            spec = _replace_path(spec, path, value)
        return spec

    def span_cable_area_m2(self, span: int) -> float:
        """Steel area of one cable in ``span`` [m^2].

        Parameters
        ----------
        span : int
            Index of the span in ``spans`` (main and side spans, in the file's order).

        Returns
        -------
        float
            The span's own cable area [m^2] when the file gives one, else the cable's.
        """
        a = self.spans[span].cable_area_m2
        return self.cable.area_m2 if a is None else a

    def span_cable_mass_kg_per_m(self, span: int) -> float:
        """Mass of one cable per metre of cable in ``span`` [kg/m] (scaled with its area).

        Parameters
        ----------
        span : int
            Index of the span in ``spans`` (main and side spans, in the file's order).

        Returns
        -------
        float
            The cable mass [kg/m] times the span's area over the cable's.
        """
        return self.cable.mass_kg_per_m * self.span_cable_area_m2(span) / self.cable.area_m2

    @property
    def is_erecting(self) -> bool:
        """True for every erection stage (temporary joints), False for the completed bridge."""
        return not self.joints_closed

    def to_toml(self) -> str:
        """This bridge as bridge-file text, sources kept
        (:func:`bridgeflap.model.structure.spec_writer.to_toml`; the text is
        :func:`bridgeflap.model.structure.bridge_toml.bridge_toml`).

        Returns
        -------
        str
            TOML text that :func:`~bridgeflap.model.load_bridge` reads back to an equal bridge,
            every value with its source note.
        """
        from bridgeflap.model.structure.bridge_toml import bridge_toml

        return bridge_toml(self)


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


#: How the source of a value changed through :meth:`BridgeSpec.replace` starts.
USER_SET = "user-set value"


def user_set_source(old: str | None) -> str:
    """The source note of a value set through :meth:`BridgeSpec.replace`.

    Parameters
    ----------
    old : str or None
        The value's source note before the change (``None`` or ``"not stated"`` when it had
        none).

    Returns
    -------
    str
        ``"user-set value (was: <old>)"``; a value set twice keeps its first note, and a value
        that had no source is ``"user-set value"``.

    Examples
    --------
    >>> user_set_source("[SEED] sigma_w/U = 0.07")
    'user-set value (was: [SEED] sigma_w/U = 0.07)'
    >>> user_set_source(user_set_source("ESTIMATE"))
    'user-set value (was: ESTIMATE)'
    """
    if old is None or old == "not stated":
        return USER_SET
    if old.startswith(USER_SET):
        return old
    return f"{USER_SET} (was: {old})"


def _replace_path(spec: BridgeSpec, path: str, value: Any) -> BridgeSpec:
    if path not in PARAMETER_PATHS:
        raise BridgeflapInputError("parameter", f"unknown parameter {path!r}")
    group, name = path.split(".")
    sub = dataclasses.replace(getattr(spec, group), **{name: float(value)})
    if getattr(sub, name) == getattr(getattr(spec, group), name):
        return dataclasses.replace(spec, **{group: sub})  # the same value: its source stands
    # the new value is the user's: its source says so, and what the value was sourced from
    sources = {**spec.sources, path: user_set_source(spec.sources.get(path))}
    return dataclasses.replace(spec, **{group: sub}, sources=sources)


#: the fields of ``[deck]`` (in :class:`Deck` order; the loader checks the keys against them)
_DECK_KEYS = ("mass_kg_per_m", "mass_inertia_kgm2_per_m", "ei_vertical_nm2", "ei_lateral_nm2",
              "gj_nm2", "half_chord_m", "hanger_length_midspan_m")
