"""Imported modal models: a bridge whose structure is given as modal data, not the FE model.

A bridge definition with a ``[structure]`` section of ``kind = "modal"`` (docs/modal_import.md)
gives natural frequencies, damping ratios, generalised masses and the deck mode shapes
(vertical, torsional, optionally lateral) at stations along the deck, read from a plain file
(``.npz`` without pickles, ``.json``, or ``.csv``) with the units stated. This module

* reads and checks the file (:func:`read_modal_file` -> :class:`ModalData`: stations strictly
  increasing, no NaN, matching station and mode counts, positive frequencies and masses);
* builds the aerodynamic strips of the deck segments and interpolates the shapes onto them
  (linear between stations; strips outside the stations are refused);
* checks the generalised masses against the shapes and the stated mass per length
  (:attr:`ImportedModalModel.mass_check`);
* returns an :class:`ImportedModalModel` with the interface of :class:`model.modes.ModalModel`
  (``modes``, ``table``, ``find``, ``structural_basis``, ``plot``), so that flutter, buffeting,
  the state-space export, flaps and control design and DOE run on it unchanged.

The hook: :func:`model.fe.assemble` returns an :class:`ImportedStructure` for such a bridge and
:func:`model.modes.solve` turns it into the :class:`ImportedModalModel`; the bridge itself is a
:class:`ModalBridgeSpec` (a :class:`model.spec.BridgeSpec` whose cable, mesh and FE deck
properties raise one-line :class:`~model.errors.BridgeflapInputError` s: erection, cable statics
and FE modes need the built-in cable model). Conventions (signs, ``b``, x): :mod:`model`; the
file's own vertical sign is stated (``vertical_positive``) and converted to heave down.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from model import spec as sm
from model.basis import StructuralBasis
from model.errors import BridgeflapError, BridgeflapInputError
from model.modes import Mode

__all__ = [
    "FAMILIES",
    "ImportedModalModel",
    "ImportedStructure",
    "ModalBridgeSpec",
    "ModalData",
    "ModalStructure",
    "export_modal",
    "imported_structure",
    "modal_spec_from_dict",
    "read_modal_file",
]

FAMILIES = ("vertical", "torsional", "lateral")
UNIT_FACTORS = {
    "frequency": {"Hz": 1.0, "rad/s": 1.0 / (2 * math.pi)},   # to Hz
    "length": {"m": 1.0, "mm": 1e-3},                           # to m (stations, v and l shapes)
    "rotation": {"rad": 1.0, "deg": math.pi / 180.0},          # to rad (torsional shapes)
    "mass": {"kg": 1.0, "t": 1e3},                              # to kg (generalised masses)
}
NORMALISATIONS = ("mass", "generalised_mass")
_STRUCTURE_KEYS = {"kind", "file", "modes_file", "units", "normalisation", "vertical_positive",
                   "deck_segments_m", "strip_length_m", "main_span_m", "mass_kg_per_m",
                   "mass_inertia_kgm2_per_m", "mass_check_tolerance", "source"}
_FILE_KEYS = {"station_x", "frequency", "damping_ratio", "generalised_mass", "vertical",
              "torsional", "lateral", "label", "family", "units", "source", "provenance"}
_TOP_KEYS = {"name", "description", "structure", "deck", "aero", "variants"}
#: parameters a study may vary on a modal bridge (the FE ones need the cable model)
MODAL_PARAMETER_PATHS = ("deck.half_chord_m", "aero.air_density_kg_m3", "aero.deck_height_m",
                         "aero.turbulence_intensity", "aero.coherence_decay",
                         "aero.lift_slope_buffeting", "aero.moment_slope_buffeting")


def _needs_fe(name: str, what: str) -> BridgeflapInputError:
    return BridgeflapInputError(
        "structure", f"{what} needs the built-in cable/FE model; bridge {name!r} gives its "
        "structure as modal data ([structure] kind = \"modal\")")


# ------------------------------------------------------------------------------- the data


@dataclass(frozen=True)
class ModalData:
    """Modal data as read, in SI units, checked.

    Attributes
    ----------
    station_x_m : ndarray (n_s,)
        Deck stations [m], strictly increasing.
    frequency_hz, damping_ratio, generalised_mass : ndarray (n_m,)
        Natural frequency [Hz], ratio of critical damping [-], generalised mass per unit modal
        coordinate [kg] (1 for mass-normalised shapes).
    shapes : dict
        ``family -> (n_s, n_m)``: vertical [m, positive down], torsional [rad, nose-up],
        lateral [m] (optional) per unit modal coordinate.
    labels : tuple of str
        Mode labels from the file ("" where none is given).
    families : tuple of str
        Family of each mode from the file (empty: decided from the shapes,
        :meth:`ModalStructure.families`).
    """

    station_x_m: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    generalised_mass: np.ndarray
    shapes: dict
    labels: tuple = ()
    source: str = ""
    families: tuple = ()

    def __post_init__(self):
        x = np.asarray(self.station_x_m, float)
        if x.ndim != 1 or x.size < 2:
            raise BridgeflapInputError("structure.station_x", "need at least two stations")
        if not np.all(np.isfinite(x)):
            raise BridgeflapInputError("structure.station_x", "NaN or infinite station")
        bad = np.flatnonzero(np.diff(x) <= 0)
        if bad.size:
            raise BridgeflapInputError(
                "structure.station_x", f"stations out of order (strictly increasing needed): "
                f"station {bad[0] + 1} at {x[bad[0] + 1]} m follows {x[bad[0]]} m")
        n_m = np.asarray(self.frequency_hz).size
        for name in ("frequency_hz", "damping_ratio", "generalised_mass"):
            v = np.asarray(getattr(self, name), float)
            if v.shape != (n_m,):
                raise BridgeflapInputError(f"structure.{name}",
                                           f"{v.size} values for {n_m} modes")
            if not np.all(np.isfinite(v)):
                raise BridgeflapInputError(f"structure.{name}", "NaN or infinite value")
        if n_m < 1:
            raise BridgeflapInputError("structure.frequency", "no modes in the file")
        if np.any(np.asarray(self.frequency_hz) <= 0):
            raise BridgeflapInputError("structure.frequency", "frequencies must be positive")
        if np.any(np.asarray(self.generalised_mass) <= 0):
            raise BridgeflapInputError("structure.generalised_mass", "must be positive")
        z = np.asarray(self.damping_ratio)
        if np.any(z < 0) or np.any(z >= 1):
            raise BridgeflapInputError("structure.damping_ratio", "must be in [0, 1)")
        if not {"vertical", "torsional"} <= set(self.shapes):
            raise BridgeflapInputError("structure.shapes",
                                       "vertical and torsional shapes are required")
        for fam, s in self.shapes.items():
            if fam not in FAMILIES:
                raise BridgeflapInputError(f"structure.{fam}", "unknown shape family")
            if s.shape != (x.size, n_m):
                raise BridgeflapInputError(
                    f"structure.{fam}", f"shape table is {s.shape[0]} stations x "
                    f"{s.shape[1] if s.ndim > 1 else 1} modes, expected {x.size} x {n_m} "
                    "(mismatched station count)")
            if not np.all(np.isfinite(s)):
                i, j = np.argwhere(~np.isfinite(s))[0]
                raise BridgeflapInputError(f"structure.{fam}",
                                           f"NaN in the shape of mode {j + 1} at station {i + 1}")
        if self.labels and len(self.labels) != n_m:
            raise BridgeflapInputError("structure.label", f"{len(self.labels)} labels for "
                                                          f"{n_m} modes")
        if self.families:
            if len(self.families) != n_m:
                raise BridgeflapInputError("structure.family", f"{len(self.families)} families "
                                                               f"for {n_m} modes")
            for j, fam in enumerate(self.families):
                if fam not in self.shapes:
                    raise BridgeflapInputError(
                        "structure.family", f"mode {j + 1}: {fam!r} is not one of the shape "
                        f"families given ({', '.join(self.shapes)})")

    @property
    def n_modes(self) -> int:
        """Number of modes in the file."""
        return int(np.asarray(self.frequency_hz).size)


def _units(raw) -> dict:
    if not isinstance(raw, dict):
        raise BridgeflapInputError("structure.units", "missing: state the units, e.g. units = "
                                   "{ frequency = \"Hz\", length = \"m\", rotation = \"rad\", "
                                   "mass = \"kg\" }")
    out = {}
    for key in raw:
        if key not in UNIT_FACTORS:
            raise BridgeflapInputError(f"structure.units.{key}", "unknown key")
    for key, table in UNIT_FACTORS.items():
        u = raw.get(key)
        if u not in table:
            raise BridgeflapInputError(f"structure.units.{key}",
                                       f"must be one of {tuple(table)}, got {u!r}")
        out[key] = u
    return out


def _as_float_array(v, name: str) -> np.ndarray:
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise BridgeflapInputError(f"structure.{name}", "not numeric") from None
    return a


def _table_from_mapping(d, name: str, source: str) -> dict:
    """Arrays of a JSON object or an npz archive (keys of docs/modal_import.md)."""
    required = ("station_x", "frequency", "vertical", "torsional")
    unknown = sorted(set(d) - _FILE_KEYS)
    if unknown:
        raise BridgeflapInputError(f"structure.{unknown[0]}", f"unknown key in {name}")
    for key in required:
        if key not in d:
            raise BridgeflapInputError(f"structure.{key}", f"missing in {name}")
    out = {k: _as_float_array(d[k], k) for k in
           ("station_x", "frequency", "damping_ratio", "generalised_mass", "vertical",
            "torsional", "lateral") if k in d}
    for key in ("label", "family"):
        if key in d:
            out[key] = tuple(str(s) for s in np.asarray(d[key]).ravel())
    if "units" in d:
        u = d["units"]
        out["units"] = json.loads(str(np.asarray(u))) if not isinstance(u, dict) else u
    out["source"] = str(np.asarray(d["source"])) if "source" in d else source
    return out


def _read_csv(path: Path, modes_path: Path | None) -> dict:
    """Shapes CSV (``station_x``, ``vertical:<label>``, ...) plus a modes CSV."""
    if modes_path is None:
        raise BridgeflapInputError("structure.modes_file",
                                   "a CSV shape table needs a modes CSV (label, frequency, "
                                   "damping_ratio, generalised_mass)")
    with path.open(newline="") as fh:
        rows = [r for r in csv.reader(fh) if r and not r[0].lstrip().startswith("#")]
    with modes_path.open(newline="") as fh:
        mrows = [r for r in csv.reader(fh) if r and not r[0].lstrip().startswith("#")]
    if len(rows) < 2 or len(mrows) < 2:
        raise BridgeflapInputError("structure.file", f"empty CSV table in {path} or {modes_path}")
    head, mhead = [h.strip() for h in rows[0]], [h.strip() for h in mrows[0]]
    if "label" not in mhead or "frequency" not in mhead:
        raise BridgeflapInputError("structure.modes_file", "needs columns label and frequency")
    try:
        body = np.array([[float(v) for v in r] for r in rows[1:]])
        mcols = {h: [r[i].strip() for r in mrows[1:]] for i, h in enumerate(mhead)}
    except (ValueError, IndexError):
        raise BridgeflapInputError("structure.file", f"non-numeric or short row in {path}"
                                   ) from None
    labels = tuple(mcols["label"])
    out = {"label": labels, "source": str(path)}
    if "family" in mcols:
        out["family"] = tuple(mcols["family"])
    try:
        for key in ("frequency", "damping_ratio", "generalised_mass"):
            if key in mcols:
                out[key] = np.array([float(v) for v in mcols[key]])
    except ValueError:
        raise BridgeflapInputError("structure.modes_file", "non-numeric value") from None
    if head[0] != "station_x":
        raise BridgeflapInputError("structure.file", "first column must be station_x")
    out["station_x"] = body[:, 0]
    for fam in FAMILIES:
        cols = [h for h in head if h.startswith(fam + ":")]
        if not cols:
            continue
        got = [c.split(":", 1)[1] for c in cols]
        if got != list(labels):
            raise BridgeflapInputError(f"structure.{fam}", "shape columns do not match the "
                                       f"modes table labels ({len(got)} vs {len(labels)})")
        out[fam] = body[:, [head.index(c) for c in cols]]
    return out


def read_modal_file(path, units: dict, normalisation: str = "mass",
                    vertical_positive: str = "down", modes_file=None) -> ModalData:
    """Read and check a modal file (``.npz``, ``.json`` or ``.csv`` + modes CSV).

    Parameters
    ----------
    path : path-like
        The shape file (docs/modal_import.md#files).
    units : dict
        ``{"frequency": "Hz"|"rad/s", "length": "m"|"mm", "rotation": "rad"|"deg",
        "mass": "kg"|"t"}``; a JSON/npz file that states its own units must agree.
    normalisation : {"mass", "generalised_mass"}
        ``"mass"``: the shapes are mass-normalised (generalised masses 1; a file that gives
        them must give 1); ``"generalised_mass"``: the file gives them.
    vertical_positive : {"down", "up"}
        Sign of the file's vertical shapes (bridgeflap heave is positive down).
    """
    path = Path(path)
    if not path.is_file():
        raise BridgeflapInputError("structure.file", f"file not found: {path}")
    suffix = path.suffix.lower()
    try:
        if suffix == ".npz":
            with np.load(path, allow_pickle=False) as z:
                raw = _table_from_mapping({k: z[k] for k in z.files}, path.name, str(path))
        elif suffix == ".json":
            raw = _table_from_mapping(json.loads(path.read_text("utf-8")), path.name, str(path))
        elif suffix == ".csv":
            raw = _read_csv(path, None if modes_file is None else Path(modes_file))
        else:
            raise BridgeflapInputError("structure.file",
                                       f"unsupported type {suffix!r} (use .npz, .json or .csv)")
    except (OSError, ValueError) as exc:
        if isinstance(exc, BridgeflapInputError):
            raise
        raise BridgeflapInputError("structure.file", f"cannot read {path}: {exc}") from None
    file_units = raw.pop("units", None)
    if file_units is not None and dict(file_units) != dict(units):
        raise BridgeflapInputError("structure.units", f"the file states {dict(file_units)}, the "
                                   f"definition {dict(units)}")
    if normalisation not in NORMALISATIONS:
        raise BridgeflapInputError("structure.normalisation",
                                   f"must be one of {NORMALISATIONS}, got {normalisation!r}")
    if vertical_positive not in ("down", "up"):
        raise BridgeflapInputError("structure.vertical_positive", "must be \"down\" or \"up\"")
    n_m = raw["frequency"].size
    lf, rf = UNIT_FACTORS["length"][units["length"]], UNIT_FACTORS["rotation"][units["rotation"]]
    gm = raw.get("generalised_mass")
    if normalisation == "generalised_mass":
        if gm is None:
            raise BridgeflapInputError("structure.generalised_mass",
                                       "missing (normalisation = \"generalised_mass\")")
        gm = gm * UNIT_FACTORS["mass"][units["mass"]]
    else:
        if gm is not None and not np.allclose(gm, 1.0, rtol=1e-9, atol=0):
            raise BridgeflapInputError("structure.generalised_mass",
                                       "normalisation = \"mass\" but the file gives "
                                       "generalised masses other than 1")
        gm = np.ones(n_m)
    if "damping_ratio" not in raw:
        raise BridgeflapInputError("structure.damping_ratio", "missing in the file")
    sign = 1.0 if vertical_positive == "down" else -1.0
    shapes = {"vertical": sign * lf * raw["vertical"], "torsional": rf * raw["torsional"]}
    if "lateral" in raw:
        shapes["lateral"] = lf * raw["lateral"]
    shapes = {k: (v.reshape(-1, 1) if v.ndim == 1 and n_m == 1 else v) for k, v in shapes.items()}
    return ModalData(
        station_x_m=lf * raw["station_x"],
        frequency_hz=raw["frequency"] * UNIT_FACTORS["frequency"][units["frequency"]],
        damping_ratio=raw["damping_ratio"], generalised_mass=gm, shapes=shapes,
        labels=tuple(raw.get("label", ())), source=raw["source"],
        families=tuple(raw.get("family", ())))


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
        file=path(f), units=tuple(sorted(_units(table.get("units")).items())),
        normalisation=table.get("normalisation", "mass"),
        vertical_positive=table.get("vertical_positive", "down"),
        modes_file=None if mf is None else path(mf), deck_segments_m=segs,
        strip_length_m=num("strip_length_m"),
        main_span_m=None if main is None else pair(main, "main_span_m"),
        mass_kg_per_m=num("mass_kg_per_m"),
        mass_inertia_kgm2_per_m=num("mass_inertia_kgm2_per_m"),
        mass_check_tolerance=0.05 if tol is None else tol, source=table.get("source", ""))


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


@dataclass(frozen=True)
class ModalDeck:
    """Deck of a modal bridge: only what the aerodynamics needs."""

    half_chord_m: float
    bridge: str = ""

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

    A :class:`model.spec.BridgeSpec` (``isinstance`` works) with ``structure`` set; the
    cable, the mesh and the FE deck properties raise one-line input errors, erection stages
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


def _builtin_dir(origin: str) -> Path | None:
    files = getattr(sm, "BUILTIN_FILES", {})
    if origin in files:
        return Path(str(resources.files("model.bridges").joinpath(files[origin]))).parent
    return None


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
    base = _builtin_dir(origin)
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
               mesh=_FEOnly(name, "the FE mesh"), sources=sources, structure=structure,
               description=str(data.get("description", "")))
    variants = data.get("variants", {})
    if variant is None:
        return spec
    if not isinstance(variants, dict) or variant not in variants:
        raise BridgeflapInputError("bridge", f"unknown variant {variant!r} of {name!r}")
    changes = {}
    for path, raw in variants[variant].items():
        if path == "description":
            continue
        if isinstance(raw, dict):
            sources[path] = f"variant {variant}: {raw.get('source', 'not stated')}"
            raw = raw.get("value")
        if isinstance(raw, bool) or not isinstance(raw, int | float):
            raise BridgeflapInputError(f"variants.{variant}.{path}", "must be a number")
        changes[path] = float(raw)
    return dataclasses.replace(spec.replace(**changes), name=f"{name}:{variant}")


# ----------------------------------------------------------------------- the modal model


@dataclass(frozen=True)
class ImportedStructure:
    """What :func:`model.fe.assemble` returns for a modal bridge: the strips and the data.

    FE-only attributes (``statics``, ``families``, ``elements``) raise one-line input errors.
    """

    spec: object
    strip_x: np.ndarray          # [m] from the start of the first deck segment
    strip_length: np.ndarray     # [m]

    @property
    def main_span(self) -> int:
        """Index of the main span (of :attr:`spec`'s spans)."""
        return self.spec.main_span_index

    def global_x(self, span, x):
        """Identity on strip positions (they are already measured along the whole deck)."""
        return np.asarray(x)

    @property
    def statics(self):
        """Refused: cable statics need the cable model."""
        raise _needs_fe(self.spec.name, "cable statics")

    @property
    def families(self):
        """Refused: FE matrices need the FE model."""
        raise _needs_fe(self.spec.name, "the FE matrices")

    @property
    def elements(self):
        """Refused: the FE mesh needs the FE model."""
        raise _needs_fe(self.spec.name, "the FE mesh")

    def modal_model(self, count: int | None = None) -> ImportedModalModel:
        """The :class:`ImportedModalModel` (lowest ``count`` modes of each family)."""
        return _modal_model(self, count)


def imported_structure(spec) -> ImportedStructure:
    """The strips of a :class:`ModalBridgeSpec` (the :func:`model.fe.assemble` hook)."""
    sx, sl = spec.structure.strips()
    return ImportedStructure(spec=spec, strip_x=sx - spec.structure.deck_segments_m[0][0],
                             strip_length=sl)


@dataclass(frozen=True)
class ImportedModalModel:
    """An imported modal model with the interface of :class:`model.modes.ModalModel`.

    Attributes
    ----------
    modes : tuple of model.modes.Mode
        Sorted by frequency; labels from the file, else ``VS1``-style from the shapes.
    order : tuple of int
        Column of :attr:`ModalStructure.data` of each entry of ``modes``.
    strip_shapes : dict
        ``family -> (n_strip, n_m)`` in file column order.
    mass_check : list of dict
        :meth:`ModalStructure.mass_check`.
    """

    structure: ImportedStructure
    modes: tuple
    order: tuple
    strip_shapes: dict
    mass_check: list

    @property
    def spec(self):
        """The bridge definition."""
        return self.structure.spec

    @property
    def rayleigh(self):
        """Refused: an imported model carries its damping ratios per mode."""
        raise _needs_fe(self.spec.name, "Rayleigh damping coefficients")

    def table(self) -> list[dict]:
        """Modes as JSON-ready dicts, sorted by frequency."""
        return [m.as_dict() for m in self.modes]

    def find(self, label: str):
        """The mode with a label such as ``"TS1"``."""
        for m in self.modes:
            if m.label == label:
                return m
        raise BridgeflapError(f"no mode {label} in the imported set")

    def structural_basis(self, count: int) -> StructuralBasis:
        """The lowest ``count`` vertical and torsional modes as generalised coordinates.

        ``M = diag(M_j)``, ``K = diag(M_j omega_j^2)``, ``C = diag(2 zeta_j omega_j M_j)``
        with the generalised masses ``M_j`` (1 for mass-normalised shapes, which then gives
        exactly the FE path's basis); lateral modes are left out as in the FE path.
        """
        if count < 1:
            raise BridgeflapInputError("modes", f"at least one mode is needed, got {count}")
        d = self.structure.spec.structure.data
        chosen = [i for i, m in enumerate(self.modes)
                  if m.family in ("vertical", "torsional")][:count]
        cols = [self.order[i] for i in chosen]
        gm = d.generalised_mass[cols]
        omega = 2 * np.pi * np.array([self.modes[i].frequency_hz for i in chosen])
        zeta = np.array([self.modes[i].damping_ratio for i in chosen])
        st = self.structure
        return StructuralBasis(
            M=np.diag(gm), C=np.diag(2 * zeta * omega * gm), K=np.diag(gm * omega ** 2),
            phi_h=self.strip_shapes["vertical"][:, cols],
            phi_a=self.strip_shapes["torsional"][:, cols],
            strip_length=st.strip_length, strip_x=st.strip_x,
            labels=tuple(self.modes[i].label for i in chosen))

    def plot(self, labels=None, ax=None):
        """Deck shapes (own family) of the first modes along the deck, normalised."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(9, 4))
        d = self.spec.structure.data
        labels = labels or [m.label for m in self.modes[:6]]
        for k, lab in enumerate(labels):
            i = self.modes.index(self.find(lab))
            y = d.shapes[self.modes[i].family][:, self.order[i]]
            ax.plot(d.station_x_m, y / (np.max(np.abs(y)) or 1.0), color=f"C{k}",
                    label=f"{lab} {self.modes[i].frequency_hz:.3f} Hz")
        ax.set_xlabel("x along the deck (file coordinates) [m]")
        ax.set_ylabel("normalised deck displacement [-]")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        ax.set_title(f"{self.spec.name}: imported mode shapes")
        return ax


def _symmetry(x, y, span) -> tuple[str, float]:
    """Symmetric/antisymmetric about the main-span mid-point, and the main-span share."""
    a, b = span
    sel = (x >= a - 1e-9) & (x <= b + 1e-9)
    total = float(np.trapezoid(y ** 2, x))
    if sel.sum() < 2 or total <= 0:
        return "symmetric", 0.0
    xs, ys = x[sel], y[sel]
    corr = float(np.dot(ys, np.interp(a + b - xs, xs, ys)))
    share = float(np.trapezoid(ys ** 2, xs)) / total
    return ("symmetric" if corr >= 0 else "antisymmetric"), share


def _modal_model(st: ImportedStructure, count: int | None) -> ImportedModalModel:
    ms = st.spec.structure
    d = ms.data
    fams = ms.families()
    order = sorted(range(d.n_modes), key=lambda j: (float(d.frequency_hz[j]), j))
    if count is not None:
        seen: dict = {}
        kept = []
        for j in order:
            seen[fams[j]] = seen.get(fams[j], 0) + 1
            if seen[fams[j]] <= count:
                kept.append(j)
        order = kept
    counters: dict = {}
    modes = []
    for j in order:
        sym, share = _symmetry(d.station_x_m, d.shapes[fams[j]][:, j], ms.main_span_m)
        counters[(fams[j], sym)] = counters.get((fams[j], sym), 0) + 1
        label = d.labels[j] if d.labels and d.labels[j] else ""
        mode = Mode(fams[j], sym, float(d.frequency_hz[j]), float(d.damping_ratio[j]),
                    counters[(fams[j], sym)], share)
        if label and label != mode.label:
            mode = _LabelledMode(**dataclasses.asdict(mode), given_label=label)
        modes.append(mode)
    labels = [m.label for m in modes]
    dup = sorted({lab for lab in labels if labels.count(lab) > 1})
    if dup:
        raise BridgeflapInputError("structure.label", f"duplicate mode label {dup[0]!r}")
    return ImportedModalModel(structure=st, modes=tuple(modes), order=tuple(order),
                              strip_shapes=ms.strip_shapes(), mass_check=ms.mass_check())


@dataclass(frozen=True)
class _LabelledMode(Mode):
    """A mode whose label comes from the imported file."""

    given_label: str = ""

    @property
    def label(self) -> str:
        """The file's label."""
        return self.given_label


# ------------------------------------------------------------------------------- export


def export_modal(modal, path, count: int | None = None) -> Path:
    """Write the deck shapes of an FE :class:`model.modes.ModalModel` as a modal file.

    The stations are the FE model's aerodynamic strip mid-points (x from the first span's
    start), so that re-importing with ``deck_segments_m`` = the decked spans and the FE strip
    length reproduces the FE strips exactly. Mass-normalised shapes (``generalised_mass`` 1),
    SI units, heave positive down. ``.npz``, ``.json`` or ``.csv`` (plus ``<stem>_modes.csv``)
    by the suffix. Returns the path written.
    """
    st = modal.structure
    x = st.global_x(st.strip_span, st.strip_x)
    sel = [i for i, m in enumerate(modal.modes) if m.family in ("vertical", "torsional")]
    if count is not None:
        sel = sel[:count]
    n_s = x.size
    vert, tors = np.zeros((n_s, len(sel))), np.zeros((n_s, len(sel)))
    for j, i in enumerate(sel):
        m = modal.modes[i]
        v = st.families[m.family].strip_map @ modal.shape(i)
        (vert if m.family == "vertical" else tors)[:, j] = v
    arrays = {"station_x": x, "frequency": np.array([modal.modes[i].frequency_hz for i in sel]),
              "damping_ratio": np.array([modal.modes[i].damping_ratio for i in sel]),
              "generalised_mass": np.ones(len(sel)), "vertical": vert, "torsional": tors,
              "label": np.array([modal.modes[i].label for i in sel])}
    path = Path(path)
    suffix = path.suffix.lower()
    units = {"frequency": "Hz", "length": "m", "rotation": "rad", "mass": "kg"}
    if suffix == ".npz":
        np.savez(path, **arrays, units=np.array(json.dumps(units)),
                 source=np.array(f"bridgeflap FE modes of {modal.spec.name}"))
    elif suffix == ".json":
        out = {k: v.tolist() for k, v in arrays.items()}
        out.update(units=units, source=f"bridgeflap FE modes of {modal.spec.name}")
        path.write_text(json.dumps(out), "utf-8")
    elif suffix == ".csv":
        labels = list(arrays["label"])
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["station_x"] + [f"vertical:{lab}" for lab in labels]
                       + [f"torsional:{lab}" for lab in labels])
            for r in range(n_s):
                w.writerow([repr(float(x[r]))] + [repr(float(v)) for v in vert[r]]
                           + [repr(float(v)) for v in tors[r]])
        with path.with_name(path.stem + "_modes.csv").open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["label", "frequency", "damping_ratio", "generalised_mass"])
            for j, lab in enumerate(labels):
                w.writerow([lab, repr(float(arrays["frequency"][j])),
                            repr(float(arrays["damping_ratio"][j])), "1.0"])
    else:
        raise BridgeflapInputError("path", f"unsupported type {suffix!r} (.npz, .json, .csv)")
    return path


