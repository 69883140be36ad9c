"""Built-in section cases with flutter derivatives: the IABSE TG3.1 steps 1.1a and 1.1c.

A case is a rigid deck section (2 DOF heave/pitch, or 3 DOF with the lateral) on uniform
damping, with a derivative source (:mod:`bridgeflap.model.aero.derivatives`), shipped as plain JSON
and CSV under ``model/bridges/iabse/`` with its provenance (``README.md`` there). Loadable by name:
:func:`load_section_case` (``"iabse-1.1a"``, ``"iabse-1.1c"``) and analysed by
:func:`section_case_flutter` (Roger-RFA eigenvalue sweep and exact p-k on the same structure).

Coordinates: the package's (heave down, pitch nose-up, lateral downwind); the structure of
these cases is diagonal, so the heave sign does not change its matrices.
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass
from importlib import resources

import numpy as np

from bridgeflap.model.aero.basis import StructuralBasis
from bridgeflap.model.aero.derivatives import (
    FlutterDerivatives,
    PolimiDerivatives,
    RogerFit,
    fit_roger,
    flat_plate,
)
from bridgeflap.model.aeroelastic.derivative_system import derivative_system
from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["SECTION_CASES", "SectionCase", "case_fit", "case_system", "default_speeds",
           "load_section_case", "section_case_flutter", "section_system"]

SECTION_CASES: tuple[str, ...] = ("iabse-1.1a", "iabse-1.1c")
"""Names accepted by :func:`load_section_case`."""

_FOLDER = "iabse"


@dataclass(frozen=True)
class SectionCase:
    """A section case: structure, derivatives, air density and the reference result."""

    name: str
    title: str
    basis: StructuralBasis
    phi_p: np.ndarray | None
    derivatives: FlutterDerivatives
    air_density: float
    reference_speed_m_s: float
    reference: dict
    provenance: str


def _read(name: str) -> str:
    return resources.files("bridgeflap.model.bridges").joinpath(_FOLDER, name).read_text("utf-8")


def _polimi_table(text: str, chord_m: float, origin: str) -> PolimiDerivatives:
    rows = list(csv.DictReader(io.StringIO(
        "\n".join(line for line in text.splitlines() if not line.startswith("#")))))
    try:
        v = np.array([float(r["v_omega"]) for r in rows])
        tabs = {f: np.array([[float(r[f"{f}{i}"]) for i in range(1, 7)] for r in rows])
                for f in "hap"}
    except (KeyError, TypeError, ValueError):
        raise BridgeflapInputError("derivatives.file", "needs numeric columns v_omega, h1..h6, "
                                   "a1..a6, p1..p6") from None
    if v.size < 2 or np.any(np.diff(v) <= 0) or np.any(v <= 0):
        raise BridgeflapInputError("derivatives.v_omega", "must be positive and increasing")
    if any(np.any(~np.isfinite(t)) for t in tabs.values()):
        raise BridgeflapInputError("derivatives.file", "contains NaN or inf")
    return PolimiDerivatives(chord_m, "storebaelt-polimi" if "storebaelt" in origin else
                             "polimi-table", f"{origin} (PoliMi form)",
                             (float(1 / v.max()), float(1 / v.min())), True, tuple(v.tolist()),
                             {f: tuple(map(tuple, t.tolist())) for f, t in tabs.items()})


def _field(d: dict, key: str, where: str = ""):
    if key not in d:
        raise BridgeflapInputError(f"{where}{key}", "missing")
    return d[key]


def _vector(d: dict, key: str, n: int) -> np.ndarray:
    try:
        v = np.asarray(_field(d, key), float)
    except (TypeError, ValueError):
        raise BridgeflapInputError(key, "not numeric") from None
    if v.shape != (n,) or np.any(~np.isfinite(v)) or np.any(v <= 0):
        raise BridgeflapInputError(key, f"needs {n} positive finite values (one per DOF)")
    return v


def _scanlan_table(text: str, spec: dict, chord_m: float, origin: str) -> FlutterDerivatives:
    from bridgeflap.model.aero.derivatives import ARGUMENT_KINDS, DERIVATIVE_NAMES, tabulated

    arg = _field(spec, "argument", "derivatives.")
    if arg not in ARGUMENT_KINDS:
        raise BridgeflapInputError("derivatives.argument", f"must be one of {ARGUMENT_KINDS}")
    rows = list(csv.DictReader(io.StringIO(
        "\n".join(line for line in text.splitlines() if not line.startswith("#")))))
    if not rows or arg not in rows[0]:
        raise BridgeflapInputError("derivatives.file", f"needs a column {arg!r}")

    def col(name):
        try:
            return [float(r[name]) if r[name] not in ("", None) else float("nan") for r in rows]
        except ValueError:
            raise BridgeflapInputError(f"derivatives.{name}", "not numeric") from None

    data = {n: col(n) for n in DERIVATIVE_NAMES if n in rows[0]}
    return tabulated(col(arg), data, chord_m, name="table", source=origin, argument=arg)


def load_section_case(name: str, added_inertia: bool | None = None) -> SectionCase:
    """Load a section case: a built-in name (:data:`SECTION_CASES`) or a ``.json`` file.

    The file has the fields of ``model/bridges/iabse/iabse-1.1a.json``: ``dofs`` (``heave``,
    ``pitch``, optional ``lateral``), ``mass_kg_per_m`` and ``stiffness_n_per_m2`` per DOF,
    ``damping_ratio``, ``chord_m``, ``air_density_kg_m3``, ``derivatives`` (``{"kind":
    "flat-plate", "added_inertia": bool}``, ``{"kind": "polimi-table", "file": ...}`` or
    ``{"kind": "scanlan-table", "file": CSV, "argument": "K" | "v" | "vred_hz" |
    "k_half"}`` with one column per derivative ``H1``...``P6``, files relative to the JSON)
    and optionally ``title``, ``reference`` (``flutter_speed_m_s``, ``convention``) and
    ``provenance``. ``added_inertia`` overrides a flat plate's convention (1.1a: ``False`` is
    the reference's own, ``True`` keeps the apparent-inertia moment).

    Raises
    ------
    BridgeflapInputError
        Unknown name, missing file or field, non-physical value, inconsistent table.
    """
    from pathlib import Path

    name = str(name)
    if name in SECTION_CASES:
        d = json.loads(_read(f"{name}.json"))

        def read(file):
            return _read(file), f"model/bridges/iabse/{file}"
    elif name.lower().endswith(".json"):
        path = Path(name)
        if not path.is_file():
            raise BridgeflapInputError("bridge", f"file not found: {path}")
        try:
            d = json.loads(path.read_text("utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise BridgeflapInputError("bridge", f"malformed JSON in {path}: {exc}") from None

        def read(file):
            f = path.parent / file
            if not f.is_file():
                raise BridgeflapInputError("derivatives.file", f"file not found: {f}")
            return f.read_text("utf-8"), str(f)
    else:
        raise BridgeflapInputError("bridge", f"unknown section case {name!r} (built-in: "
                                   f"{', '.join(SECTION_CASES)}; or a .json file)")
    dofs = tuple(_field(d, "dofs"))
    if (len(set(dofs)) != len(dofs) or not {"heave", "pitch"} <= set(dofs)
            or not set(dofs) <= {"heave", "pitch", "lateral"}):
        raise BridgeflapInputError("dofs", "must be heave and pitch, optionally lateral, once")
    n = len(dofs)
    m = _vector(d, "mass_kg_per_m", n)
    k = _vector(d, "stiffness_n_per_m2", n)
    zeta = float(_field(d, "damping_ratio"))
    if not (np.isfinite(zeta) and 0 <= zeta < 1):
        raise BridgeflapInputError("damping_ratio", f"must be in [0, 1), got {zeta}")
    B = float(_field(d, "chord_m"))
    rho = float(_field(d, "air_density_kg_m3"))
    for key, v in (("chord_m", B), ("air_density_kg_m3", rho)):
        if not (np.isfinite(v) and v > 0):
            raise BridgeflapInputError(key, f"must be positive, got {v}")
    M, K = np.diag(m), np.diag(k)
    C = np.diag(2 * zeta * np.sqrt(k * m))
    sel = {lab: np.eye(n)[[dofs.index(lab)]] if lab in dofs else None
           for lab in ("heave", "pitch", "lateral")}
    basis = StructuralBasis(M=M, C=C, K=K, phi_h=sel["heave"], phi_a=sel["pitch"],
                            strip_length=np.array([1.0]), strip_x=np.array([0.0]),
                            labels=dofs)
    spec = _field(d, "derivatives")
    kind = _field(spec, "kind", "derivatives.")
    if kind != "flat-plate" and added_inertia is not None:
        raise BridgeflapInputError("added_inertia", "applies to flat-plate cases only")
    if kind == "flat-plate":
        ai = bool(spec.get("added_inertia", False)) if added_inertia is None else added_inertia
        source = flat_plate(B, bool(ai))
    elif kind == "polimi-table":
        text, origin = read(_field(spec, "file", "derivatives."))
        source = _polimi_table(text, B, origin)
    elif kind == "scanlan-table":
        text, origin = read(_field(spec, "file", "derivatives."))
        source = _scanlan_table(text, spec, B, origin)
    else:
        raise BridgeflapInputError("derivatives.kind", f"unknown {kind!r} (flat-plate, "
                                   "polimi-table, scanlan-table)")
    ref = d.get("reference", {})
    return SectionCase(str(d.get("name", name)), str(d.get("title", name)), basis, sel["lateral"],
                       source, rho, float(ref.get("flutter_speed_m_s", float("nan"))),
                       {"convention": "", **ref}, str(d.get("provenance", "")))


def default_speeds(case: SectionCase) -> np.ndarray:
    """``0 .. 2 x reference`` in 401 points, or ``0 .. 20 (B/2) omega_max`` without one [m/s]."""
    if np.isfinite(case.reference_speed_m_s):
        return np.linspace(0.0, 2.0 * case.reference_speed_m_s, 401)
    w = np.sqrt(np.max(np.diag(case.basis.K) / np.diag(case.basis.M)))
    return np.linspace(0.0, 20 * 0.5 * case.derivatives.chord_m * w, 401)


def case_fit(case: SectionCase, n_lags: int | None = None, weighting: str | None = None
             ) -> RogerFit:
    """The Roger RFA used for a case.

    Flat plate: 4 lags on ``K`` in [0.01, 6] (the range of
    :func:`bridgeflap.model.aero.rfa.fit_theodorsen` doubled, ``K = 2k``). Scanlan tables: 2 lags on
    the table's range (held end values of Scanlan derivatives, which grow like ``1/K`` or ``1/K^2``,
    are not physical). PoliMi tables: 2 lags on ``K`` from two thirds of the table's lowest value to
    its highest: the lateral mode's ``K`` at flutter (0.14 for 1.1c) lies below the table (0.18),
    where the reference's evaluation holds the end values of the (normalised) PoliMi coefficients,
    as
    :class:`~bridgeflap.model.aero.derivatives.PolimiDerivatives` does.
    """
    src = case.derivatives
    d = 2 if case.phi_p is None else 3  # a 2-DOF section ignores lateral derivatives
    w = "derivative" if weighting is None else weighting
    if src.name == "flat-plate":
        return fit_roger(src, n_lags=4 if n_lags is None else n_lags, n_dof=d,
                         k_range=(0.01, 6.0), weighting=w)
    lo, hi = src.k_range
    if isinstance(src, PolimiDerivatives):
        lo = lo / 1.5
    return fit_roger(src, n_lags=2 if n_lags is None else n_lags, n_dof=d, k_range=(lo, hi),
                     weighting=w)


def case_system(case: SectionCase, n_lags: int | None = None, weighting: str | None = None):
    """``(system, fit)``: the case's Roger-RFA state space on its fit (:func:`case_fit`)."""
    fit = case_fit(case, n_lags, weighting)
    return derivative_system(case.basis, case.derivatives, case.air_density, fit=fit,
                             phi_p=case.phi_p), fit


