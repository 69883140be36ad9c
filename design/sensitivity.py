"""Sensitivities of the flutter and divergence speeds to bridge parameters (METHODS.md §7).

Local derivatives: implicit-function theorem (IFT)
--------------------------------------------------
At the flutter speed ``U_F`` the critical eigenvalue ``lambda(U, p)`` of ``A(U; p)`` satisfies
``Re lambda(U_F(p), p) = 0``, so::

    dU_F/dp = - (d Re lambda / dp) / (d Re lambda / dU)

with first-order eigenvalue perturbation theory (left eigenvector ``w``, right ``v``,
``w^H A = lambda w^H``)::

    d lambda / dU = w^H (A1 + 2 U A2) v / (w^H v)        (exact: A = A0 + U A1 + U^2 A2)
    d lambda / dp = w^H (dA/dp) v / (w^H v)

Torsional divergence is the same with the real eigenvalue that crosses zero at ``U_D``.

``dA/dp`` for a parameter that enters through the cable statics and the finite-element assembly
(deck mass, inertia, GJ, EI, sag, cable spacing, ...) is the central difference of the
**Ritz-projected** state matrix: the perturbed FE matrices ``M(p), K(p)`` are projected on the
*nominal* mass-normalised mode shapes ``Phi_0`` (``M_r = Phi_0^T M(p) Phi_0``, ``K_r = Phi_0^T
K(p) Phi_0``), the Rayleigh coefficients are recomputed from the perturbed first vertical and
torsional frequencies, and the aerodynamic matrices are rebuilt on ``Phi_0`` with the perturbed
``b`` and ``rho``. Holding the basis fixed avoids the sign flips and re-ordering of re-solved
modes; at the nominal point the projected model *is* the nominal modal model. The derivative is
therefore exact for the retained (Ritz) basis; it differs from the derivative of the fully
re-solved pipeline only by the rotation of the retained modal subspace out of itself, which is
small when the truncation has converged. Two finite-difference checks quantify both parts:

* ``d_flutter_speed_ritz_fd``: central difference of ``U_F`` of the Ritz-projected system (the
  same model as the IFT; differs only by truncation error of the difference quotient);
* ``d_flutter_speed_fd``: central difference of ``U_F`` of the full pipeline (statics, FE,
  modes re-solved and re-truncated, flutter sweep).

Relative (unit-free) derivatives ``(p/U) dU/dp`` are reported next to the absolute ones.

Global sensitivity
------------------
:func:`global_sensitivity` samples stated ranges of the *estimated* inputs (HUMBER_DATA.md §0 and
§2: NOT FOUND or ESTIMATE) with SALib (Morris elementary effects or Sobol'/Saltelli), runs the
flutter case of every sample through the fault-tolerant batch runner (:func:`design.doe.run_batch`),
and returns the indices and the 5/50/95 % band of the flutter and divergence speeds.

References
----------
Seyranian, A. P. & Mailybaev, A. A. (2003), *Multiparameter Stability Theory with Mechanical
Applications* (eigenvalue sensitivities). Morris, M. D. (1991), Technometrics 33(2). Saltelli, A.
(2002), Comput. Phys. Commun. 145. Herman, J. & Usher, W. (2017), SALib, JOSS 2(9).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.linalg as sla

from model import statespace
from model.analysis import DEFAULT_MODES, bridge_system, modal_model, parse_range
from model.basis import StructuralBasis
from model.errors import BridgeflapError, BridgeflapInputError
from model.fe import assemble
from model.modes import ModalModel, rayleigh_coefficients
from model.spec import PARAMETER_PATHS, BridgeSpec, get_path
from model.stability import CONVERGED, oscillation_tolerance, sweep

__all__ = [
    "DEFAULT_PARAMETERS",
    "DEFAULT_UNCERTAIN_RANGES",
    "GlobalSensitivityResult",
    "SensitivityResult",
    "critical_speeds",
    "eigenvalue_derivative",
    "global_sensitivity",
    "local_sensitivity",
    "ritz_system",
    "speed_derivative_ift",
]

#: Parameters of the local study by default: the estimated structural inputs and the aero ones.
DEFAULT_PARAMETERS = (
    "deck.mass_kg_per_m",
    "deck.mass_inertia_kgm2_per_m",
    "deck.gj_nm2",
    "deck.ei_vertical_nm2",
    "cable.main_sag_m",
    "cable.spacing_m",
    "cable.mass_kg_per_m",
    "deck.half_chord_m",
    "aero.air_density_kg_m3",
    "damping.ratio",
)

#: Ranges [SI] of the estimated Humber inputs (HUMBER_DATA.md §0/§2 and humber.toml sources).
DEFAULT_UNCERTAIN_RANGES = {
    # r = 6.5 .. 7.6 m (7.6 m: thin-walled 22 x 4.5 m box; humber.toml uses r = 7.0 m)
    "deck.mass_inertia_kgm2_per_m": (7660.0 * 6.5 ** 2, 7660.0 * 7.6 ** 2),
    # updated GJ 3.73e11; initial Bredt estimate 4.7e11; -25 % below the updated value
    "deck.gj_nm2": (2.8e11, 4.7e11),
    # updated EI 1.54e12; initial estimate ~1e12
    "deck.ei_vertical_nm2": (1.0e12, 2.0e12),
    # [DERIVED] plausible sag range 110-125 m
    "cable.main_sag_m": (110.0, 125.0),
    # NOT FOUND; ~22 m [MEMORY, UNVERIFIED]
    "cable.spacing_m": (20.0, 24.0),
    # b = 11 m (22 m box) to 14.25 m (28.5 m overall)
    "deck.half_chord_m": (11.0, 14.25),
    # 6.5-8 [MEMORY, UNVERIFIED], README sensitivity 6-10: enters buffeting only
    "aero.coherence_decay": (6.0, 10.0),
}

_REL_STEP_A = 1e-4   # relative step of the central difference of A(U; p) (Ritz)
_REL_STEP_FD = 1e-3  # relative step of the finite-difference checks of U itself
_SPEED_TOL = 1e-7    # [m/s] Brent tolerance of the crossings used by the checks
_NOT_DIFFERENTIABLE = {"mesh.element_length_m": "changes the mesh (no fixed Ritz basis)"}


# --------------------------------------------------------------------------- eigen-derivatives


def eigenvalue_derivative(w: np.ndarray, v: np.ndarray, dA: np.ndarray) -> complex:
    """First-order derivative of a simple eigenvalue, ``w^H dA v / (w^H v)``.

    Parameters
    ----------
    w, v : ndarray (n,)
        Left (``w^H A = lambda w^H``) and right eigenvectors.
    dA : ndarray (n, n)
        Derivative of the matrix.
    """
    return complex(np.vdot(w, dA @ v) / np.vdot(w, v))


def critical_eigenpair(A: np.ndarray, kind: str, omega_tol: float):
    """Critical eigenvalue and its left/right eigenvectors at a stability boundary.

    ``kind="flutter"``: the oscillatory eigenvalue (``Im > omega_tol``) with the largest real
    part; ``kind="divergence"``: the real eigenvalue (``|Im| <= omega_tol``) nearest zero.
    """
    lam, vl, vr = sla.eig(A, left=True, right=True)
    if kind == "flutter":
        idx = np.where(lam.imag > omega_tol)[0]
        if idx.size == 0:
            raise BridgeflapError("no oscillatory eigenvalue at the flutter speed")
        k = int(idx[np.argmax(lam[idx].real)])
    else:
        idx = np.where(np.abs(lam.imag) <= omega_tol)[0]
        if idx.size == 0:
            raise BridgeflapError("no real eigenvalue at the divergence speed")
        k = int(idx[np.argmin(np.abs(lam[idx].real))])
    return lam[k], vl[:, k], vr[:, k]


def speed_derivative_ift(A_of_p: Callable[[float], np.ndarray], dA_dU: np.ndarray, A0: np.ndarray,
                         p0: float, kind: str, omega_tol: float,
                         rel_step: float = _REL_STEP_A) -> tuple[float, dict]:
    """``dU/dp`` at a stability boundary by the implicit-function theorem.

    Parameters
    ----------
    A_of_p : callable
        ``A(U_crit; p)`` at the (fixed) critical speed as a function of the parameter.
    dA_dU : ndarray
        ``A1 + 2 U_crit A2`` (exact).
    A0 : ndarray
        ``A(U_crit; p0)``.
    p0 : float
        Nominal parameter value (any unit; the step is relative, ``rel_step * |p0|``, so the
        result transforms as ``1/unit`` and the relative derivative is unit-free).
    kind : {"flutter", "divergence"}
    omega_tol : float
        [rad/s] oscillatory/real threshold.

    Returns
    -------
    (float, dict)
        ``dU/dp`` [m/s per unit of p] and diagnostics (``d_re_lambda_dU``, ``d_re_lambda_dp``,
        ``re_lambda`` at the nominal point).
    """
    if p0 == 0 or not np.isfinite(p0):
        raise BridgeflapInputError("parameter", "nominal value is zero: relative step undefined")
    lam, w, v = critical_eigenpair(A0, kind, omega_tol)
    h = rel_step * abs(p0)
    dA_dp = (A_of_p(p0 + h) - A_of_p(p0 - h)) / (2 * h)
    d_dU = eigenvalue_derivative(w, v, dA_dU).real
    d_dp = eigenvalue_derivative(w, v, dA_dp).real
    if d_dU == 0:
        raise BridgeflapError("critical eigenvalue does not cross (d Re lambda/dU = 0)")
    return -d_dp / d_dU, {"d_re_lambda_dU": d_dU, "d_re_lambda_dp": d_dp,
                          "re_lambda": float(lam.real), "im_lambda": float(lam.imag)}


# --------------------------------------------------------------------------- Ritz projection


def _chosen_modes(modal: ModalModel, n_modes: int) -> list[int]:
    cand = [i for i, m in enumerate(modal.modes) if m.family in ("vertical", "torsional")]
    return cand[:int(n_modes)]


def _first_omega(fam) -> float:
    w2 = sla.eigh(fam.K, fam.M, eigvals_only=True, subset_by_index=[0, 0])[0]
    return float(np.sqrt(w2))


def shape_derivatives(spec: BridgeSpec, nominal: ModalModel, n_modes: int, path: str,
                      rel_step: float = _REL_STEP_A,
                      erection_gj_factor: float = 0.5) -> dict:
    """Out-of-subspace derivative of the retained mode shapes with respect to ``path``.

    For a retained mode ``i`` of a family (all ``N`` modes ``phi_j``, ``lambda_j = omega_j^2``
    known from the complete family eigen-solution)::

        d phi_i / dp  =  sum_{j not retained} phi_j phi_j^T (dK/dp - lambda_i dM/dp) phi_i
                                                / (lambda_i - lambda_j)  +  (retained part)

    (Nelson 1976; modal expansion, complete because the family is finite-dimensional). The
    retained part only re-combines the retained coordinates, to which the flutter eigenvalues
    are invariant, so it is dropped. ``dK/dp, dM/dp`` are central differences of the assembled
    family matrices. Returns ``family -> (n_dof, n_retained_in_family)``.
    """
    p0 = float(get_path(spec, path))
    h = rel_step * abs(p0)
    plus = assemble(spec.replace(**{path: p0 + h}), erection_gj_factor=erection_gj_factor)
    minus = assemble(spec.replace(**{path: p0 - h}), erection_gj_factor=erection_gj_factor)
    chosen = _chosen_modes(nominal, n_modes)
    out = {}
    for family in ("vertical", "torsional"):
        cols = [j for j, i in enumerate(chosen) if nominal.modes[i].family == family]
        fam0 = nominal.structure.families[family]
        if plus.families[family].M.shape != fam0.M.shape:
            raise BridgeflapError("the perturbation changes the mesh: no fixed Ritz basis")
        dK = (plus.families[family].K - minus.families[family].K) / (2 * h)
        dM = (plus.families[family].M - minus.families[family].M) / (2 * h)
        lam_all, Phi_all = sla.eigh(fam0.K, fam0.M)
        k = len(cols)
        Phi_r, lam_r = Phi_all[:, :k], lam_all[:k]
        Phi_o, lam_o = Phi_all[:, k:], lam_all[k:]
        # signs of the retained columns as stored in the nominal modal model
        stored = np.column_stack([nominal.shape(chosen[j]) for j in cols]) if k else Phi_r
        sign = np.sign(np.sum(stored * Phi_r, axis=0)) if k else np.ones(0)
        d = np.zeros((fam0.M.shape[0], k))
        for c in range(k):
            rhs = Phi_o.T @ ((dK - lam_r[c] * dM) @ Phi_r[:, c])
            d[:, c] = sign[c] * (Phi_o @ (rhs / (lam_r[c] - lam_o)))
        out[family] = d
    return out


def ritz_basis(spec: BridgeSpec, nominal: ModalModel, n_modes: int,
               erection_gj_factor: float = 0.5, shape_offset: dict | None = None,
               ) -> StructuralBasis:
    """Structural basis of ``spec`` projected on the nominal mode shapes (Ritz).

    Parameters
    ----------
    spec : BridgeSpec
        Perturbed bridge (same mesh as ``nominal``).
    nominal : ModalModel
        Nominal modal model; its lowest ``n_modes`` vertical and torsional shapes are the basis.
    n_modes : int
        Retained coordinates, chosen as in :meth:`ModalModel.structural_basis`.

    Notes
    -----
    ``M_r = Phi^T M(p) Phi`` and ``K_r = Phi^T K(p) Phi`` per family (the families are
    uncoupled), Rayleigh damping ``C_r = a_M M_r + a_K K_r`` with ``(a_M, a_K)`` from the
    perturbed first vertical and torsional frequencies of the full FE families (as
    :func:`model.modes.solve` does). At ``spec == nominal.spec`` this reproduces
    ``nominal.structural_basis(n_modes)`` (``M_r = I``, ``K_r = diag(omega^2)``).
    """
    structure = assemble(spec, erection_gj_factor=erection_gj_factor)
    chosen = _chosen_modes(nominal, n_modes)
    n = len(chosen)
    n_strip = len(structure.strip_x)
    if n_strip != len(nominal.structure.strip_x):
        raise BridgeflapError("the perturbation changes the mesh: no fixed Ritz basis")
    M, K = np.zeros((n, n)), np.zeros((n, n))
    phi_h, phi_a = np.zeros((n_strip, n)), np.zeros((n_strip, n))
    for family, target in (("vertical", phi_h), ("torsional", phi_a)):
        cols = [j for j, i in enumerate(chosen) if nominal.modes[i].family == family]
        if not cols:
            continue
        Phi = np.column_stack([nominal.shape(chosen[j]) for j in cols])
        if shape_offset is not None:
            Phi = Phi + shape_offset[family]
        fam = structure.families[family]
        if fam.M.shape[0] != Phi.shape[0]:
            raise BridgeflapError("the perturbation changes the mesh: no fixed Ritz basis")
        ix = np.ix_(cols, cols)
        M[ix] = Phi.T @ fam.M @ Phi
        K[ix] = Phi.T @ fam.K @ Phi
        target[:, cols] = fam.strip_map @ Phi
    a_m, a_k = rayleigh_coefficients(_first_omega(structure.families["vertical"]),
                                     _first_omega(structure.families["torsional"]),
                                     spec.damping.ratio)
    M, K = 0.5 * (M + M.T), 0.5 * (K + K.T)
    return StructuralBasis(M=M, C=a_m * M + a_k * K, K=K, phi_h=phi_h, phi_a=phi_a,
                           strip_length=structure.strip_length,
                           strip_x=structure.global_x(structure.strip_span, structure.strip_x),
                           labels=tuple(nominal.modes[i].label for i in chosen))


def ritz_system(spec: BridgeSpec, nominal: ModalModel, n_modes: int = DEFAULT_MODES,
                rfa: str = "rfa4", order: str = "modal",
                shape_offset: dict | None = None) -> statespace.AeroelasticSystem:
    """Aeroelastic state space of ``spec`` on the nominal Ritz basis (see :func:`ritz_basis`)."""
    basis = ritz_basis(spec, nominal, n_modes, shape_offset=shape_offset)
    a = spec.aero
    return statespace.build(basis, spec.deck.half_chord_m, a.air_density_kg_m3, rfa=rfa,
                            order=order, added_inertia=a.added_inertia,
                            lift_slope_buffeting=a.lift_slope_buffeting,
                            moment_slope_buffeting=a.moment_slope_buffeting)


# --------------------------------------------------------------------------- critical speeds


def critical_speeds(system: statespace.AeroelasticSystem, speeds,
                    speed_tol: float = _SPEED_TOL) -> dict:
    """Flutter and divergence speeds [m/s] of a system (NaN unless converged) and statuses."""
    sw = sweep(system, speeds, speed_tol=speed_tol)
    return {"flutter_speed_m_s": sw.flutter.speed if sw.flutter.status == CONVERGED else np.nan,
            "flutter_status": sw.flutter.status,
            "divergence_speed_m_s": (sw.divergence.speed if sw.divergence.status == CONVERGED
                                     else np.nan),
            "divergence_status": sw.divergence.status}


def _full_speeds(spec, speeds, n_modes, rfa, order):
    _, system = bridge_system(spec, n_modes, order, rfa)
    return critical_speeds(system, speeds)


def _check_parameters(parameters: Sequence[str]) -> tuple[str, ...]:
    if isinstance(parameters, str):
        parameters = [p.strip() for p in parameters.split(",") if p.strip()]
    parameters = tuple(parameters)
    if not parameters:
        raise BridgeflapInputError("parameters", "no parameter given")
    for p in parameters:
        if p not in PARAMETER_PATHS:
            raise BridgeflapInputError("parameters", f"unknown parameter {p!r} (known: "
                                                     f"{', '.join(PARAMETER_PATHS)})")
    return parameters


# --------------------------------------------------------------------------- local result


@dataclass(frozen=True)
class SensitivityResult:
    """Local sensitivities of the flutter and divergence speeds.

    Attributes
    ----------
    flutter_speed_m_s, divergence_speed_m_s : float
        Nominal critical speeds [m/s] (NaN when not found).
    rows : tuple of dict
        Per parameter: ``parameter``, ``value`` [SI], for ``q`` in (flutter, divergence):
        ``d_<q>_speed`` (IFT, [m/s per SI unit]), ``d_<q>_speed_ritz_fd``, ``d_<q>_speed_fd``,
        ``relative_d_<q>_speed`` (``p/U dU/dp`` [-]), and ``status`` / ``<q>_status``.
    """

    bridge: str
    flutter_speed_m_s: float
    divergence_speed_m_s: float
    flutter_status: str
    divergence_status: str
    n_modes: int
    rows: tuple
    settings: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """The ``bridgeflap sensitivity`` JSON contract."""
        return {"bridge": self.bridge, "flutter_speed_m_s": self.flutter_speed_m_s,
                "flutter_status": self.flutter_status,
                "divergence_speed_m_s": self.divergence_speed_m_s,
                "divergence_status": self.divergence_status, "modes_retained": self.n_modes,
                "settings": dict(self.settings),
                "derivatives": {r["parameter"]: {k: v for k, v in r.items() if k != "parameter"}
                                for r in self.rows}}

    def table(self) -> str:
        """Plain-text table of the IFT derivatives and both checks."""
        lines = [f"{'parameter':30s} {'value':>10s} {'dUF/dp IFT':>12s} {'full FD':>12s} "
                 f"{'fixed-basis':>12s} {'Ritz FD':>12s} {'p/UF dUF/dp':>11s} {'p/UD dUD/dp':>11s}"]
        for r in self.rows:
            lines.append(f"{r['parameter']:30s} {r['value']:10.4g} {r['d_flutter_speed']:12.5g} "
                         f"{r['d_flutter_speed_fd']:12.5g} "
                         f"{r['d_flutter_speed_fixed_basis']:12.5g} "
                         f"{r['d_flutter_speed_ritz_fd']:12.5g} "
                         f"{r['relative_d_flutter_speed']:11.4f} "
                         f"{r['relative_d_divergence_speed']:11.4f}")
        return "\n".join(lines)

    def plot(self, ax=None):
        """Tornado plot of the relative derivatives ``(p/U) dU/dp`` (flutter and divergence)."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 0.45 * len(self.rows) + 1.5))
        rel_f = np.array([r["relative_d_flutter_speed"] for r in self.rows], dtype=float)
        rel_d = np.array([r["relative_d_divergence_speed"] for r in self.rows], dtype=float)
        order = np.argsort(np.nan_to_num(np.abs(rel_f)))
        y = np.arange(len(order))
        ax.barh(y + 0.2, rel_f[order], height=0.4, color="C3", label="flutter")
        ax.barh(y - 0.2, rel_d[order], height=0.4, color="C0", label="torsional divergence")
        ax.set_yticks(y)
        ax.set_yticklabels([self.rows[i]["parameter"] for i in order], fontsize=8)
        ax.axvline(0, color="k", lw=0.8)
        ax.set_xlabel("relative sensitivity (p/U) dU/dp [-]")
        ax.set_title(f"{self.bridge}: U_F = {self.flutter_speed_m_s:.2f} m/s, "
                     f"U_D = {self.divergence_speed_m_s:.2f} m/s (IFT, {self.n_modes} modes)",
                     fontsize=9)
        ax.grid(alpha=0.3, axis="x")
        ax.legend(fontsize=8)
        return ax