def compare_modes(modal, reference, share_min: float = 0.5) -> list[dict]:
    """Pair the main-span modes of two modal models by (family, symmetry, order) and compare.

    Main-span modes (``main_span_share > share_min``) of each model, in frequency order
    within (family, symmetry); the ``k``-th of one is paired with the ``k``-th of the other.
    Rows: ``label`` (the reference's main-span label, e.g. ``VA2`` for the second main-span
    antisymmetric vertical mode), ``reference_hz``, ``model_hz``, ``ratio`` (model/reference),
    ``model_label``. Modes without a partner are left out.
    """
    def main_modes(mm):
        out: dict = {}
        for m in sorted(mm.modes, key=lambda m: m.frequency_hz):
            if m.main_span_share > share_min:
                out.setdefault((m.family, m.symmetry), []).append(m)
        return out

    ours, ref = main_modes(modal), main_modes(reference)
    rows = []
    for key, rmodes in ref.items():
        for k, r in enumerate(rmodes):
            mine = ours.get(key, [])
            if k >= len(mine):
                continue
            label = f"{key[0][0].upper()}{key[1][0].upper()}{k + 1}"
            rows.append({"label": label, "family": key[0], "symmetry": key[1],
                         "reference_hz": r.frequency_hz, "model_hz": mine[k].frequency_hz,
                         "ratio": mine[k].frequency_hz / r.frequency_hz,
                         "model_label": mine[k].label})
    return sorted(rows, key=lambda r: r["reference_hz"])