def section_system(name: str, added_inertia: bool | None = None):
    """``(system, speeds [m/s])`` of a section case by name or ``.json`` path
    (:func:`load_section_case`): its Roger-RFA state space on the default fit and
    :func:`default_speeds`. The one builder of the named cases for the benchmarks
    (``bench/``) and the tests, which run against the installed wheel without ``bench/``."""
    case = load_section_case(name, added_inertia)
    return case_system(case)[0], default_speeds(case)


def section_case_flutter(case: SectionCase, speeds=None, n_lags: int | None = None,
                         speed_tol: float = 1e-6, weighting: str | None = None) -> dict:
    """Flutter of a case: Roger-RFA eigenvalue sweep and exact p-k (JSON-ready dict)."""
    from bridgeflap.model.stability import sweeps as stability

    if speeds is None:
        speeds = default_speeds(case)
    system, fit = case_system(case, n_lags, weighting)
    sw = stability.sweep(system, speeds, speed_tol=speed_tol)
    pk = stability.pk_sweep(system, speeds, speed_tol=speed_tol)
    ref = case.reference_speed_m_s

    def rel(u):
        return float(u / ref - 1.0) if np.isfinite(u) else float("nan")

    return {
        "bridge": case.name,
        "derivatives": case.derivatives.name,
        "derivatives_source": case.derivatives.source,
        "reference_flutter_speed_m_s": ref,
        "reference_convention": case.reference["convention"],
        "rfa_flutter_speed_m_s": sw.flutter.speed,
        "rfa_flutter_frequency_hz": sw.flutter.frequency_hz,
        "rfa_flutter_status": sw.flutter.status,
        "rfa_relative_to_reference": rel(sw.flutter.speed),
        "pk_flutter_speed_m_s": pk.flutter.speed,
        "pk_flutter_frequency_hz": pk.flutter.frequency_hz,
        "pk_flutter_status": pk.flutter.status,
        "pk_relative_to_reference": rel(pk.flutter.speed),
        "rfa": fit.summary(),
        "n_states": system.n_states,
    }
