"""Symbolic CasADi state matrix ``A(U, p)`` of the bridge (modal lag order).

``p`` holds the parameters a designer varies, **relative to nominal** (``p = 1`` is the bridge
file's value), in the order of :data:`SYMBOLIC_PARAMETERS`:

========================  ==========================================================
``damping.ratio``         Rayleigh ratio; ``C = zeta/zeta0 (a_M M + a_K K)`` (coefficients
                          fitted at the nominal first vertical and torsional frequencies)
``deck.mass_kg_per_m``    enters the mass and, through the dead load, the cable tension
``deck.mass_inertia_...`` torsional mass
``deck.gj_nm2``           torsional stiffness
``deck.ei_vertical_nm2``  vertical bending stiffness
``cable.main_sag_m``      cable tension, geometric and cable-stretching stiffness
``deck.half_chord_m``     ``b`` in every aerodynamic term and in the lag rates ``beta U/b``
``aero.air_density...``   ``rho`` in every aerodynamic term
========================  ==========================================================

The structural parameters act through a **Ritz projection on the nominal modes**: with ``Phi``
the retained mass-normalised nominal modes, ``M(p) = I + sum_k (p_k - 1) Phi^T dM_k Phi`` and
likewise for ``K``, where ``dM_k = p0_k dM_FE/dp_k`` is the change of the assembled FE matrices
(central difference of the assembly, exact for the parameters that enter linearly: mass,
inertia, GJ, EI; first order for the sag and the dead-load part of the deck mass). This is
exact at nominal and first-order accurate away from it within the retained basis; the numeric
path (:func:`model.analysis.bridge_system`) re-solves the modes instead. Half-chord and air
density enter exactly. ``U`` enters as ``A0 + U A1 + U^2 A2`` as in :mod:`model.statespace`.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from model.analysis import DEFAULT_MODES, modal_model
from model.fe import assemble
from model.modes import ModalModel
from model.rfa import RationalApprox, get_rfa
from model.spec import BridgeSpec, get_path

SYMBOLIC_PARAMETERS = (
    "damping.ratio",
    "deck.mass_kg_per_m",
    "deck.mass_inertia_kgm2_per_m",
    "deck.gj_nm2",
    "deck.ei_vertical_nm2",
    "cable.main_sag_m",
    "deck.half_chord_m",
    "aero.air_density_kg_m3",
)
_STRUCTURAL = SYMBOLIC_PARAMETERS[1:6]


@dataclass(frozen=True)
class SymbolicModel:
    """``A_fun(U, p)`` as a named CasADi Function plus what produced it."""

    A_fun: ca.Function
    parameters: tuple
    nominal_values: np.ndarray
    n_modes: int
    labels: tuple
    n_states: int

    def A(self, wind_speed: float, p=None) -> np.ndarray:
        """Numeric ``A`` at ``wind_speed`` [m/s] and relative parameters ``p`` (default 1)."""
        p = np.ones(len(self.parameters)) if p is None else np.asarray(p, dtype=float)
        return np.array(self.A_fun(wind_speed, p))


def _projected_derivatives(spec: BridgeSpec, modal: ModalModel, chosen: list[int],
                           rel_step: float = 1e-3):
    """Ritz-projected ``(dM_k, dK_k)`` per unit relative change of each structural parameter."""
    n = len(chosen)
    out = {}
    for path in _STRUCTURAL:
        p0 = get_path(spec, path)
        mats = []
        for sgn in (+1, -1):
            st = assemble(spec.replace(**{path: p0 * (1 + sgn * rel_step)}))
            dM, dK = np.zeros((n, n)), np.zeros((n, n))
            for fam in ("vertical", "torsional"):
                cols = [j for j, i in enumerate(chosen) if modal.modes[i].family == fam]
                if not cols:
                    continue
                Phi = np.column_stack([modal.shape(chosen[j]) for j in cols])
                F = st.families[fam]
                if F.M.shape[0] != Phi.shape[0]:  # pragma: no cover - mesh must not change
                    raise RuntimeError(f"mesh changed when perturbing {path}")
                dM[np.ix_(cols, cols)] = Phi.T @ F.M @ Phi
                dK[np.ix_(cols, cols)] = Phi.T @ F.K @ Phi
            mats.append((dM, dK))
        (Mp, Kp), (Mm, Km) = mats
        out[path] = ((Mp - Mm) / (2 * rel_step), (Kp - Km) / (2 * rel_step))
    return out


def build_symbolic(spec: BridgeSpec, n_modes: int = DEFAULT_MODES,
                   rfa: RationalApprox | str = "rfa4", modal: ModalModel | None = None,
                   ) -> SymbolicModel:
    """Build ``A(U, p)`` (modal lag order) for ``spec`` with relative parameters ``p``."""
    modal = modal_model(spec) if modal is None else modal
    rfa = get_rfa(rfa) if isinstance(rfa, str) else rfa
    basis = modal.structural_basis(n_modes)
    chosen = [i for i, m in enumerate(modal.modes) if m.family in ("vertical", "torsional")]
    chosen = chosen[:n_modes]
    n = len(chosen)
    derivs = _projected_derivatives(spec, modal, chosen)
    omega = np.sqrt(np.diag(basis.K))
    a_m, a_k = modal.rayleigh
    zeta0 = spec.damping.ratio

    U = ca.SX.sym("U")
    p = ca.SX.sym("p", len(SYMBOLIC_PARAMETERS))
    M = ca.SX(np.eye(n))
    K = ca.SX(np.diag(omega ** 2))
    for k, path in enumerate(SYMBOLIC_PARAMETERS):
        if path in derivs:
            dM, dK = derivs[path]
            M = M + (p[k] - 1) * ca.DM(dM)
            K = K + (p[k] - 1) * ca.DM(dK)
    zeta_rel = p[0]
    C = zeta_rel * (a_m * M + a_k * K) if zeta0 > 0 else ca.SX.zeros(n, n)
    b = spec.deck.half_chord_m * p[SYMBOLIC_PARAMETERS.index("deck.half_chord_m")]
    rho = spec.aero.air_density_kg_m3 * p[SYMBOLIC_PARAMETERS.index("aero.air_density_kg_m3")]
    kappa = 1.0 if spec.aero.added_inertia else 0.0
    dl = basis.strip_length[:, None]
    ph, pa = basis.phi_h, basis.phi_a
    Shh = ca.DM(ph.T @ (dl * ph))
    Sha = ca.DM(ph.T @ (dl * pa))
    Saa = ca.DM(pa.T @ (dl * pa))
    PhT = ca.DM((dl * ph).T)
    PaT = ca.DM((dl * pa).T)
    M_nc = np.pi * rho * b ** 2 * Shh + kappa * np.pi * rho * b ** 4 / 8 * Saa
    D_nc = np.pi * rho * b ** 2 * Sha + np.pi * rho * b ** 3 / 2 * Saa
    P = -2 * np.pi * rho * b * PhT + np.pi * rho * b ** 2 * PaT
    G1 = ca.DM(ph) + 0.5 * b * ca.DM(pa)
    G0 = ca.DM(pa)
    Mt = M + M_nc
    nl = rfa.n_lags
    nx = 2 * n + nl * n
    rows_q = ca.horzcat(ca.SX.zeros(n, n), ca.SX.eye(n), ca.SX.zeros(n, nl * n))
    force_q = -K + U ** 2 * 0.5 * (P @ G0)
    force_v = -C + U * (-D_nc + 0.5 * (P @ G1))
    force_lag = [U * rfa.gains[j] * ca.SX.eye(n) for j in range(nl)]
    rows_v = ca.solve(Mt, ca.horzcat(force_q, force_v, *force_lag))
    lag_rows = []
    for j in range(nl):
        rate = rfa.poles[j] * U / b
        blocks = [rate * U * (P @ G0), rate * (P @ G1)]
        blocks += [(-rate * ca.SX.eye(n)) if i == j else ca.SX.zeros(n, n) for i in range(nl)]
        lag_rows.append(ca.horzcat(*blocks))
    A = ca.vertcat(rows_q, rows_v, *lag_rows)
    A_fun = ca.Function("A", [U, p], [A], ["U", "p"], ["A"])
    assert A.shape == (nx, nx)
    return SymbolicModel(A_fun=A_fun, parameters=SYMBOLIC_PARAMETERS,
                         nominal_values=np.array([get_path(spec, q) for q in SYMBOLIC_PARAMETERS]),
                         n_modes=n, labels=basis.labels, n_states=nx)
