"""The bridge TOML text of a :class:`~bridgeflap.model.structure.spec.BridgeSpec` (the loader's
format).

:func:`bridge_toml` gives the text from the spec's attributes only (it imports no spec
module, so :meth:`BridgeSpec.to_toml` can call it);
:func:`bridgeflap.model.structure.spec_writer.to_toml` checks its argument and
:func:`bridgeflap.model.structure.spec_writer.save_bridge` writes the file. The round trip
``load_bridge(path) -> to_toml -> write -> load_bridge`` gives an equal spec (``==``) with the same
``sources`` and the same lumped ``deck_section``, for every built-in bridge and variant
(tests/test_spec_writer.py). What is written:

* every resolved value (a variant's values applied: ``humber:box`` is written as a plain bridge
  named ``"humber:box"``, without a ``[variants]`` table), as ``{ value, source }`` when the
  value has a source, bare otherwise; a value the file left at its default (no source
  recorded, default value) is left out, so the reloaded ``sources`` are the same;
* the ``[[deck_section]]`` items when their sums are the deck's mass and inertia; when the deck
  mass or inertia was changed in memory (``spec.replace``), the two values instead (their
  sources say so);
* floats by ``repr`` (the shortest text that reads back to the same float: exact).

Files a bridge refers to (the modal data of ``[structure]``, a ``[derivatives]`` table) are
written as **absolute paths** to the files the spec was loaded from: the written file works
from any folder on this machine, not after the data files move (copy them along and edit the
paths). Specs from relative paths therefore reload with absolute ones (equal values, a
different ``file`` string). An erection stage (:meth:`BridgeSpec.erected`) has no bridge file:
write ``spec.completed()`` and call ``erected`` after loading.
"""

from __future__ import annotations

import dataclasses
import math
import os

import tomli_w

from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["bridge_toml"]

_SECTION_PREFIX = "sum over the [[deck_section]] items"


