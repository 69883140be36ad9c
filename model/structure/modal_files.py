"""Modal data files: reading, checking and writing (``.npz`` without pickles, JSON, CSV).

The file formats and units are in docs/modal_import.md#files; :func:`read_modal_file` returns a
checked :class:`ModalData` in SI units (heave positive down, :mod:`bridgeflap.model`), and
:func:`export_modal` writes the modes of an FE model in the same formats. The bridge-definition
side is :mod:`bridgeflap.model.structure.modal_import`.
"""

from __future__ import annotations

import csv
import json
import math
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["FAMILIES", "FREQUENCY_RANGE_HZ", "NORMALISATIONS", "UNIT_FACTORS", "ModalData",
           "export_modal", "needs_fe", "read_modal_file", "read_polimi_derivatives",
           "units_from_table"]

FAMILIES = ("vertical", "torsional", "lateral")
UNIT_FACTORS = {
    "frequency": {"Hz": 1.0, "rad/s": 1.0 / (2 * math.pi)},   # to Hz
    "length": {"m": 1.0, "mm": 1e-3},                           # to m (stations, v and l shapes)
    "rotation": {"rad": 1.0, "deg": math.pi / 180.0},          # to rad (torsional shapes)
    "mass": {"kg": 1.0, "t": 1e3},                              # to kg (generalised masses)
}
NORMALISATIONS = ("mass", "generalised_mass")
#: plausible natural frequencies of a bridge mode [Hz]: the first mode of the longest span built
#: (Akashi Kaikyo, 1991 m) is near 0.03 Hz and deck modes of interest for flutter and buffeting
#: are below about 10 Hz; 1e-4 Hz (a 2.8-hour period) to 1e3 Hz is two orders of magnitude
#: outside both, and keeps omega^2 and 1/omega finite in the modal matrices (1e300 Hz overflows)
FREQUENCY_RANGE_HZ = (1.0e-4, 1.0e3)
_FILE_KEYS = {"station_x", "frequency", "damping_ratio", "generalised_mass", "vertical",
              "torsional", "lateral", "label", "family", "units", "source", "provenance"}


def needs_fe(name: str, what: str) -> BridgeflapInputError:
    """The one-line error of an analysis that needs the cable/FE model on a modal bridge."""
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
        lo, hi = FREQUENCY_RANGE_HZ
        out = np.flatnonzero((np.asarray(self.frequency_hz) < lo)
                             | (np.asarray(self.frequency_hz) > hi))
        if out.size:
            j = int(out[0])
            raise BridgeflapInputError(
                "structure.frequency", f"mode {j + 1}: {float(self.frequency_hz[j]):g} Hz is "
                f"outside the plausible range [{lo:g}, {hi:g}] Hz of a bridge mode")
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


def units_from_table(raw) -> dict:
    """The ``units`` table of a ``[structure]`` section, checked (docs/modal_import.md#units)."""
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
    if not hasattr(d, "keys"):
        raise BridgeflapInputError("structure.file", f"{name} must hold an object of named "
                                   f"arrays (docs/modal_import.md#files), got "
                                   f"{type(d).__name__}")
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
        try:
            u = json.loads(str(np.asarray(u))) if not isinstance(u, dict) else u
        except ValueError:
            u = None
        if not isinstance(u, dict):
            raise BridgeflapInputError("structure.units", f"{name} states units that are not "
                                       "a table such as {\"frequency\": \"Hz\", ...}, got "
                                       f"{d['units']!r}"[:200])
        out["units"] = u
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
    suffix = path.suffix.lower()
    try:
        if not path.is_file():  # inside: a name beyond NAME_MAX raises OSError
            raise BridgeflapInputError("structure.file", f"file not found: {path}")
        if suffix == ".npz":
            # an open file of our own: np.load leaks its handle when the zip is bad
            with path.open("rb") as fh:
                z = np.load(fh, allow_pickle=False)
                if not hasattr(z, "files"):
                    raise BridgeflapInputError("structure.file", f"{path.name} holds one .npy "
                                               "array, not an .npz archive of named arrays")
                with z:
                    raw = _table_from_mapping({k: z[k] for k in z.files}, path.name, str(path))
        elif suffix == ".json":
            raw = _table_from_mapping(json.loads(path.read_text("utf-8")), path.name, str(path))
        elif suffix == ".csv":
            raw = _read_csv(path, None if modes_file is None else Path(modes_file))
        else:
            raise BridgeflapInputError("structure.file",
                                       f"unsupported type {suffix!r} (use .npz, .json or .csv)")
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        if isinstance(exc, BridgeflapInputError):
            raise
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
        raise BridgeflapInputError("structure.file", f"cannot read {path}: "
                                   f"{type(exc).__name__}: {why}") from None
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


# ------------------------------------------------------------------------------- export


