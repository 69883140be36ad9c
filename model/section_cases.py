"""Built-in section cases with flutter derivatives: the IABSE TG3.1 steps 1.1a and 1.1c.

A case is a rigid deck section (2 DOF heave/pitch, or 3 DOF with the lateral) on uniform
damping, with a derivative source (:mod:`model.derivatives`), shipped as plain JSON and CSV
under ``model/bridges/iabse/`` with its provenance (``README.md`` there). Loadable by name:
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

from model.basis import StructuralBasis
from model.derivatives import (
    FlutterDerivatives,
    PolimiDerivatives,
    RogerFit,
    derivative_system,
    fit_roger,
    flat_plate,
)
from model.errors import BridgeflapInputError

__all__ = ["SECTION_CASES", "SectionCase", "SectionCaseResult", "case_fit", "load_section_case",
           "section_case_flutter", "section_case_result"]

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
    return resources.files("model.bridges").joinpath(_FOLDER, name).read_text("utf-8")


def _polimi_table(file: str, chord_m: float) -> PolimiDerivatives:
    rows = [r for r in csv.DictReader(io.StringIO(
        "\n".join(line for line in _read(file).splitlines() if not line.startswith("#"))))]
    v = np.array([float(r["v_omega"]) for r in rows])
    tabs = {f: np.array([[float(r[f"{f}{i}"]) for i in range(1, 7)] for r in rows])
            for f in "hap"}
    if np.any(np.diff(v) <= 0):
        raise BridgeflapInputError("derivatives.v_omega", "must be strictly increasing")
    return PolimiDerivatives(chord_m, "storebaelt-polimi",
                             f"model/bridges/iabse/{file} (PoliMi form, wawi IABSE 1.1c data)",
                             (float(1 / v.max()), float(1 / v.min())), True, tuple(v.tolist()),
                             {f: tuple(map(tuple, t.tolist())) for f, t in tabs.items()})


def load_section_case(name: str, added_inertia: bool | None = None) -> SectionCase:
    """Load a built-in section case by name (:data:`SECTION_CASES`).

    ``added_inertia`` overrides the case's flat-plate convention (1.1a only: ``False`` is
    the reference's own, ``True`` keeps the apparent-inertia moment).
    """
    if name not in SECTION_CASES:
        raise BridgeflapInputError("bridge", f"unknown section case {name!r} (built-in: "
                                   f"{', '.join(SECTION_CASES)})")
    d = json.loads(_read(f"{name}.json"))
    m = np.asarray(d["mass_kg_per_m"], float)
    k = np.asarray(d["stiffness_n_per_m2"], float)
    zeta = float(d["damping_ratio"])
    B = float(d["chord_m"])
    dofs = tuple(d["dofs"])
    n = len(dofs)
    M, K = np.diag(m), np.diag(k)
    C = np.diag(2 * zeta * np.sqrt(k * m))
    sel = {lab: np.eye(n)[[dofs.index(lab)]] if lab in dofs else None
           for lab in ("heave", "pitch", "lateral")}
    basis = StructuralBasis(M=M, C=C, K=K, phi_h=sel["heave"], phi_a=sel["pitch"],
                            strip_length=np.array([1.0]), strip_x=np.array([0.0]),
                            labels=dofs)
    spec = d["derivatives"]
    if spec["kind"] == "flat-plate":
        ai = bool(spec["added_inertia"]) if added_inertia is None else bool(added_inertia)
        source = flat_plate(B, ai)
    elif spec["kind"] == "polimi-table":
        if added_inertia is not None:
            raise BridgeflapInputError("added_inertia", "applies to flat-plate cases only")
        source = _polimi_table(spec["file"], B)
    else:  # pragma: no cover - shipped data
        raise BridgeflapInputError("derivatives.kind", f"unknown {spec['kind']!r}")
    return SectionCase(name, d["title"], basis, sel["lateral"], source,
                       float(d["air_density_kg_m3"]), float(d["reference"]["flutter_speed_m_s"]),
                       d["reference"], d["provenance"])


def case_fit(case: SectionCase, n_lags: int | None = None, weighting: str | None = None
             ) -> RogerFit:
    """The Roger RFA used for a case.

    Flat plate: 4 lags on ``K`` in [0.01, 6] (the range of :func:`model.rfa.fit_theodorsen`
    doubled, ``K = 2k``). Tables: 2 lags on ``K`` from two thirds of the table's lowest value
    to its highest: the lateral mode's ``K`` at flutter (0.14 for 1.1c) lies below the table
    (0.18), where the reference's evaluation holds the end values, as
    :class:`~model.derivatives.PolimiDerivatives` does.
    """
    src = case.derivatives
    w = "derivative" if weighting is None else weighting
    if src.name == "flat-plate":
        return fit_roger(src, n_lags=4 if n_lags is None else n_lags, k_range=(0.01, 6.0),
                         weighting=w)
    lo, hi = src.k_range
    return fit_roger(src, n_lags=2 if n_lags is None else n_lags, k_range=(lo / 1.5, hi),
                     weighting=w)


def section_case_flutter(case: SectionCase, speeds=None, n_lags: int | None = None,
                         speed_tol: float = 1e-6, weighting: str | None = None) -> dict:
    """Flutter of a case: Roger-RFA eigenvalue sweep and exact p-k (JSON-ready dict)."""
    from model import stability

    if speeds is None:
        speeds = np.linspace(0.0, 2.0 * case.reference_speed_m_s, 401)
    fit = case_fit(case, n_lags, weighting)
    system = derivative_system(case.basis, case.derivatives, case.air_density, fit=fit,
                               phi_p=case.phi_p)
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


@dataclass(frozen=True)
class SectionCaseResult:
    """Flutter of a section case in the shape of :class:`model.analysis.FlutterResult`.

    ``summary()`` has the keys of the Humber ``flutter`` summary (the sweep of the Roger-RFA
    state space; ``critical_branch`` from the section's DOF labels) plus ``section_case``:
    the reference, the exact p-k on the derivatives and the RFA fit. ``plot()`` is the sweep's.
    """

    case: SectionCase
    sweep: object
    pk: object
    fit: RogerFit
    n_states: int

    def summary(self) -> dict:
        """JSON-ready numbers (units in the key names) and statuses."""
        from model.analysis import critical_speed

        s = self.sweep.summary()
        label = self.sweep.critical_branch
        fam = {"heave": "vertical", "pitch": "torsional", "lateral": "lateral"}.get(label, "")
        s.update(critical_speed(s))
        ref = self.case.reference_speed_m_s
        pk = self.pk.flutter
        s.update({"bridge": self.case.name, "erected_fraction": 1.0, "joints_closed": True,
                  "critical_branch": {"label": label, "family": fam, "symmetry": "",
                                      "span": "", "frequency_hz": float("nan")},
                  "modes_retained": self.case.basis.n, "order": "modal", "rfa": self.fit.name,
                  "states": self.n_states, "half_chord_m": 0.5 * self.case.derivatives.chord_m,
                  "added_inertia": bool(getattr(self.case.derivatives, "added_inertia", False)),
                  "section_case": {
                      "derivatives": self.case.derivatives.name,
                      "reference_flutter_speed_m_s": ref,
                      "reference_convention": self.case.reference["convention"],
                      "pk_flutter_speed_m_s": pk.speed,
                      "pk_flutter_frequency_hz": pk.frequency_hz,
                      "pk_flutter_status": pk.status,
                      "rfa_relative_to_reference": (float(self.sweep.flutter.speed / ref - 1)
                                                    if np.isfinite(self.sweep.flutter.speed)
                                                    else float("nan")),
                      "pk_relative_to_reference": (float(pk.speed / ref - 1)
                                                   if np.isfinite(pk.speed) else float("nan")),
                      **self.fit.summary()}})
        return s

    def plot(self, axes=None):
        """Root locus, damping and frequency of the RFA sweep."""
        return self.sweep.plot(axes, title=self.case.name)


def section_case_result(name: str, speeds=None, added_inertia: bool | None = None,
                        n_lags: int | None = None) -> SectionCaseResult:
    """:class:`SectionCaseResult` of a built-in case (the hook for ``flutter --bridge NAME``).

    ``speeds`` [m/s] default ``0 .. 2 x reference`` in 401 points.
    """
    from model import stability

    case = load_section_case(name, added_inertia)
    if speeds is None:
        speeds = np.linspace(0.0, 2.0 * case.reference_speed_m_s, 401)
    fit = case_fit(case, n_lags)
    system = derivative_system(case.basis, case.derivatives, case.air_density, fit=fit,
                               phi_p=case.phi_p)
    return SectionCaseResult(case, stability.sweep(system, speeds),
                             stability.pk_sweep(system, speeds), fit, system.n_states)