def local_sensitivity(spec: BridgeSpec, parameters: Sequence[str] = DEFAULT_PARAMETERS,
                      speeds="0:120:1", n_modes: int = DEFAULT_MODES, rfa: str = "rfa4",
                      order: str = "modal", check: bool = True,
                      rel_step: float = _REL_STEP_A, fd_step: float = _REL_STEP_FD,
                      progress: Callable[[str], None] | None = None) -> SensitivityResult:
    """IFT derivatives of ``U_F`` and ``U_D`` with finite-difference checks.

    Parameters
    ----------
    spec : BridgeSpec
    parameters : sequence of str
        Dotted paths from :data:`model.spec.PARAMETER_PATHS`.
    speeds : str or array_like
        Sweep grid [m/s] that locates the nominal crossings (refined to 1e-7 m/s).
    n_modes : int
        Retained vertical + torsional modes.
    check : bool
        Also compute the Ritz and the full-pipeline finite differences (two extra sweeps per
        parameter each).
    rel_step : float
        Relative step of the central difference of ``A(U; p)`` (truncation error
        ``O(rel_step^2)``; cable statics are solved to ~1e-9 relative, so round-off in the
        quotient is ~1e-9/rel_step).
    fd_step : float
        Relative step of the finite-difference checks of ``U`` itself.
    """
    parameters = _check_parameters(parameters)
    u = parse_range(speeds, "speeds", 0.0) if isinstance(speeds, str) else np.asarray(speeds)
    nominal = modal_model(spec)
    _, system0 = bridge_system(spec, n_modes, order, rfa, modal=nominal)
    omega_tol = oscillation_tolerance(system0)
    crit = critical_speeds(system0, u)
    ritz = functools.partial(ritz_system, nominal=nominal, n_modes=n_modes, rfa=rfa, order=order)
    rows = []
    for path in parameters:
        p0 = float(get_path(spec, path))
        row: dict = {"parameter": path, "value": p0}
        dphi = None
        for q in ("flutter", "divergence"):
            U = crit[f"{q}_speed_m_s"]
            key = f"d_{q}_speed"
            row.update({key: np.nan, f"{key}_fixed_basis": np.nan, f"{key}_ritz_fd": np.nan,
                        f"{key}_fd": np.nan, f"relative_{key}": np.nan,
                        f"relative_{key}_fixed_basis": np.nan, f"relative_{key}_fd": np.nan,
                        f"{q}_status": "ok"})
            if not np.isfinite(U):
                row[f"{q}_status"] = f"nominal {q}: {crit[f'{q}_status']}"
                continue
            if path in _NOT_DIFFERENTIABLE:
                row[f"{q}_status"] = f"IFT not available: {_NOT_DIFFERENTIABLE[path]}"
                continue
            try:
                if dphi is None:
                    dphi = shape_derivatives(spec, nominal, n_modes, path, rel_step)
                dA_dU = system0.A1 + 2 * U * system0.A2
                for variant, offset in (("", dphi), ("_fixed_basis", None)):
                    def A_of_p(value, path=path, U=U, offset=offset, p0=p0):
                        shift = (None if offset is None else
                                 {f: (value - p0) * d for f, d in offset.items()})
                        return ritz(spec.replace(**{path: value}), shape_offset=shift).A(U)

                    d, diag = speed_derivative_ift(A_of_p, dA_dU, system0.A(U), p0, q,
                                                   omega_tol, rel_step)
                    row[key + variant] = d
                    row[f"relative_{key}{variant}"] = p0 / U * d
                row[f"{q}_re_lambda_at_crossing"] = diag["re_lambda"]
            except BridgeflapError as exc:
                row[f"{q}_status"] = f"IFT failed: {exc}"
        if check:
            h = fd_step * abs(p0)
            if h > 0:
                try:
                    if path not in _NOT_DIFFERENTIABLE:
                        plus = critical_speeds(ritz(spec.replace(**{path: p0 + h})), u)
                        minus = critical_speeds(ritz(spec.replace(**{path: p0 - h})), u)
                        for q in ("flutter", "divergence"):
                            k = f"{q}_speed_m_s"
                            row[f"d_{q}_speed_ritz_fd"] = (plus[k] - minus[k]) / (2 * h)
                    plus = _full_speeds(spec.replace(**{path: p0 + h}), u, n_modes, rfa, order)
                    minus = _full_speeds(spec.replace(**{path: p0 - h}), u, n_modes, rfa, order)
                    for q in ("flutter", "divergence"):
                        k = f"{q}_speed_m_s"
                        d = (plus[k] - minus[k]) / (2 * h)
                        row[f"d_{q}_speed_fd"] = d
                        row[f"relative_d_{q}_speed_fd"] = p0 / crit[k] * d
                except BridgeflapError as exc:
                    row["check_status"] = f"finite differences failed: {exc}"
        rows.append(row)
        if progress:
            progress(path)
    return SensitivityResult(
        bridge=spec.name, flutter_speed_m_s=crit["flutter_speed_m_s"],
        divergence_speed_m_s=crit["divergence_speed_m_s"],
        flutter_status=crit["flutter_status"], divergence_status=crit["divergence_status"],
        n_modes=int(n_modes), rows=tuple(rows),
        settings={"speeds_m_s": [float(u[0]), float(u[-1])], "rfa": rfa, "order": order,
                  "rel_step_A": rel_step, "rel_step_fd": fd_step,
                  "erected_fraction": spec.erected_fraction,
                  "method": "IFT on the critical eigenvalue; dA/dp by central difference of "
                            "the projected A: on the nominal modes moved along their "
                            "out-of-subspace derivative (d_*), and on the fixed nominal modes "
                            "(d_*_fixed_basis, checked by *_ritz_fd)"})