def export_modal(modal, path, count: int | None = None) -> Path:
    """Write the deck shapes of an FE :class:`bridgeflap.model.structure.modes.ModalModel` as a
    modal file.

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


# ------------------------------------------------------------------- derivative tables

#: PoliMi columns whose conversion to Scanlan form differs between the IABSE 1.1c functions
#: (model.aero.derivatives.polimi_to_scanlan: pi/2) and the step-2a "BB3" file's own statement
#: (factor 1): they must be zero in a BB3-form file, so that the two readings agree
_AMBIGUOUS_POLIMI = {"h": (5,), "a": (5,), "p": (3, 5)}


def read_polimi_derivatives(path, chord_m: float, field_name: str = "derivatives.file"):
    """PoliMi flutter-derivative tables of the IABSE step-2a "BB3" form (plain JSON).

    The file (``model/bridges/iabse/step2a_bb3_derivatives.json``) gives ``v_heave`` and
    ``v_pitch`` (reduced velocities ``U / (omega B)``, increasing), ``abscissa_of_column``
    (which of the two each of the 6 ``h``/``a`` columns is tabulated on; ``p`` is on
    ``v_pitch``) and ``polimi`` ``{"h", "a", "p"}`` tables (rows = reduced velocities, 6
    columns). Returns a :class:`bridgeflap.model.aero.derivatives.PolimiDerivatives` (linear
    interpolation of the PoliMi coefficients in ``v``, end values held, then
    :func:`bridgeflap.model.aero.derivatives.polimi_to_scanlan`) with ``lateral=True`` when ``p`` or
    the lateral ``h``/``a`` columns are non-zero.

    Raises
    ------
    BridgeflapInputError
        Missing file or key, tables of the wrong size, NaN, axes not positive and increasing,
        non-zero columns whose conversion is ambiguous (``h6``, ``a6``, ``p4``, ``p6``).
    """
    from bridgeflap.model.aero.derivatives import PolimiDerivatives

    path = Path(path)
    if not path.is_file():
        raise BridgeflapInputError(field_name, f"file not found: {path}")
    try:
        d = json.loads(path.read_text("utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise BridgeflapInputError(field_name, f"malformed JSON in {path}: {exc}") from None
    if not isinstance(d, dict):
        raise BridgeflapInputError(field_name, "must be a JSON object")
    axes = {}
    for key in ("v_heave", "v_pitch"):
        try:
            v = np.asarray(d[key], float)
        except KeyError:
            raise BridgeflapInputError(f"derivatives.{key}", f"missing in {path.name}") from None
        except (TypeError, ValueError):
            raise BridgeflapInputError(f"derivatives.{key}", "not numeric") from None
        if (v.ndim != 1 or v.size < 2 or not np.all(np.isfinite(v)) or np.any(v <= 0)
                or np.any(np.diff(v) <= 0)):
            raise BridgeflapInputError(f"derivatives.{key}", "must be at least two positive, "
                                       "strictly increasing reduced velocities")
        axes[key] = v
    if axes["v_heave"].size != axes["v_pitch"].size:
        raise BridgeflapInputError("derivatives.v_heave", "must have as many points as v_pitch")
    cols = d.get("abscissa_of_column")
    if (not isinstance(cols, list) or len(cols) != 6
            or any(c not in axes for c in cols)):
        raise BridgeflapInputError("derivatives.abscissa_of_column",
                                   "must list 6 of 'v_heave' / 'v_pitch'")
    tabs = {}
    n = axes["v_pitch"].size
    pol = d.get("polimi")
    if not isinstance(pol, dict):
        raise BridgeflapInputError("derivatives.polimi", f"missing in {path.name}")
    for fam in "hap":
        try:
            t = np.asarray(pol[fam], float)
        except KeyError:
            raise BridgeflapInputError(f"derivatives.polimi.{fam}", "missing") from None
        except (TypeError, ValueError):
            raise BridgeflapInputError(f"derivatives.polimi.{fam}", "not numeric") from None
        if t.shape != (n, 6):
            raise BridgeflapInputError(f"derivatives.polimi.{fam}", f"is {t.shape}, expected "
                                       f"({n}, 6): one row per reduced velocity")
        if not np.all(np.isfinite(t)):
            raise BridgeflapInputError(f"derivatives.polimi.{fam}", "contains NaN or inf")
        for i in _AMBIGUOUS_POLIMI[fam]:
            if np.any(t[:, i] != 0):
                raise BridgeflapInputError(f"derivatives.polimi.{fam}{i + 1}",
                                           "must be zero (its Scanlan conversion is ambiguous)")
        tabs[fam] = t
    lateral = bool(np.any(tabs["p"]) or np.any(tabs["h"][:, 4:]) or np.any(tabs["a"][:, 4:]))
    every = np.concatenate(list(axes.values()))
    return PolimiDerivatives(
        float(chord_m), path.stem, f"{path.name} (PoliMi form; provenance in the file)",
        (float(1 / every.max()), float(1 / every.min())), lateral,
        tuple(axes["v_pitch"].tolist()),
        {f: tuple(map(tuple, t.tolist())) for f, t in tabs.items()},
        tuple(tuple(axes[c].tolist()) for c in cols))