def _lit(v) -> str:
    """A TOML literal of a scalar, a list or an inline table."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return tomli_w.dumps({"v": v})[4:].rstrip("\n")
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_lit(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_lit(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"no TOML literal for {type(v).__name__}")


class _Writer:
    def __init__(self, spec):
        self.spec, self.lines = spec, []

    def add(self, line: str = "") -> None:
        self.lines.append(line)

    def value(self, path: str, key: str, v, default=None, has_default: bool = False) -> None:
        """``key = { value, source }`` (or bare); skipped when left at its default."""
        src = self.spec.sources.get(path)
        if src is None and has_default and v == default:
            return
        if isinstance(v, float | int) and not isinstance(v, bool):
            v = float(v)
        self.add(f"{key} = {_lit(v)}" if src in (None, "not stated")
                 else f"{key} = {_lit({'value': v, 'source': src})}")

    def aero(self) -> None:
        defaults = type(self.spec.aero)()  # the Aero defaults, without importing the spec module
        self.add("[aero]")
        for f in dataclasses.fields(self.spec.aero):
            v = getattr(self.spec.aero, f.name)
            self.value(f"aero.{f.name}", f.name, v, getattr(defaults, f.name), True)
        self.add()

    def tables(self) -> None:
        spec = self.spec
        d = getattr(spec, "derivatives", None)
        if d is not None:
            self.add("[derivatives]")
            row = {"file": os.path.abspath(d.file), "form": d.form, "lateral": d.lateral,
                   "n_lags": int(d.n_lags), "weighting": d.weighting}
            if d.fit_k_range is not None:
                row["fit_k_range"] = [float(x) for x in d.fit_k_range]
            if d.source:
                row["source"] = d.source
            self.add_rows(row)
        s = getattr(spec, "static_coefficients", None)
        if s is not None:
            self.add("[static_coefficients]")
            row = {f.name: getattr(s, f.name) for f in dataclasses.fields(s)
                   if f.name != "source" and getattr(s, f.name) is not None}
            if s.source:
                row["source"] = s.source  # the per-value notes, joined as the loader does
            self.add_rows(row)

    def add_rows(self, row: dict) -> None:
        for k, v in row.items():
            self.add(f"{k} = {_lit(v)}")
        self.add()

    def text(self) -> str:
        return "\n".join(self.lines).rstrip("\n") + "\n"


def _header(w: _Writer, spec) -> None:
    w.add(f"# Bridge {spec.name!r} written by bridgeflap "
          f"(bridgeflap.model.structure.spec_writer.to_toml): "
          "every value")
    w.add("# resolved, with its source. Load it with model.load_bridge(<this file>).")
    w.add(f"name = {_lit(spec.name)}")
    desc = getattr(spec, "description", "")
    if desc:
        w.add(f"description = {_lit(desc)}")


def _fe(spec) -> str:
    if spec.is_erecting or spec.erected_fraction != 1.0:
        raise BridgeflapInputError(
            "erected_fraction", "an erection stage has no bridge file: write spec.completed() "
                                "and call erected() after loading")
    w = _Writer(spec)
    _header(w, spec)
    w.add(f"main_span = {_lit(spec.main_span.name)}")
    w.add()
    for s in spec.spans:
        w.add("[[spans]]")
        w.add(f"name = {_lit(s.name)}")
        where = f"spans.{s.name}"
        w.value(f"{where}.length_m", "length_m", s.length_m)
        w.value(f"{where}.chord_rise_m", "chord_rise_m", s.chord_rise_m, 0.0, True)
        w.add(f"suspended_deck = {_lit(s.suspended_deck)}")
        if s.cable_area_m2 is not None:
            w.value(f"{where}.cable_area_m2", "cable_area_m2", s.cable_area_m2)
        w.add()
    w.add("[cable]")
    for f in dataclasses.fields(spec.cable):
        w.value(f"cable.{f.name}", f.name, getattr(spec.cable, f.name))
    w.add()
    section = spec.deck_section
    keep = section is not None and (
        section.mass_kg_per_m == spec.deck.mass_kg_per_m
        and section.inertia_kgm2_per_m == spec.deck.mass_inertia_kgm2_per_m)
    w.add("[deck]")
    for f in dataclasses.fields(spec.deck):
        if keep and f.name in ("mass_kg_per_m", "mass_inertia_kgm2_per_m"):
            continue
        path = f"deck.{f.name}"
        v = getattr(spec.deck, f.name)
        src = spec.sources.get(path, "")
        if src.startswith(_SECTION_PREFIX):  # the other one changed: the items are not written
            note = (f"{src}, which are not written: the deck's mass or inertia was changed "
                    "in memory")
            w.add(f"{f.name} = {_lit({'value': float(v), 'source': note})}")
            continue
        w.value(path, f.name, v)
    w.add()
    if keep:
        from bridgeflap.model.structure.section_props import _GEOMETRY

        for item in section.items:
            w.add("[[deck_section]]")
            row = {"name": item.name, "kind": item.kind, "mass_kg_per_m": item.mass_kg_per_m}
            row.update(zip(_GEOMETRY[item.kind], item.geometry, strict=True))
            row["source"] = item.source
            w.add_rows(row)
    w.add("[erection]")
    w.value("erection.side_spans", "side_spans", spec.side_span_decks, "in_place", True)
    w.add()
    w.add("[damping]")
    w.value("damping.ratio", "ratio", spec.damping.ratio, 0.01, True)
    w.add()
    w.aero()
    w.add("[mesh]")
    w.value("mesh.element_length_m", "element_length_m", spec.mesh.element_length_m, 25.0, True)
    w.add()
    w.tables()
    return w.text()


def _modal(spec) -> str:
    st = spec.structure
    w = _Writer(spec)
    _header(w, spec)
    w.add()
    w.add("[structure]")
    row = {"kind": "modal", "file": os.path.abspath(st.file), "units": dict(st.units),
           "normalisation": st.normalisation, "vertical_positive": st.vertical_positive}
    if st.modes_file is not None:
        row["modes_file"] = os.path.abspath(st.modes_file)
    row["deck_segments_m"] = [list(s) for s in st.deck_segments_m]
    row["strip_length_m"] = st.strip_length_m
    row["main_span_m"] = list(st.main_span_m)
    for k in ("mass_kg_per_m", "mass_inertia_kgm2_per_m"):
        if getattr(st, k) is not None:
            row[k] = getattr(st, k)
    row["mass_check_tolerance"] = st.mass_check_tolerance
    if st.source:
        row["source"] = st.source
    w.add_rows(row)
    w.add("[deck]")
    w.value("deck.half_chord_m", "half_chord_m", spec.deck.half_chord_m)
    w.add()
    w.aero()
    w.tables()
    return w.text()


def bridge_toml(spec) -> str:
    """The bridge TOML text of ``spec``, a :class:`~bridgeflap.model.structure.spec.BridgeSpec`
    (module docstring: what is written, the round trip).

    Raises
    ------
    BridgeflapInputError
        ``erected_fraction`` for an erection stage.
    """
    return _modal(spec) if getattr(spec, "structure", None) is not None else _fe(spec)
