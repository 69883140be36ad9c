"""Reading a bridge: built-in names, TOML files, variants, parsed dicts -> :class:`BridgeSpec`.

A bridge file is TOML. Every physical value is either a bare number or a table
``{ value = ..., source = "..." }``; built-in bridges
(:mod:`bridgeflap.model.structure.builtin_bridges`) give a source for every value (data-sheet tag,
or ``ESTIMATE: reasoning``).
:func:`load_bridge` reads a name or a file (``"name:variant"`` applies a ``[variants]`` table);
:func:`spec_from_dict` builds the frozen dataclasses of :mod:`bridgeflap.model.structure.spec` from
parsed TOML, and hands a file with ``[structure]`` (an imported modal model) to
:func:`bridgeflap.model.structure.modal_import.modal_spec_from_dict`. Writing a bridge back is
:mod:`bridgeflap.model.structure.spec_writer`. Conventions: see :mod:`bridgeflap.model`.

Example
-------
>>> spec = load_bridge("humber")            # doctest: +SKIP
>>> spec.erected(0.6).deck.half_chord_m      # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
import sys
from importlib import resources
from pathlib import Path
from typing import Any

from bridgeflap.model.arguments import check_mapping, check_text, checked, optional
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.structure.builtin_bridges import BUILTIN_BRIDGES, BUILTIN_FILES
from bridgeflap.model.structure.limits import check_section_geometry, to_float
from bridgeflap.model.structure.modal_import import aero_sections, modal_spec_from_dict
from bridgeflap.model.structure.section_props import section_from_list
from bridgeflap.model.structure.spec import (
    _DECK_KEYS,
    PARAMETER_PATHS,
    Aero,
    BridgeSpec,
    Cable,
    Damping,
    Deck,
    Mesh,
    Span,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["load_bridge", "spec_from_dict"]


def load_bridge(name_or_path: str | Path | BridgeSpec) -> BridgeSpec:
    """A bridge by built-in name or bridge TOML file; a :class:`BridgeSpec` is returned as it is.

    So every function that takes a bridge takes a name, a file or a spec. ``"name:variant"`` (or
    ``"file.toml:variant"``) applies the file's ``[variants.variant]`` table: dotted parameter paths
    with ``{ value, source }``, an alternative reading of the sources kept next to the default one
    (e.g. ``humber:box``, the 22 m steel box as chord).

    Parameters
    ----------
    name_or_path : str, path-like or BridgeSpec
        ``"humber"``, ``"humber:box"``, ``"great-belt"``, ``"iabse-2a:bb3"``, a path to a bridge
        TOML file (docs/reference/formats/bridge.md), or a spec.

    Returns
    -------
    BridgeSpec
        The validated bridge, every value with its source in ``spec.sources``.

    Raises
    ------
    BridgeflapInputError
        Unknown name or variant, missing file, malformed TOML, missing, unknown or
        non-physical field (the field is named).

    Examples
    --------
    >>> from bridgeflap import model
    >>> spec = model.load_bridge("humber")
    >>> spec.main_span.length_m, spec.deck.half_chord_m
    (1410.0, 14.25)
    >>> model.load_bridge("humber:box").deck.half_chord_m  # the 22 m steel box as chord
    11.0
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
        # study or DOE on a bridge with a bad table is refused before it writes
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
        return resources.files("bridgeflap.model.bridges").joinpath(
            BUILTIN_FILES[s]).read_text("utf-8"), s
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
_SECTION_KEYS = ("mass_kg_per_m", "mass_inertia_kgm2_per_m")
_TOP_KEYS = {"name", "description", "spans", "main_span", "cable", "deck", "deck_section",
             "damping", "aero", "mesh", "variants", "erection", "derivatives",
             "static_coefficients"}
_TABLE_PATHS = ("derivatives", "static_coefficients")  # whole tables, in variants too


def _check_keys(table: dict, allowed, where: str) -> None:
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise BridgeflapInputError(f"{where}.{unknown[0]}", "unknown key")


@checked(data=check_mapping, origin=check_text, variant=optional(check_text))
def spec_from_dict(data: dict, origin: str = "<dict>", variant: str | None = None) -> BridgeSpec:
    """A :class:`BridgeSpec` from a bridge definition already parsed from TOML.

    Unknown sections and keys, non-boolean switches and duplicate span names are rejected with
    the field named. A ``[[deck_section]]`` array (:mod:`bridgeflap.model.structure.section_props`)
    gives the deck mass and mass moment of inertia as sums of lumped items; ``[deck]`` then must not
    repeat them.

    Parameters
    ----------
    data : dict
        The bridge file's tables (docs/reference/formats/bridge.md): values plain or as
        ``{ value, source }``.
    origin : str, default "<dict>"
        Where the data came from, for messages.
    variant : str, optional
        Apply ``[variants.<variant>]`` (see :func:`load_bridge`).

    Returns
    -------
    BridgeSpec
        The validated bridge; each value's source in ``spec.sources``.

    Raises
    ------
    BridgeflapInputError
        A missing, unknown or non-physical field, named.
    """
    if isinstance(data, dict) and "structure" in data:  # imported modal model
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
