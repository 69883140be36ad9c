"""The implicit-function core of the sensitivity studies, shared by the structural
parameters (:mod:`bridgeflap.design.sensitivity.local`) and the imported modal data
(:mod:`bridgeflap.design.sensitivity.modal`): the critical eigenpair at a stability boundary,
``dU/dp`` by the implicit-function theorem (the derivation:
:mod:`bridgeflap.design.sensitivity.local`), the nominal critical speeds, and the result record. It
imports neither of the two studies."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from bridgeflap.model.aeroelastic import statespace
from bridgeflap.model.errors import BridgeflapError, BridgeflapInputError
from bridgeflap.model.results import ResultData, jsonable, table_text
from bridgeflap.model.spectrum import eigenvalue_derivative
from bridgeflap.model.stability.sweeps import CONVERGED, sweep

_REL_STEP_A = 1e-4   # relative step of the central difference of A(U; p) (Ritz)
_SPEED_TOL = 1e-7    # [m/s] Brent tolerance of the crossings used by the checks


# --------------------------------------------------------------------------- eigen-derivatives


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


# --------------------------------------------------------------------------- critical speeds


def critical_speeds(system: statespace.AeroelasticSystem, speeds,
                    speed_tol: float = _SPEED_TOL) -> dict:
    """Flutter and divergence speeds [m/s] of a system (NaN unless converged), statuses and
    the branch of each crossing (``flutter_branch_label``, ``divergence_branch_label``)."""
    sw = sweep(system, speeds, speed_tol=speed_tol)
    return {"flutter_speed_m_s": sw.flutter.speed if sw.flutter.status == CONVERGED else np.nan,
            "flutter_status": sw.flutter.status,
            "flutter_branch_label": sw.flutter.label,
            "divergence_speed_m_s": (sw.divergence.speed if sw.divergence.status == CONVERGED
                                     else np.nan),
            "divergence_status": sw.divergence.status,
            "divergence_branch_label": sw.divergence.label}


# --------------------------------------------------------------------------- local result


@dataclass(frozen=True)
class SensitivityResult(ResultData):
    """Local sensitivities of the flutter and divergence speeds.

    Attributes
    ----------
    flutter_speed_m_s, divergence_speed_m_s : float
        Nominal critical speeds [m/s] (NaN when not found).
    rows : tuple of dict
        Per parameter: ``parameter``, ``value`` [SI], for ``q`` in (flutter, divergence):
        ``d_<q>_speed`` (IFT, [m/s per SI unit]), ``d_<q>_speed_ritz_fd``, ``d_<q>_speed_fd``,
        ``relative_d_<q>_speed`` (``p/U dU/dp`` [-]), ``status`` / ``<q>_status``,
        ``<q>_valid_within_branch`` (the label of the branch critical at the nominal point: the
        IFT derivative holds within that branch only; a small change of the input may hand the
        instability to another branch and the speed jumps) and ``<q>_fd_same_branch`` (both
        finite-difference points critical on the nominal branch; False: the difference
        quotient straddles a branch switch).
    critical_branch_label, divergence_branch_label : str
        Branches of the nominal crossings.
    """

    bridge: str
    flutter_speed_m_s: float
    divergence_speed_m_s: float
    flutter_status: str
    divergence_status: str
    n_modes: int
    rows: tuple
    settings: dict = field(default_factory=dict)
    critical_branch_label: str = ""
    divergence_branch_label: str = ""

    def summary(self) -> dict:
        """The ``bridgeflap sensitivity`` JSON contract."""
        return {"bridge": self.bridge, "flutter_speed_m_s": self.flutter_speed_m_s,
                "flutter_status": self.flutter_status,
                "critical_branch_label": self.critical_branch_label,
                "divergence_branch_label": self.divergence_branch_label,
                "divergence_speed_m_s": self.divergence_speed_m_s,
                "divergence_status": self.divergence_status, "modes_retained": self.n_modes,
                "settings": dict(self.settings),
                "derivatives": {r["parameter"]: {k: v for k, v in r.items() if k != "parameter"}
                                for r in self._rows()}}

    _HEADLINE_KEYS = ("bridge", "flutter_speed_m_s", "flutter_status", "critical_branch_label",
                      "divergence_speed_m_s", "divergence_status", "modes_retained")

    def _headline(self) -> dict:
        return {**super()._headline(), "parameters": ", ".join(r["parameter"] for r in self.rows)}

    def _rows(self) -> list[dict]:
        """Per parameter, keys with units: ``value_si`` (the parameter in SI units),
        ``d_<q>_speed_m_s_per_unit[_fd|_fixed_basis|_ritz_fd]`` ([m/s] per SI unit of the
        parameter), ``relative_d_<q>_speed...`` [-], statuses as in :attr:`rows`."""
        return [{_unit_key(k): v for k, v in r.items()} for r in self.rows]

    def to_dict(self) -> dict:
        """Strict JSON: :meth:`summary` (its derivative keys carry their units)."""
        return jsonable(self.summary())

    def table(self, fmt: str = "simple") -> str:
        """Text table of the IFT derivatives and both checks (:mod:`tabulate`)."""
        cols = {"parameter": "parameter", "value_si": "value",
                "d_flutter_speed_m_s_per_unit": "dUF/dp IFT",
                "d_flutter_speed_m_s_per_unit_fd": "full FD",
                "d_flutter_speed_m_s_per_unit_fixed_basis": "fixed-basis",
                "d_flutter_speed_m_s_per_unit_ritz_fd": "Ritz FD",
                "relative_d_flutter_speed": "p/UF dUF/dp",
                "relative_d_divergence_speed": "p/UD dUD/dp"}
        frame = self.to_dataframe().reindex(columns=list(cols)).rename(columns=cols)
        return table_text(frame, fmt, floatfmt=".5g")

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
        def sp(u):
            return "none found" if u is None or u != u else f"{u:.2f} m/s"
        ax.set_title(f"{self.bridge}: U_F = {sp(self.flutter_speed_m_s)}, "
                     f"U_D = {sp(self.divergence_speed_m_s)} (IFT, {self.n_modes} modes)",
                     fontsize=9)
        ax.grid(alpha=0.3, axis="x")
        ax.legend(fontsize=8)
        return ax


def _unit_key(key: str) -> str:
    """``d_flutter_speed_fd`` -> ``d_flutter_speed_m_s_per_unit_fd``; ``value`` -> ``value_si``."""
    if key == "value":
        return "value_si"
    for q in ("flutter", "divergence"):
        stem = f"d_{q}_speed"
        if key.startswith(stem) and not key.startswith(f"{stem}_m_s"):
            return f"{stem}_m_s_per_unit{key[len(stem):]}"
    return key


def empty_entries(q: str, crit: dict) -> dict:
    """A row's entries for quantity ``q`` before they are computed: every derivative NaN, the
    status ``ok`` and the branch the derivative is valid within."""
    key = f"d_{q}_speed"
    return {key: np.nan, f"{key}_fixed_basis": np.nan, f"{key}_ritz_fd": np.nan,
            f"{key}_fd": np.nan, f"relative_{key}": np.nan,
            f"relative_{key}_fixed_basis": np.nan, f"relative_{key}_fd": np.nan,
            f"{q}_status": "ok", f"{q}_valid_within_branch": crit[f"{q}_branch_label"]}


def sensitivity_result(spec, crit: dict, rows, n_modes: int, settings: dict) -> SensitivityResult:
    """The result of a local sensitivity run from the nominal summary ``crit``, the
    per-parameter ``rows`` and the run's ``settings`` (also
    :mod:`bridgeflap.design.sensitivity.modal`)."""
    return SensitivityResult(
        bridge=spec.name, flutter_speed_m_s=crit["flutter_speed_m_s"],
        divergence_speed_m_s=crit["divergence_speed_m_s"],
        flutter_status=crit["flutter_status"], divergence_status=crit["divergence_status"],
        n_modes=int(n_modes), rows=tuple(rows),
        critical_branch_label=crit["flutter_branch_label"],
        divergence_branch_label=crit["divergence_branch_label"], settings=settings)