# --------------------------------------------------------------------------- global


@dataclass(frozen=True)
class GlobalSensitivityResult:
    """Global sensitivity indices and uncertainty band of the flutter and divergence speeds.

    Attributes
    ----------
    method : str
        ``"morris"`` (``mu_star``, ``sigma`` [m/s]) or ``"sobol"`` (``S1``, ``ST`` [-]).
    ranges : dict
        Parameter -> (lower, upper) [SI].
    indices : dict
        Output -> parameter -> index dict; or ``{"status": ...}`` when not computable.
    band : dict
        Output -> ``{"p05", "p50", "p95", "min", "max"}`` [m/s] over the finite samples.
    cases, succeeded, failed : int
        Batch counts; ``out_dir`` the batch folder.
    """

    method: str
    ranges: dict
    indices: dict
    band: dict
    cases: int
    succeeded: int
    failed: int
    out_dir: str
    samples: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)), compare=False)
    outputs: dict = field(default_factory=dict, compare=False)

    def summary(self) -> dict:
        """JSON-ready summary."""
        return {"method": self.method, "ranges": {k: list(v) for k, v in self.ranges.items()},
                "indices": self.indices, "band": self.band, "cases": self.cases,
                "succeeded": self.succeeded, "failed": self.failed, "out_dir": self.out_dir}

    def plot(self, axes=None):
        """Index bars per output (left) and histograms of the two speeds (right)."""
        import matplotlib.pyplot as plt

        if axes is None:
            _, axes = plt.subplots(1, 2, figsize=(12, 4.2))
        ax0, ax1 = axes
        names = list(self.ranges)
        y = np.arange(len(names))
        key = "mu_star" if self.method == "morris" else "ST"
        for j, (out, col) in enumerate((("flutter_speed_m_s", "C3"),
                                        ("divergence_speed_m_s", "C0"))):
            idx = self.indices.get(out, {})
            vals = [idx.get(n, {}).get(key, np.nan) if isinstance(idx.get(n), dict) else np.nan
                    for n in names]
            ax0.barh(y + (0.2 if j == 0 else -0.2), vals, height=0.4, color=col,
                     label=out.replace("_speed_m_s", ""))
            data = np.asarray(self.outputs.get(out, []), dtype=float)
            data = data[np.isfinite(data)]
            if data.size:
                ax1.hist(data, bins=20, alpha=0.6, color=col,
                         label=f"{out.replace('_speed_m_s', '')}: 5-95 % "
                               f"{self.band[out]['p05']:.1f}-{self.band[out]['p95']:.1f} m/s")
        ax0.set_yticks(y)
        ax0.set_yticklabels(names, fontsize=8)
        ax0.set_xlabel("Morris mu* [m/s]" if self.method == "morris" else "Sobol total index ST")
        ax0.legend(fontsize=8)
        ax0.grid(alpha=0.3, axis="x")
        ax1.set_xlabel("critical wind speed [m/s]")
        ax1.set_ylabel("samples")
        ax1.legend(fontsize=8)
        ax1.set_title(f"{self.method}: {self.succeeded}/{self.cases} cases ok", fontsize=9)
        return axes


