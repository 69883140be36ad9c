"""Sensitivities of the flutter and divergence speeds to bridge parameters
(docs/methods.md#sensitivities).

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

Each derivative holds **within one branch**: it follows the eigenvalue that is critical at the
nominal point. A finite change of an input may hand the instability to another branch (TS1 to a
vertical or side-span hybrid) and the speed then jumps, which no derivative predicts. Every row
says which branch its derivatives hold on (``<q>_valid_within_branch``) and whether both
finite-difference points stayed on it (``<q>_fd_same_branch``);
:func:`bridgeflap.design.batch.branch_flags.flag_branch_neighbours` flags DOE/sensitivity rows whose
neighbours in parameter space have a different critical branch.

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

Global screening (Morris, Sobol') is in :mod:`bridgeflap.design.studies.screening`.

References
----------
Seyranian, A. P. & Mailybaev, A. A. (2003), *Multiparameter Stability Theory with Mechanical
Applications* (eigenvalue sensitivities).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence

import numpy as np
import scipy.linalg as sla

# the IFT core, also served from here (design.sensitivity.ift)
from bridgeflap.design.sensitivity.ift import (
    _REL_STEP_A,
    KINK_STEP,
    SensitivityResult,
    any_kink,
    critical_eigenpair,
    critical_speeds,
    empty_entries,
    kink_entries,
    sensitivity_result,
    speed_derivative_ift,
)
from bridgeflap.model.aeroelastic import statespace
from bridgeflap.model.analysis import DEFAULT_MODES, bridge_system, modal_model
from bridgeflap.model.arguments import check_callable, check_strings, flag, number, optional
from bridgeflap.model.errors import BridgeflapError, BridgeflapInputError
from bridgeflap.model.grid import speed_grid
from bridgeflap.model.stability.sweeps import oscillation_tolerance
from bridgeflap.model.structure.bridge_arg import BridgeArg, takes_bridge
from bridgeflap.model.structure.fe import assemble
from bridgeflap.model.structure.modes import ModalModel
from bridgeflap.model.structure.ritz import chosen_modes, ritz_basis
from bridgeflap.model.structure.spec import PARAMETER_PATHS, BridgeSpec, get_path

__all__ = [
    "DEFAULT_PARAMETERS",
    "SensitivityResult",
    "critical_eigenpair",
    "critical_speeds",
    "local_sensitivity",
    "ritz_system",
    "shape_derivatives",
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

_REL_STEP_FD = 1e-3  # relative step of the finite-difference checks of U itself
_NOT_DIFFERENTIABLE = {"mesh.element_length_m": "changes the mesh (no fixed Ritz basis)"}


# --------------------------------------------------------------------------- Ritz projection


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
    if getattr(spec, "structure", None) is not None:  # imported modes do not move with p
        return {}
    p0 = float(get_path(spec, path))
    h = rel_step * abs(p0)
    plus = assemble(spec.replace(**{path: p0 + h}), erection_gj_factor=erection_gj_factor)
    minus = assemble(spec.replace(**{path: p0 - h}), erection_gj_factor=erection_gj_factor)
    chosen = chosen_modes(nominal, n_modes)
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


def ritz_system(spec: BridgeSpec, nominal: ModalModel, n_modes: int = DEFAULT_MODES,
                rfa: str = "rfa4", order: str = "modal",
                shape_offset: dict | None = None) -> statespace.AeroelasticSystem:
    """State space of ``spec`` on the nominal Ritz basis
    (:func:`bridgeflap.model.structure.ritz.ritz_basis`)."""
    basis = ritz_basis(spec, nominal, n_modes, shape_offset=shape_offset)
    return statespace.spec_system(spec, basis, order, rfa)


# --------------------------------------------------------------------------- critical speeds


def _full_speeds(spec, speeds, n_modes, rfa, order):
    _, system = bridge_system(spec, n_modes, order, rfa)
    return critical_speeds(system, speeds)


def check_parameters(parameters: Sequence[str]) -> tuple[str, ...]:
    if isinstance(parameters, str):
        parameters = [p.strip() for p in parameters.split(",") if p.strip()]
    parameters = tuple(parameters)
    if not parameters:
        raise BridgeflapInputError("parameters", "no parameter given")
    from bridgeflap.design.sensitivity.modal import MODAL_QUANTITIES, is_modal_parameter

    for p in parameters:
        if p not in PARAMETER_PATHS and not is_modal_parameter(p):
            raise BridgeflapInputError("parameters", f"unknown parameter {p!r} (known: "
                                                     f"{', '.join(PARAMETER_PATHS)}, and "
                                                     f"mode.<label>.{{{','.join(MODAL_QUANTITIES)}}})")
    return parameters


def _parameters(value, field: str) -> tuple[str, ...]:
    """Rule: parameter paths, as a list or as one comma-separated string (the CLI's)."""
    return check_parameters(value if isinstance(value, str) else check_strings(value, field))


@takes_bridge(parameters=_parameters, check=flag, rel_step=number(0.0, 0.5, strict=True),
              fd_step=number(0.0, 0.5, strict=True), kink_step=number(0.0, 0.5, strict=True),
              progress=optional(check_callable))
def local_sensitivity(bridge: BridgeArg, parameters: Sequence[str] = DEFAULT_PARAMETERS,
                      speeds="0:120:1", n_modes: int = DEFAULT_MODES, rfa: str = "rfa4",
                      order: str = "modal", check: bool = True,
                      rel_step: float = _REL_STEP_A, fd_step: float = _REL_STEP_FD,
                      kink_step: float = KINK_STEP,
                      progress: Callable[[str], None] | None = None) -> SensitivityResult:
    """IFT derivatives of ``U_F`` and ``U_D`` with finite-difference checks.

    Parameters
    ----------
    bridge : str, os.PathLike or BridgeSpec
    parameters : sequence of str
        Dotted paths from :data:`bridgeflap.model.structure.spec.PARAMETER_PATHS`, or modal data
        ``mode.<label>.<quantity>`` only (:mod:`bridgeflap.design.sensitivity.modal`).
    speeds : str or array_like
        Sweep grid [m/s] that locates the nominal crossings (refined to 1e-7 m/s).
    n_modes : int
        Retained vertical + torsional modes.
    check : bool
        Also compute the Ritz and the full-pipeline finite differences (two extra sweeps per
        parameter each) and the kink check (two more full-pipeline sweeps, at ``kink_step``).
    rel_step : float
        Relative step of the central difference of ``A(U; p)`` (truncation error
        ``O(rel_step^2)``; cable statics are solved to ~1e-9 relative, so round-off in the
        quotient is ~1e-9/rel_step).
    fd_step : float
        Relative step of the finite-difference checks of ``U`` itself.
    kink_step : float
        Relative step of the kink check: the one-sided slopes of ``U`` over ``-+kink_step p``
        of the full pipeline against the IFT derivative; a row is flagged (``kink``) when the
        critical branch changes within the step or a slope disagrees beyond the tolerance of
        :func:`bridgeflap.design.sensitivity.ift.kink_check`.

    Returns
    -------
    SensitivityResult
        One row per parameter: the IFT derivative ``dU/dp`` [m/s per unit of ``p``], the relative
        ``(p/U) dU/dp`` [-] of ``U_F`` and ``U_D``, the finite-difference checks and the kink
        flag; ``table()``, ``to_dataframe()``, ``plot()`` (tornado).

    Raises
    ------
    BridgeflapInputError
        A bad bridge, parameter path, speed grid or step.

    Examples
    --------
    >>> from bridgeflap import design
    >>> res = design.local_sensitivity("humber", ["deck.gj_nm2"], speeds="0:90:2", n_modes=6,
    ...                                check=False)
    >>> "deck.gj_nm2" in res.table()
    True
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
    parameters = check_parameters(parameters)
    u = speed_grid(speeds)  # "lo:hi:step" text or numbers [m/s]
    if any(p.startswith("mode.") for p in parameters):  # imported modal data
        from bridgeflap.design.sensitivity.modal import modal_sensitivity

        return modal_sensitivity(spec, parameters, u, n_modes, check, rel_step, fd_step,
                                 progress, kink_step)
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
            # an implicit-function derivative follows the critical eigenvalue: it holds within
            # the branch that is critical at the nominal point, not across a branch switch
            row.update(empty_entries(q, crit))
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
                        # a difference quotient across a branch switch is no derivative
                        row[f"{q}_fd_same_branch"] = (
                            plus[f"{q}_branch_label"] == minus[f"{q}_branch_label"]
                            == crit[f"{q}_branch_label"])
                    # the kink check: is the derivative still the slope a few per cent away?
                    hk = kink_step * abs(p0)
                    plus = _full_speeds(spec.replace(**{path: p0 + hk}), u, n_modes, rfa, order)
                    minus = _full_speeds(spec.replace(**{path: p0 - hk}), u, n_modes, rfa, order)
                    for q in ("flutter", "divergence"):
                        row.update(kink_entries(q, p0, hk, crit, minus, plus,
                                                row[f"d_{q}_speed"]))
                except BridgeflapError as exc:
                    row["check_status"] = f"finite differences failed: {exc}"
        row["kink"] = any_kink(row)
        rows.append(row)
        if progress:
            progress(path)
    return sensitivity_result(
        spec, crit, rows, n_modes,
        {"speeds_m_s": [float(u[0]), float(u[-1])], "rfa": rfa, "order": order,
         "rel_step_A": rel_step, "rel_step_fd": fd_step, "rel_step_kink": kink_step,
         "erected_fraction": spec.erected_fraction,
         "method": "IFT on the critical eigenvalue; dA/dp by central difference of "
                   "the projected A: on the nominal modes moved along their "
                   "out-of-subspace derivative (d_*), and on the fixed nominal modes "
                   "(d_*_fixed_basis, checked by *_ritz_fd)"})
