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

#: Relative step of the kink check: the speed is re-solved at ``p (1 - KINK_STEP)`` and
#: ``p (1 + KINK_STEP)`` and the two one-sided slopes are compared with the IFT derivative.
#: +-5 % is the scale at which an input is uncertain (and at which a tornado is read); a branch
#: switch a few per cent away is invisible to the 0.1 % central difference of the other check.
KINK_STEP = 0.05
#: Tolerance of the kink check, on relative derivatives ``(p/U) dU/dp`` [-]: a one-sided slope
#: disagrees when ``|D_side - D_IFT| > KINK_ABS_TOL + KINK_REL_TOL |D_IFT|``. Across the step
#: ``h`` the disagreement moves the speed by ``h |D_side - D_IFT|`` of ``U``: the absolute part,
#: 0.02 at h = 5 %, is 0.1 % of ``U`` -- the mesh-convergence error of the speed (0.08 % on
#: Humber), so smaller disagreements are under what the model resolves; the relative part says
#: a bar of the tornado is more than a quarter too long or too short over the step. A smooth
#: ``U`` passes unless it bends strongly: its one-sided slopes differ from the derivative by
#: ``(h/2) |p^2 U''/U|``.
KINK_ABS_TOL = 0.02
KINK_REL_TOL = 0.25


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


# --------------------------------------------------------------------------- kink check


def kink_check(p0: float, h: float, u0: float, u_minus: float, u_plus: float,
               d_ift: float = np.nan, labels: tuple[str, str, str] = ("", "", ""),
               abs_tol: float = KINK_ABS_TOL, rel_tol: float = KINK_REL_TOL) -> dict:
    """One-sided slopes of ``U(p)`` over a finite step, and whether a derivative describes them.

    Parameters
    ----------
    p0, h : float
        Nominal value and (absolute, positive) step of the input.
    u0, u_minus, u_plus : float
        The speed [m/s] at ``p0``, ``p0 - h``, ``p0 + h`` (NaN: no crossing found).
    d_ift : float
        The derivative at ``p0`` [m/s per unit of p] (NaN when not available: the central
        slope, the mean of the one-sided ones, stands in for it).
    labels : (str, str, str)
        Critical branch at ``p0``, ``p0 - h``, ``p0 + h`` (empty: unknown, not compared).
    abs_tol, rel_tol : float
        Tolerance on relative derivatives (:data:`KINK_ABS_TOL`, :data:`KINK_REL_TOL`).

    Returns
    -------
    dict
        ``derivative_minus`` ``(U0 - U(p0 - h)) / h``, ``derivative_plus`` ``(U(p0 + h) - U0) /
        h`` [m/s per unit of p], their relative forms ``relative_derivative_minus/plus``
        ``(p0/U0) dU/dp`` [-], ``kink`` (True: the critical branch changes within the step,
        the crossing is lost on one side, or a one-sided slope disagrees beyond the tolerance;
        None: not assessed, the nominal speed is not finite) and ``kink_reason`` (text).
    """
    out = {"derivative_minus": np.nan, "derivative_plus": np.nan,
           "relative_derivative_minus": np.nan, "relative_derivative_plus": np.nan,
           "kink": None, "kink_reason": ""}
    if not (np.isfinite(u0) and u0 != 0 and h > 0):
        out["kink_reason"] = "not assessed: no nominal speed"
        return out
    dm, dp = (u0 - u_minus) / h, (u_plus - u0) / h
    scale = p0 / u0
    rm, rp, ri = scale * dm, scale * dp, scale * d_ift
    out.update(derivative_minus=float(dm), derivative_plus=float(dp),
               relative_derivative_minus=float(rm), relative_derivative_plus=float(rp))
    reasons = []
    l0, lm, lp = labels
    switched = [f"{side} {lab}" for side, lab in (("-", lm), ("+", lp)) if l0 and lab
                and lab != l0]
    if switched:
        reasons.append(f"critical branch {l0} at p, " + ", ".join(switched) + " at p±step")
    lost = [side for side, u in (("-", u_minus), ("+", u_plus)) if not np.isfinite(u)]
    if lost:
        reasons.append("no crossing at p" + "/".join(lost) + "step")
    if np.isfinite(ri):
        tol = abs_tol + rel_tol * abs(ri)
        off = [(side, r) for side, r in (("-", rm), ("+", rp)) if np.isfinite(r)
               and abs(r - ri) > tol]
        if off:
            reasons.append("one-sided " + ", ".join(f"{s}step {r:.3g}" for s, r in off)
                           + f" vs IFT {ri:.3g} (tolerance {tol:.3g}, relative)")
    elif np.isfinite(rm) and np.isfinite(rp):
        # no derivative: the central slope stands in for it (each side is half the spread off)
        tol = abs_tol + rel_tol * abs(rm + rp) / 2
        if abs(rp - rm) / 2 > tol:
            reasons.append(f"one-sided -step {rm:.3g} vs +step {rp:.3g} "
                           f"(tolerance {tol:.3g}, relative)")
    out["kink"] = bool(reasons)
    out["kink_reason"] = "; ".join(reasons)
    return out


