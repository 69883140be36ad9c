"""The flap loop's algebra in real arithmetic, shared by the robustness terms
(:mod:`bridgeflap.design.control.formulation.robust`) and the buffeting term
(:mod:`bridgeflap.design.control.formulation.buffeting_term`): ``K(j omega)`` of the 2nd-order
compensator for symbolic or numeric coefficients, the real block form of ``I - K N``, and the rank
tolerance of the flap pitch map. A leaf module: it imports neither."""

from __future__ import annotations

import casadi as ca

#: Relative singular value of ``Phi_a`` below which a direction counts as absent in
#: :func:`design.control.formulation.robust.lowrank_robust_data` (the pitch map of 25 flaps on 16
#: modes has rank 4 exactly: only the torsional modes pitch; the rest of its spectrum is round-off,
#: ~1e-16).
LOWRANK_RTOL = 1e-12


def k_complex(th, om):
    """Real and imaginary parts of ``K(j om)`` for symbolic or numeric theta."""
    b2, b1, b0, a2, a1 = (th[i] for i in range(5))
    nr, ni = b0 - b2 * om * om, b1 * om
    dr, di = 1 - a2 * om * om, a1 * om
    d2 = dr * dr + di * di
    return (nr * dr + ni * di) / d2, (ni * dr - nr * di) / d2


def _loop_block(Kr, Ki, Nr, Ni):
    """``I - K N`` (``K = Kr + i Ki`` scalar, ``N = Nr + i Ni`` square) as the real block matrix
    ``[[Re, -Im], [Im, Re]]`` of a complex solve in real arithmetic."""
    Mr = ca.DM.eye(Nr.shape[0]) - (Kr * Nr - Ki * Ni)
    Mi = -(Kr * Ni + Ki * Nr)
    return ca.vertcat(ca.horzcat(Mr, -Mi), ca.horzcat(Mi, Mr))


#: The compensator's pole damping may fall short of ``compensator_damping_min`` by this
#: (relative): Ipopt meets the constraint to its ``constr_viol_tol`` (1e-6, relative as written
#: in :mod:`design.control.formulation.nlp`), so 1e-5 separates a met constraint from a violated
#: one.
COMPENSATOR_DAMPING_RTOL = 1e-5


def compensator_damping_ratio(theta) -> float:
    """Damping ratio [-] of the compensator's poles, ``a2 s^2 + a1 s + 1 = 0``:
    ``a1 / (2 sqrt(a2))`` (>= 1: two real poles)."""
    a2, a1 = float(theta[3]), float(theta[4])
    return a1 / (2.0 * a2 ** 0.5) if a2 > 0 else float("nan")


def compensator_damped(theta, zeta_min: float) -> bool:
    """Whether the compensator's poles meet ``zeta_min`` (within
    :data:`COMPENSATOR_DAMPING_RTOL`); always true for ``zeta_min = 0`` and a stable K."""
    z = compensator_damping_ratio(theta)
    return bool(z >= zeta_min * (1.0 - COMPENSATOR_DAMPING_RTOL)) if zeta_min > 0 else True