def _salib_problem(ranges: Mapping[str, tuple[float, float]]) -> dict:
    names = list(ranges)
    for n in names:
        if n not in PARAMETER_PATHS:
            raise BridgeflapInputError("ranges", f"unknown parameter {n!r}")
        lo, hi = (float(v) for v in ranges[n])
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise BridgeflapInputError(f"ranges.{n}", f"empty range ({lo}, {hi})")
    return {"num_vars": len(names), "names": names,
            "bounds": [[float(ranges[n][0]), float(ranges[n][1])] for n in names]}


def _band(y: np.ndarray) -> dict:
    y = y[np.isfinite(y)]
    if y.size == 0:
        return {"p05": np.nan, "p50": np.nan, "p95": np.nan, "min": np.nan, "max": np.nan,
                "finite": 0}
    p = np.percentile(y, [5, 50, 95])
    return {"p05": p[0], "p50": p[1], "p95": p[2], "min": y.min(), "max": y.max(),
            "finite": int(y.size)}


def global_sensitivity(bridge: str = "humber",
                       ranges: Mapping[str, tuple[float, float]] | None = None,
                       method: str = "morris", n: int = 8, seed: int = 1,
                       out_dir: str | Path = "gsa", workers: int = 1,
                       scheduler: str | None = None, resume: bool = False,
                       case_options: Mapping | None = None,
                       progress: bool = True) -> GlobalSensitivityResult:
    """Morris or Sobol' indices of ``U_F`` and ``U_D`` through the DOE batch runner.

    Parameters
    ----------
    bridge : str
        Built-in name or bridge TOML path (loaded by each case).
    ranges : mapping
        Parameter path -> (lower, upper) [SI]; default :data:`DEFAULT_UNCERTAIN_RANGES`.
    method : {"morris", "sobol"}
        Morris: ``n`` trajectories, ``n (k + 1)`` cases, 4 levels. Sobol: Saltelli sample of base
        size ``n`` (a power of two), ``n (k + 2)`` cases, first and total indices.
    out_dir : path
        Batch folder (``cases/``, ``table.csv``, ``batch.json``; resumable).
    case_options : mapping
        Keyword options of :func:`design.cases.flutter_case` (``speeds``, ``modes``, ...).

    Notes
    -----
    A case whose crossing is not found (status other than converged) gives NaN; the indices of
    that output are then not computed (SALib needs every sample) and its status says why. The
    band is over the finite samples; for Morris the sample is a set of one-at-a-time
    trajectories on a 4-level grid, uniform in each marginal, so the band is indicative; the
    Sobol' (Saltelli) sample is quasi-random uniform on the box.
    """
    from design.cases import flutter_case
    from design.doe import run_batch

    ranges = dict(DEFAULT_UNCERTAIN_RANGES if ranges is None else ranges)
    problem = _salib_problem(ranges)
    if method not in ("morris", "sobol"):
        raise BridgeflapInputError("method", f"must be 'morris' or 'sobol', got {method!r}")
    if isinstance(n, bool) or not isinstance(n, int) or n < 2:
        raise BridgeflapInputError("n", f"must be an integer >= 2, got {n!r}")
    if method == "morris":
        from SALib.sample import morris as sampler

        X = sampler.sample(problem, n, num_levels=4, seed=seed)
    else:
        if n & (n - 1):
            raise BridgeflapInputError("n", f"Sobol base sample must be a power of two, got {n}")
        from SALib.sample import sobol as sampler

        X = sampler.sample(problem, n, calc_second_order=False, seed=seed)
    names = problem["names"]
    cases = [{"case_id": f"case-{i:04d}", **{k: float(v) for k, v in zip(names, row,
                                                                           strict=True)}}
             for i, row in enumerate(X)]
    fn = functools.partial(flutter_case, bridge=str(bridge), **dict(case_options or {}))
    batch = run_batch(fn, cases, out_dir, workers=workers, scheduler=scheduler, resume=resume,
                      progress=progress)
    outputs, indices, band = {}, {}, {}
    for out in ("flutter_speed_m_s", "divergence_speed_m_s"):
        y = np.array([np.nan if (r["result"] is None or r["result"].get(out) is None)
                      else r["result"][out] for r in batch.rows], dtype=float)
        outputs[out] = y
        band[out] = _band(y)
        if not np.all(np.isfinite(y)):
            indices[out] = {"status": f"not computed: {int(np.sum(~np.isfinite(y)))} of "
                                      f"{y.size} cases without a converged {out}"}
            continue
        if np.ptp(y) == 0:
            indices[out] = {"status": "not computed: output constant over the sample"}
            continue
        if method == "morris":
            from SALib.analyze import morris as analyzer

            res = analyzer.analyze(problem, X, y, num_levels=4, seed=seed)
            indices[out] = {nm: {"mu_star": float(res["mu_star"][i]),
                                 "mu": float(res["mu"][i]), "sigma": float(res["sigma"][i]),
                                 "mu_star_conf": float(res["mu_star_conf"][i])}
                            for i, nm in enumerate(names)}
        else:
            from SALib.analyze import sobol as analyzer

            res = analyzer.analyze(problem, y, calc_second_order=False, seed=seed)
            indices[out] = {nm: {"S1": float(res["S1"][i]), "ST": float(res["ST"][i]),
                                 "S1_conf": float(res["S1_conf"][i]),
                                 "ST_conf": float(res["ST_conf"][i])}
                            for i, nm in enumerate(names)}
        indices[out]["status"] = "ok"
    return GlobalSensitivityResult(method=method, ranges={k: tuple(v) for k, v in ranges.items()},
                                   indices=indices, band=band, cases=batch.cases,
                                   succeeded=batch.succeeded, failed=batch.failed,
                                   out_dir=str(batch.table_path.parent), samples=X,
                                   outputs=outputs)
