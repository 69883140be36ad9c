"""Named CasADi functions of the one assembly: open-loop ``A(U, p)``, closed-loop ``A_cl``.

Both are built by :mod:`model.assembly` from CasADi symbols (the backend shim of
:mod:`model.backend`), from the same code as the numeric matrices of :mod:`model.statespace`
and :mod:`model.flaps`. This is one of the two files of :mod:`model` allowed to import CasADi.

Open loop, modal lag order: ``A(U, p)``.

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
inertia, GJ, EI; first order for the sag and the dead-load part of the deck mass) of the Ritz
basis of :func:`model.ritz.ritz_basis`. This is
exact at nominal and first-order accurate away from it within the retained basis; the numeric
path (:func:`model.statespace.spec_system` on re-solved modes) re-solves the modes instead.
Half-chord and air density enter exactly. ``U`` enters as ``A0 + U A1 + U^2 A2`` as in
:mod:`model.statespace`.

Closed loop (:func:`closed_loop_functions`): ``A_cl(U, theta, w)`` and ``A_parts(theta, w) ->
(A0, A1, A2)`` with the compensator coefficients ``theta = (b2, b1, b0, a2, a1)`` and the
per-flap weights ``w``, the functions the compensator optimiser differentiates.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from model.aero import strip_aero
from model.assembly import compensator_matrices, open_pieces, rfa_parts
from model.basis import StructuralBasis
from model.fe import assemble
from model.modes import ModalModel, solve
from model.rfa import RationalApprox, get_rfa
from model.ritz import chosen_modes, ritz_basis
from model.spec import BridgeSpec, get_path

__all__ = ["SYMBOLIC_PARAMETERS", "SymbolicModel", "build_symbolic", "closed_loop_functions"]

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
    """``A_fun(U, p)`` and ``parts_fun(p) -> (A0, A1, A2)`` as named CasADi Functions."""

    A_fun: ca.Function
    parts_fun: ca.Function
    parameters: tuple
    nominal_values: np.ndarray
    n_modes: int
    labels: tuple
    n_states: int

    def A(self, wind_speed: float, p=None) -> np.ndarray:
        """Numeric ``A`` at ``wind_speed`` [m/s] and relative parameters ``p`` (default 1)."""
        p = np.ones(len(self.parameters)) if p is None else np.asarray(p, dtype=float)
        return np.array(self.A_fun(wind_speed, p))


def _projected_derivatives(spec: BridgeSpec, modal: ModalModel, n_modes: int,
                           rel_step: float = 1e-3) -> dict:
    """``(dM_k, dK_k)`` per unit relative change of each structural parameter (Ritz basis)."""
    out = {}
    for path in _STRUCTURAL:
        p0 = get_path(spec, path)
        plus, minus = (ritz_basis(spec.replace(**{path: p0 * (1 + sgn * rel_step)}), modal,
                                  n_modes) for sgn in (+1, -1))
        out[path] = ((plus.M - minus.M) / (2 * rel_step), (plus.K - minus.K) / (2 * rel_step))
    return out


def build_symbolic(spec: BridgeSpec, n_modes: int, rfa: RationalApprox | str = "rfa4",
                   modal: ModalModel | None = None) -> SymbolicModel:
    """Build ``A(U, p)`` (modal lag order) for ``spec`` with relative parameters ``p``.

    Parameters
    ----------
    spec : BridgeSpec
    n_modes : int
        Retained vertical and torsional modes.
    rfa : RationalApprox or str
        Rational approximation of C(k).
    modal : ModalModel, optional
        Nominal modes (solved from ``spec`` when omitted).
    """
    modal = solve(assemble(spec)) if modal is None else modal
    rfa = get_rfa(rfa) if isinstance(rfa, str) else rfa
    nominal = modal.structural_basis(n_modes)
    n = len(chosen_modes(modal, n_modes))
    derivs = _projected_derivatives(spec, modal, n_modes)
    omega = np.sqrt(np.diag(nominal.K))
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
    C = p[0] * (a_m * M + a_k * K) if zeta0 > 0 else ca.SX.zeros(n, n)
    b = spec.deck.half_chord_m * p[SYMBOLIC_PARAMETERS.index("deck.half_chord_m")]
    rho = spec.aero.air_density_kg_m3 * p[SYMBOLIC_PARAMETERS.index("aero.air_density_kg_m3")]
    basis = StructuralBasis(M=M, C=C, K=K, phi_h=nominal.phi_h, phi_a=nominal.phi_a,
                            strip_length=nominal.strip_length, strip_x=nominal.strip_x,
                            labels=nominal.labels)
    a = spec.aero
    aero = strip_aero(basis, b, rho, a.added_inertia, a.lift_slope_buffeting,
                      a.moment_slope_buffeting)
    A0, A1, A2, _, _ = rfa_parts(open_pieces(basis, aero, "modal"), rfa)
    parts_fun = ca.Function("A_parts", [p], [A0, A1, A2], ["p"], ["A0", "A1", "A2"])
    A_fun = ca.Function("A", [U, p], [A0 + U * A1 + U ** 2 * A2], ["U", "p"], ["A"])
    return SymbolicModel(A_fun=A_fun, parts_fun=parts_fun, parameters=SYMBOLIC_PARAMETERS,
                         nominal_values=np.array([get_path(spec, q) for q in SYMBOLIC_PARAMETERS]),
                         n_modes=n, labels=nominal.labels, n_states=int(A0.shape[0]))


def closed_loop_functions(model) -> dict:
    """``{"A_parts": (theta, w) -> (A0, A1, A2), "A_cl": (U, theta, w) -> A}`` of a flap model.

    Parameters
    ----------
    model : model.flaps.ClosedLoopModel
        Open-loop system (modal order) and flap set.
    """
    theta = ca.SX.sym("theta", 5)
    w = ca.SX.sym("w", model.n_flaps)
    A0, A1, A2, _, _ = rfa_parts(model.pieces(w), model.open_loop.rfa,
                                 compensator_matrices(theta))
    parts = ca.Function("A_parts", [theta, w], [A0, A1, A2], ["theta", "w"],
                        ["A0", "A1", "A2"])
    U = ca.SX.sym("U")
    th2, w2 = ca.SX.sym("theta", 5), ca.SX.sym("w", model.n_flaps)
    P0, P1, P2 = parts(th2, w2)
    A_cl = ca.Function("A_cl", [U, th2, w2], [P0 + U * P1 + U * U * P2], ["U", "theta", "w"],
                       ["A"])
    return {"A_parts": parts, "A_cl": A_cl}