def kink_entries(q: str, p0: float, h: float, crit: dict, minus: dict, plus: dict,
                 d_ift: float) -> dict:
    """A row's kink-check entries for quantity ``q`` (:func:`kink_check` on the nominal ``crit``
    and the critical speeds at ``p0 -+ h``): ``d_<q>_speed_minus``, ``d_<q>_speed_plus``,
    ``relative_d_<q>_speed_minus/plus``, ``<q>_kink``, ``<q>_kink_reason``."""
    k, b = f"{q}_speed_m_s", f"{q}_branch_label"
    c = kink_check(p0, h, crit[k], minus[k], plus[k], d_ift,
                   (crit[b] or "", minus[b] or "", plus[b] or ""))
    key = f"d_{q}_speed"
    return {f"{key}_minus": c["derivative_minus"], f"{key}_plus": c["derivative_plus"],
            f"relative_{key}_minus": c["relative_derivative_minus"],
            f"relative_{key}_plus": c["relative_derivative_plus"],
            f"{q}_kink": c["kink"], f"{q}_kink_reason": c["kink_reason"]}


def any_kink(row: dict) -> bool | None:
    """``kink`` of a row: True when the flutter or the divergence check flags one, None when
    neither was assessed."""
    flags = [row.get(f"{q}_kink") for q in ("flutter", "divergence")]
    if all(f is None for f in flags):
        return None
    return any(bool(f) for f in flags)


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
        quotient straddles a branch switch). The kink check (``check=True``): ``d_<q>_speed_minus``
        and ``d_<q>_speed_plus`` (one-sided differences of the full pipeline over the step
        ``settings["rel_step_kink"]``, 5 % by default), their ``relative_`` forms,
        ``<q>_kink`` (True: the critical branch changes within the step, or a one-sided slope
        disagrees with the IFT derivative beyond :data:`KINK_ABS_TOL` + :data:`KINK_REL_TOL`
        times it -- the derivative does not describe the speed over the step; None: not
        assessed), ``<q>_kink_reason`` and ``kink`` (flutter or divergence flagged).
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
        """The ``bridgeflap sensitivity`` JSON contract.

        Returns
        -------
        dict
            The flutter and divergence speeds [m/s] and statuses, the branch labels, the mode
            count, the settings, the kinked parameters and, under ``derivatives``, per parameter
            its value in SI units, the derivatives of each speed ([m/s] per SI unit) by the IFT
            and the checks, and the relative derivatives [-].
        """
        return {"bridge": self.bridge, "flutter_speed_m_s": self.flutter_speed_m_s,
                "flutter_status": self.flutter_status,
                "critical_branch_label": self.critical_branch_label,
                "divergence_branch_label": self.divergence_branch_label,
                "divergence_speed_m_s": self.divergence_speed_m_s,
                "divergence_status": self.divergence_status, "modes_retained": self.n_modes,
                "settings": dict(self.settings),
                # inputs whose derivative does not describe the speed over the kink step
                "kinked_parameters": [r["parameter"] for r in self.rows if r.get("kink")],
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
        """Strict JSON: :meth:`summary` (its derivative keys carry their units).

        Returns
        -------
        dict
            :meth:`summary` with NaN and infinities as ``None``.
        """
        return jsonable(self.summary())

    def table(self, fmt: str = "simple") -> str:
        """Text table of the IFT derivatives and both checks (:mod:`tabulate`).

        Parameters
        ----------
        fmt : str, default "simple"
            A :mod:`tabulate` table format.

        Returns
        -------
        str
            One row per parameter: its value, the flutter-speed derivative by the IFT and the
            checks, the relative derivatives [-] and the statuses.
        """
        cols = {"parameter": "parameter", "value_si": "value",
                "d_flutter_speed_m_s_per_unit": "dUF/dp IFT",
                "d_flutter_speed_m_s_per_unit_fd": "full FD",
                "d_flutter_speed_m_s_per_unit_fixed_basis": "fixed-basis",
                "d_flutter_speed_m_s_per_unit_ritz_fd": "Ritz FD",
                "relative_d_flutter_speed": "p/UF dUF/dp",
                "relative_d_flutter_speed_minus": "p/UF one-sided -",
                "relative_d_flutter_speed_plus": "p/UF one-sided +",
                "relative_d_divergence_speed": "p/UD dUD/dp",
                "kink": "kink"}
        frame = self.to_dataframe().reindex(columns=list(cols))
        frame["kink"] = [_kink_mark(r) for r in self.rows]
        table = table_text(frame.rename(columns=cols), fmt, floatfmt=".5g")
        flagged = [r for r in self.rows if r.get("kink")]
        if flagged:  # say what the mark means, under the table
            step = self.settings.get("rel_step_kink", KINK_STEP)
            table += (f"\nkink: the derivative does not describe the speed over ±{100 * step:g} %"
                      " of the input (branch switch or one-sided slopes off the IFT one); "
                      "UF = flutter, UD = divergence:")
            for r in flagged:
                why = "; ".join(f"{m}: {r[f'{q}_kink_reason']}"
                                for q, m in (("flutter", "UF"), ("divergence", "UD"))
                                if r.get(f"{q}_kink"))
                table += f"\n  {r['parameter']}: {why}"
        return table

    def plot(self, ax=None):
        """Tornado plot of the relative derivatives ``(p/U) dU/dp`` (flutter and divergence).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 0.45 * len(self.rows) + 1.5))
        rel_f = np.array([r["relative_d_flutter_speed"] for r in self.rows], dtype=float)
        rel_d = np.array([r["relative_d_divergence_speed"] for r in self.rows], dtype=float)
        order = np.argsort(np.nan_to_num(np.abs(rel_f)))
        y = np.arange(len(order))
        ax.barh(y + 0.2, rel_f[order], height=0.4, color="C3", label="flutter")
        ax.barh(y - 0.2, rel_d[order], height=0.4, color="C0", label="torsional divergence")
        # the kink check: one-sided slopes over the step drawn on the flagged rows (the bar is
        # the derivative; the markers are what the speed does a few per cent away)
        step = self.settings.get("rel_step_kink", KINK_STEP)
        shown = False
        for j, i in enumerate(order):
            r = self.rows[i]
            for q, dy in (("flutter", 0.2), ("divergence", -0.2)):
                if not r.get(f"{q}_kink"):
                    continue
                lo = r.get(f"relative_d_{q}_speed_minus", np.nan)
                hi = r.get(f"relative_d_{q}_speed_plus", np.nan)
                ax.plot([lo, hi], [j + dy, j + dy], color="k", lw=0.8, zorder=3,
                        label=None if shown else (f"kink: one-sided slopes over −{100 * step:g} %"
                                                  f" (◀) and +{100 * step:g} % (▶)"))
                ax.plot([lo], [j + dy], "k<", ms=6, zorder=4)
                ax.plot([hi], [j + dy], "k>", ms=6, zorder=4)
                shown = True
        ax.set_yticks(y)
        ax.set_yticklabels([self.rows[i]["parameter"] + (" (kink)" if self.rows[i].get("kink")
                                                          else "") for i in order], fontsize=8)
        for tick, i in zip(ax.get_yticklabels(), order, strict=True):
            if self.rows[i].get("kink"):
                tick.set_color("C3")
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


def _kink_mark(row: dict) -> str:
    """The table's kink column: ``UF``/``UD`` for each flagged speed, ``-`` when none is
    flagged, empty when not assessed."""
    if row.get("kink") is None:
        return ""
    marks = [m for q, m in (("flutter", "UF"), ("divergence", "UD")) if row.get(f"{q}_kink")]
    return ",".join(marks) or "-"


def empty_entries(q: str, crit: dict) -> dict:
    """A row's entries for quantity ``q`` before they are computed: every derivative NaN, the
    status ``ok``, the branch the derivative is valid within and the kink check not assessed."""
    key = f"d_{q}_speed"
    return {key: np.nan, f"{key}_fixed_basis": np.nan, f"{key}_ritz_fd": np.nan,
            f"{key}_fd": np.nan, f"relative_{key}": np.nan,
            f"relative_{key}_fixed_basis": np.nan, f"relative_{key}_fd": np.nan,
            f"{key}_minus": np.nan, f"{key}_plus": np.nan, f"relative_{key}_minus": np.nan,
            f"relative_{key}_plus": np.nan,
            f"{q}_status": "ok", f"{q}_valid_within_branch": crit[f"{q}_branch_label"],
            f"{q}_kink": None, f"{q}_kink_reason": "not assessed"}


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
