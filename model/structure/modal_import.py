"""Imported modal models: a bridge whose structure is given as modal data, not the FE model.

A bridge definition with a ``[structure]`` section of ``kind = "modal"`` (docs/modal_import.md)
gives natural frequencies, damping ratios, generalised masses and the deck mode shapes
(vertical, torsional, optionally lateral) at stations along the deck, read from a plain file
(``.npz`` without pickles, ``.json``, or ``.csv``) with the units stated. Three modules:

* :mod:`bridgeflap.model.structure.modal_files` reads and checks the file (:func:`read_modal_file`
  ->
  :class:`ModalData`: stations strictly increasing, no NaN, matching station and mode counts,
  positive frequencies and masses) and writes FE modes (:func:`export_modal`);
* this module parses the definition (:class:`ModalStructure`: deck segments and strips, linear
  interpolation of the shapes onto them, the generalised-mass check) and builds the bridge
  (:class:`ModalBridgeSpec`);
* :mod:`bridgeflap.model.structure.modal_model` gives the :class:`ImportedModalModel`, with the
  interface of
  :class:`bridgeflap.model.structure.modes.ModalModel` (``modes``, ``table``, ``find``,
  ``structural_basis``, ``plot``), so that flutter, buffeting, the state-space export, flaps and
  control design, sensitivities to aerodynamic inputs and DOE run on it unchanged.

The hook: :func:`bridgeflap.model.structure.loader.spec_from_dict` hands a file with ``[structure]``
to
:func:`modal_spec_from_dict`, :func:`bridgeflap.model.structure.fe.assemble` returns an
:class:`ImportedStructure` for such a bridge and :func:`bridgeflap.model.structure.modes.solve`
turns it into the :class:`ImportedModalModel`. The bridge is a :class:`ModalBridgeSpec` (a
:class:`bridgeflap.model.structure.spec.BridgeSpec` whose cable, mesh and FE deck properties raise
one-line
:class:`~bridgeflap.model.errors.BridgeflapInputError` s: erection, cable statics and FE modes need
the built-in cable model). Conventions (signs, ``b``, x):
:mod:`bridgeflap.model`; the file's own vertical sign is stated (``vertical_positive``) and
converted to heave down.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.structure import spec as sm
from bridgeflap.model.structure.builtin_bridges import builtin_folder
from bridgeflap.model.structure.limits import MAX_STRIPS
from bridgeflap.model.structure.modal_files import (
    FAMILIES,
    UNIT_FACTORS,
    ModalData,
    export_modal,
    read_modal_file,
    read_polimi_derivatives,
    units_from_table,
)
from bridgeflap.model.structure.modal_files import needs_fe as _needs_fe
from bridgeflap.model.structure.modal_model import (
    ImportedModalModel,
    ImportedStructure,
    compare_modes,
    imported_structure,
)

__all__ = [
    "FAMILIES",
    "MODAL_PARAMETER_PATHS",
    "UNIT_FACTORS",
    "ImportedModalModel",
    "ImportedStructure",
    "ModalBridgeSpec",
    "ModalData",
    "DerivativeLoads",
    "ModalStructure",
    "compare_modes",
    "derivatives_from_dict",
    "export_modal",
    "imported_structure",
    "modal_spec_from_dict",
    "read_modal_file",
    "structure_from_dict",
]

_STRUCTURE_KEYS = {"kind", "file", "modes_file", "units", "normalisation", "vertical_positive",
                   "deck_segments_m", "strip_length_m", "main_span_m", "mass_kg_per_m",
                   "mass_inertia_kgm2_per_m", "mass_check_tolerance", "source"}
_TOP_KEYS = {"name", "description", "structure", "deck", "aero", "derivatives",
             "static_coefficients", "variants"}
_DERIVATIVE_KEYS = {"file", "form", "lateral", "n_lags", "fit_k_range", "weighting", "source"}
#: parameters a study may vary on a modal bridge (the FE ones need the cable model)
MODAL_PARAMETER_PATHS = ("deck.half_chord_m", "aero.air_density_kg_m3", "aero.deck_height_m",
                         "aero.turbulence_intensity", "aero.coherence_decay",
                         "aero.lift_slope_buffeting", "aero.moment_slope_buffeting")


# -------------------------------------------------------------------------- the definition


@dataclass(frozen=True)
class ModalStructure:
    """The ``[structure] kind = "modal"`` section of a bridge definition (docs/modal_import.md).

    ``deck_segments_m`` are the aerodynamic deck pieces [m] in the file's x (default: first to
    last station); each is cut into equal strips no longer than ``strip_length_m`` (default:
    the largest station spacing). ``main_span_m`` (default: the whole deck) is the main span
    for symmetry labels, flap placement and the buffeting main-span statistics. The masses per
    length (optional) are what the modes move with, for the generalised-mass check.
    """

    file: str
    units: tuple
    normalisation: str = "mass"
    vertical_positive: str = "down"
    modes_file: str | None = None
    deck_segments_m: tuple | None = None
    strip_length_m: float | None = None
    main_span_m: tuple | None = None
    mass_kg_per_m: float | None = None
    mass_inertia_kgm2_per_m: float | None = None
    mass_check_tolerance: float = 0.05
    source: str = ""
    data: ModalData | None = field(default=None, compare=False, hash=False, repr=False)

    def __post_init__(self):
        d = self.data
        if d is None:
            object.__setattr__(self, "data", read_modal_file(
                self.file, dict(self.units), self.normalisation, self.vertical_positive,
                self.modes_file))
            d = self.data
        x = d.station_x_m
        segs = self.deck_segments_m or ((float(x[0]), float(x[-1])),)
        for i, (a, b) in enumerate(segs):
            if not b > a:
                raise BridgeflapInputError(f"structure.deck_segments_m[{i}]",
                                           "end must be beyond start")
            if i and a < segs[i - 1][1]:
                raise BridgeflapInputError(f"structure.deck_segments_m[{i}]",
                                           "segments out of order or overlapping")
        object.__setattr__(self, "deck_segments_m", tuple((float(a), float(b)) for a, b in segs))
        if self.strip_length_m is None:
            object.__setattr__(self, "strip_length_m", float(np.max(np.diff(x))))
        if not (math.isfinite(self.strip_length_m) and self.strip_length_m > 0):
            raise BridgeflapInputError("structure.strip_length_m", "must be positive")
        n_strips = sum((b - a) / self.strip_length_m for a, b in segs)
        if n_strips > MAX_STRIPS:
            raise BridgeflapInputError(
                "structure.strip_length_m", f"{self.strip_length_m:g} m gives {n_strips:.3g} "
                f"strips over the deck, more than the {MAX_STRIPS} allowed")
        ms = self.main_span_m or (segs[0][0], segs[-1][1])
        if not ms[1] > ms[0]:
            raise BridgeflapInputError("structure.main_span_m", "end must be beyond start")
        object.__setattr__(self, "main_span_m", (float(ms[0]), float(ms[1])))
        for name in ("mass_kg_per_m", "mass_inertia_kgm2_per_m"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise BridgeflapInputError(f"structure.{name}", "must be positive")
        if not self.mass_check_tolerance > 0:
            raise BridgeflapInputError("structure.mass_check_tolerance", "must be positive")
        sx, _ = self.strips()
        if sx.min() < x[0] - 1e-9 or sx.max() > x[-1] + 1e-9:
            raise BridgeflapInputError("structure.deck_segments_m",
                                       f"strips from {sx.min():.1f} to {sx.max():.1f} m reach "
                                       f"outside the stations ({x[0]:.1f} to {x[-1]:.1f} m)")
        self.mass_check()   # raises on inconsistent generalised masses

    def strips(self) -> tuple[np.ndarray, np.ndarray]:
        """Strip mid-points [m, file x] and lengths [m]: equal strips per deck segment."""
        xs, ls = [], []
        for a, b in self.deck_segments_m:
            n = max(1, math.ceil((b - a) / self.strip_length_m - 1e-9))
            edges = np.linspace(a, b, n + 1)
            xs.append(0.5 * (edges[:-1] + edges[1:]))
            ls.append(np.diff(edges))
        return np.concatenate(xs), np.concatenate(ls)

    def strip_shapes(self) -> dict:
        """``family -> (n_strip, n_m)``: the shapes interpolated (linearly) onto the strips."""
        sx, _ = self.strips()
        d = self.data
        return {fam: np.column_stack([np.interp(sx, d.station_x_m, s[:, j])
                                      for j in range(d.n_modes)])
                for fam, s in d.shapes.items()}

    def families(self) -> list[str]:
        """Family of each mode: the one with the largest share of the kinetic energy.

        Energies ``int m phi^2`` with the stated masses per length (deck vertical mass for the
        lateral too), or the bare ``int phi^2`` with ``I = m b_r^2`` ``(b_r = 1 m)`` when no
        mass is stated: a file that mixes families should state the masses. A ``family``
        column in the file overrides this.
        """
        d = self.data
        if d.families:
            return list(d.families)
        m = self.mass_kg_per_m or 1.0
        inertia = self.mass_inertia_kgm2_per_m or 1.0
        w = {"vertical": m, "torsional": inertia, "lateral": m}
        e = {fam: w[fam] * np.trapezoid(s ** 2, d.station_x_m, axis=0)
             for fam, s in d.shapes.items()}
        fams = list(e)
        stack = np.vstack([e[f] for f in fams])
        return [fams[int(i)] for i in np.argmax(stack, axis=0)]

    def mass_check(self) -> list[dict]:
        """Stated generalised mass against ``int m phi^2 dx`` of each mode's own family.

        Returns one row per mode (``ratio`` = integral / stated, NaN without masses per length).
        Raises :class:`BridgeflapInputError` when a ratio is off by more than
        ``mass_check_tolerance`` (the shapes are not normalised as stated).
        """
        d = self.data
        per = {"vertical": self.mass_kg_per_m, "lateral": self.mass_kg_per_m,
               "torsional": self.mass_inertia_kgm2_per_m}
        rows = []
        for j, fam in enumerate(self.families()):
            mu = per[fam]
            ratio = float("nan")
            if mu is not None:
                est = mu * float(np.trapezoid(d.shapes[fam][:, j] ** 2, d.station_x_m))
                ratio = est / float(d.generalised_mass[j])
                if abs(ratio - 1.0) > self.mass_check_tolerance:
                    lab = d.labels[j] if d.labels else f"{j + 1}"
                    raise BridgeflapInputError(
                        "structure.generalised_mass",
                        f"mode {lab}: int m phi^2 dx = {est:.4g} but the stated generalised mass"
                        f" is {float(d.generalised_mass[j]):.4g} (ratio {ratio:.3f}; shapes not "
                        f"{self.normalisation}-normalised as stated, or wrong units)")
            rows.append({"mode": j + 1, "family": fam, "ratio": ratio})
        return rows


def structure_from_dict(table: dict, base: Path) -> ModalStructure:
    """The :class:`ModalStructure` of a ``[structure]`` table (files relative to ``base``)."""
    if not isinstance(table, dict):
        raise BridgeflapInputError("structure", "must be a table")
    unknown = sorted(set(table) - _STRUCTURE_KEYS)
    if unknown:
        raise BridgeflapInputError(f"structure.{unknown[0]}", "unknown key")
    if table.get("kind") != "modal":
        raise BridgeflapInputError("structure.kind", f"must be \"modal\" (the built-in FE model "
                                   f"needs no [structure] section), got {table.get('kind')!r}")
    f = table.get("file")
    if not isinstance(f, str) or not f:
        raise BridgeflapInputError("structure.file", "missing or not a string")

    def path(p):
        q = Path(p)
        return str(q if q.is_absolute() else base / q)

    def num(key):
        v = table.get(key)
        if v is None:
            return None
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise BridgeflapInputError(f"structure.{key}", f"must be a number, got {v!r}")
        return float(v)

    def pair(v, key):
        if (not isinstance(v, list | tuple) or len(v) != 2
                or not all(isinstance(t, int | float) and not isinstance(t, bool) for t in v)):
            raise BridgeflapInputError(f"structure.{key}", "must be [start_m, end_m]")
        return float(v[0]), float(v[1])

    segs = table.get("deck_segments_m")
    if segs is not None:
        if not isinstance(segs, list) or not segs:
            raise BridgeflapInputError("structure.deck_segments_m", "must be a list of pairs")
        segs = tuple(pair(s, "deck_segments_m") for s in segs)
    main = table.get("main_span_m")
    for key in ("normalisation", "vertical_positive", "source"):
        if key in table and not isinstance(table[key], str):
            raise BridgeflapInputError(f"structure.{key}", "must be a string")
    mf = table.get("modes_file")
    tol = num("mass_check_tolerance")
    return ModalStructure(
        file=path(f), units=tuple(sorted(units_from_table(table.get("units")).items())),
        normalisation=table.get("normalisation", "mass"),
        vertical_positive=table.get("vertical_positive", "down"),
        modes_file=None if mf is None else path(mf), deck_segments_m=segs,
        strip_length_m=num("strip_length_m"),
        main_span_m=None if main is None else pair(main, "main_span_m"),
        mass_kg_per_m=num("mass_kg_per_m"),
        mass_inertia_kgm2_per_m=num("mass_inertia_kgm2_per_m"),
        mass_check_tolerance=0.05 if tol is None else tol, source=table.get("source", ""))


# -------------------------------------------------------------- flutter-derivative loads


@dataclass(frozen=True)
class DerivativeLoads:
    """The ``[derivatives]`` section: self-excited loads from flutter-derivative tables.

    Instead of the thin-aerofoil (Theodorsen) strip loads, the deck's self-excited loads come
    from measured flutter derivatives (:mod:`bridgeflap.model.aero.derivatives`), turned into a
    Roger RFA state space on the modal coordinates
    (:func:`bridgeflap.model.aeroelastic.derivative_system.derivative_bridge_system`). ``file`` is a
    table of the ``form`` ``"polimi-json"``
    (:func:`bridgeflap.model.structure.modal_files.read_polimi_derivatives`, the IABSE step-2a "BB3"
    file); ``lateral`` includes the lateral DOF (the drag and lateral-coupling derivatives on the
    lateral shapes of the modes, lateral modes retained) when the modal file has lateral shapes;
    ``n_lags``, ``fit_k_range`` (``[K_min, K_max]`` of ``K = B omega / U``, default the table's) and
    ``weighting`` set the RFA (:func:`bridgeflap.model.aero.derivatives.fit_roger`).
    """

    file: str
    form: str = "polimi-json"
    lateral: bool = True
    n_lags: int = 2
    fit_k_range: tuple | None = None
    weighting: str = "derivative"
    source: str = ""

    def table(self, chord_m: float):
        """The :class:`~bridgeflap.model.aero.derivatives.FlutterDerivatives` of the file (deck
        chord B [m])."""
        return _derivative_table(self.file, float(chord_m))

    def fit(self, chord_m: float, n_dof: int):
        """The Roger fit (cached per chord and DOF count)."""
        return _derivative_fit(self, float(chord_m), int(n_dof))


@functools.lru_cache(maxsize=8)
def _derivative_table(file: str, chord_m: float):
    return read_polimi_derivatives(file, chord_m)


@functools.lru_cache(maxsize=8)
def _derivative_fit(loads: DerivativeLoads, chord_m: float, n_dof: int):
    from bridgeflap.model.aero.derivatives import fit_roger

    return fit_roger(loads.table(chord_m), n_lags=loads.n_lags, n_dof=n_dof,
                     k_range=loads.fit_k_range, weighting=loads.weighting)


def derivatives_from_dict(table, base: Path, where: str = "derivatives") -> DerivativeLoads:
    """The :class:`DerivativeLoads` of a ``[derivatives]`` table (file relative to ``base``)."""
    if not isinstance(table, dict):
        raise BridgeflapInputError(where, "must be a table")
    unknown = sorted(set(table) - _DERIVATIVE_KEYS)
    if unknown:
        raise BridgeflapInputError(f"{where}.{unknown[0]}", "unknown key")
    f = table.get("file")
    if not isinstance(f, str) or not f:
        raise BridgeflapInputError(f"{where}.file", "missing or not a string")
    form = table.get("form", "polimi-json")
    if form != "polimi-json":
        raise BridgeflapInputError(f"{where}.form", f"must be \"polimi-json\", got {form!r}")
    lateral = table.get("lateral", True)
    if not isinstance(lateral, bool):
        raise BridgeflapInputError(f"{where}.lateral", "must be true or false")
    n_lags = table.get("n_lags", 2)
    if isinstance(n_lags, bool) or not isinstance(n_lags, int) or not 0 <= n_lags <= 8:
        raise BridgeflapInputError(f"{where}.n_lags", f"must be an integer 0..8, got {n_lags!r}")
    rng = table.get("fit_k_range")
    if rng is not None:
        if (not isinstance(rng, list | tuple) or len(rng) != 2
                or not all(isinstance(t, int | float) and not isinstance(t, bool) for t in rng)
                or not 0 < rng[0] < rng[1] or not math.isfinite(rng[1])):
            raise BridgeflapInputError(f"{where}.fit_k_range", "must be [K_min, K_max] with "
                                       "0 < K_min < K_max")
        rng = (float(rng[0]), float(rng[1]))
    w = table.get("weighting", "derivative")
    if w not in ("derivative", "row"):
        raise BridgeflapInputError(f"{where}.weighting", "must be \"derivative\" or \"row\"")
    src = table.get("source", "")
    if not isinstance(src, str):
        raise BridgeflapInputError(f"{where}.source", "must be a string")
    q = Path(f)
    return DerivativeLoads(file=str(q if q.is_absolute() else base / q), form=form,
                           lateral=lateral, n_lags=n_lags, fit_k_range=rng, weighting=w,
                           source=src)


def aero_sections(data: dict, origin: str = "<dict>", prefix: str = "") -> dict:
    """``derivatives`` and ``static_coefficients`` of a bridge file (FE or modal), parsed.

    Only the keys present in ``data`` are returned; files are relative to the bridge file's
    folder (``origin``); ``prefix`` names a variant in the error messages.
    """
    from bridgeflap.model.aero.quasi_steady import static_from_dict

    base = builtin_folder(origin)
    if base is None:
        base = Path(origin).parent if origin not in ("<dict>", "") else Path(".")
    out = {}
    if "derivatives" in data:
        out["derivatives"] = derivatives_from_dict(data["derivatives"], base,
                                                   f"{prefix}derivatives")
    if "static_coefficients" in data:
        out["static_coefficients"] = static_from_dict(data["static_coefficients"],
                                                      f"{prefix}static_coefficients")
    return out


# ------------------------------------------------------------------------------ the bridge


class _FEOnly:
    """Stands for a part of the FE bridge definition that a modal bridge does not have."""

    def __init__(self, bridge: str, what: str):
        self._bridge, self._what = bridge, what

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        raise _needs_fe(self._bridge, self._what)

    def __repr__(self):
        return f"<{self._what}: not defined for a modal bridge>"

    def __eq__(self, other):  # the bridge's name is compared by the spec itself
        return isinstance(other, _FEOnly) and self._what == other._what

    def __hash__(self):
        return hash(self._what)


@dataclass(frozen=True)
class ModalDeck:
    """Deck of a modal bridge: only what the aerodynamics needs."""

    half_chord_m: float
    bridge: str = field(default="", compare=False)  # for the messages only

    def __post_init__(self):
        if not (isinstance(self.half_chord_m, float) and math.isfinite(self.half_chord_m)
                and self.half_chord_m > 0):
            raise BridgeflapInputError("deck.half_chord_m", "must be a positive number")

    def __getattr__(self, name):
        if name.startswith("__") or name in ("half_chord_m", "bridge"):
            raise AttributeError(name)
        raise _needs_fe(self.bridge, f"deck.{name}")


@dataclass(frozen=True)
class ModalBridgeSpec(sm.BridgeSpec):
    """A bridge whose structure is an imported modal model (module docstring).

    A :class:`bridgeflap.model.structure.spec.BridgeSpec` (``isinstance`` works) with ``structure``
    set; the cable, the mesh and the FE deck properties raise one-line input errors, erection stages
    are refused, and :meth:`replace` accepts :data:`MODAL_PARAMETER_PATHS`.
    """

    structure: ModalStructure | None = None
    description: str = ""

    def __post_init__(self):
        if self.structure is None:
            raise BridgeflapInputError("structure", "missing")

    def erected(self, fraction, side_spans=None):
        """Refused: erection stages need the cable/FE model."""
        raise _needs_fe(self.name, "an erection stage")

    def completed(self):
        """The bridge itself (a modal model describes one state)."""
        return self

    def replace(self, **changes):
        """Copy with dotted-path changes among :data:`MODAL_PARAMETER_PATHS`."""
        spec = self
        for path, value in changes.items():
            if path not in MODAL_PARAMETER_PATHS:
                if path in sm.PARAMETER_PATHS:
                    raise _needs_fe(self.name, f"parameter {path!r}")
                raise BridgeflapInputError("parameter", f"unknown parameter {path!r}")
            group, name = path.split(".")
            sub = dataclasses.replace(getattr(spec, group), **{name: float(value)})
            spec = dataclasses.replace(spec, **{group: sub})
        return spec


def modal_spec_from_dict(data: dict, origin: str = "<dict>", variant: str | None = None):
    """A :class:`ModalBridgeSpec` from a parsed bridge file with ``[structure] kind = "modal"``.

    Sections: ``name``, ``description``, ``[structure]``, ``[deck] half_chord_m``, ``[aero]``
    (as for the FE bridge); ``[variants]`` may change :data:`MODAL_PARAMETER_PATHS`. Relative
    file names are taken from the bridge file's folder.
    """
    unknown = sorted(set(data) - _TOP_KEYS)
    if unknown:
        raise BridgeflapInputError(unknown[0], "unknown section for a modal bridge (cable, spans, "
                                   "mesh, erection and deck stiffness belong to the FE model)")
    name = data.get("name")
    if not isinstance(name, str) or not name:
        raise BridgeflapInputError("name", "missing or not a string")
    base = builtin_folder(origin)
    if base is None:
        base = Path(origin).parent if origin not in ("<dict>", "") else Path(".")
    sources: dict = {}

    def value(table, group, key, default=None):
        raw = table.get(key, default)
        if isinstance(raw, dict):
            sources[f"{group}.{key}"] = str(raw.get("source", "not stated"))
            raw = raw.get("value")
        if raw is None:
            raise BridgeflapInputError(f"{group}.{key}", "missing")
        if isinstance(raw, bool):
            return raw
        if not isinstance(raw, int | float):
            raise BridgeflapInputError(f"{group}.{key}", f"must be a number, got {raw!r}")
        return float(raw)

    structure = structure_from_dict(data.get("structure"), base)
    d = data.get("deck", {})
    if not isinstance(d, dict):
        raise BridgeflapInputError("deck", "must be a table")
    for k in d:
        if k != "half_chord_m":
            raise BridgeflapInputError(f"deck.{k}", "a modal bridge's deck gives only "
                                       "half_chord_m (mass and stiffness are in the modes)")
    deck = ModalDeck(value(d, "deck", "half_chord_m"), bridge=name)
    ag = data.get("aero", {})
    if not isinstance(ag, dict):
        raise BridgeflapInputError("aero", "must be a table")
    names = [f.name for f in dataclasses.fields(sm.Aero)]
    for k in ag:
        if k not in names:
            raise BridgeflapInputError(f"aero.{k}", "unknown key")
    defaults = sm.Aero()
    kw = {k: value(ag, "aero", k, getattr(defaults, k)) for k in names}
    if not isinstance(kw["added_inertia"], bool):
        raise BridgeflapInputError("aero.added_inertia", "must be true or false")
    aero = sm.Aero(**kw)
    a, b = structure.main_span_m
    x0 = structure.deck_segments_m[0][0]
    x1 = structure.deck_segments_m[-1][1]
    spans = []
    for nm, lo, hi in (("before_main", x0, a), ("main", a, b), ("after_main", b, x1)):
        if hi - lo > 1e-9:
            spans.append(sm.Span(name=nm, length_m=hi - lo))
    main_index = [s.name for s in spans].index("main")
    spec = ModalBridgeSpec(name=name, spans=tuple(spans), main_span_index=main_index,
               cable=_FEOnly(name, "the cable"), deck=deck, aero=aero,
               damping=_FEOnly(name, "Rayleigh damping (the modes carry their own ratios)"),
               mesh=_FEOnly(name, "the FE mesh"), sources=sources, structure=structure,
               description=str(data.get("description", "")), **aero_sections(data, origin))
    variants = data.get("variants", {})
    if variant is None:
        return spec
    if not isinstance(variants, dict) or variant not in variants:
        raise BridgeflapInputError("bridge", f"unknown variant {variant!r} of {name!r}")
    changes = {}
    for path, raw in variants[variant].items():
        if path == "description":
            continue
        if path in ("derivatives", "static_coefficients"):  # whole tables
            spec = dataclasses.replace(spec, **aero_sections({path: raw}, origin,
                                                             f"variants.{variant}."))
            continue
        if isinstance(raw, dict):
            sources[path] = f"variant {variant}: {raw.get('source', 'not stated')}"
            raw = raw.get("value")
        if isinstance(raw, bool) or not isinstance(raw, int | float):
            raise BridgeflapInputError(f"variants.{variant}.{path}", "must be a number")
        changes[path] = float(raw)
    return dataclasses.replace(spec.replace(**changes), name=f"{name}:{variant}")
