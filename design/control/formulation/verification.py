"""The dense a posteriori check of a compensator design
(:meth:`bridgeflap.design.control.formulation.nlp.DesignProblem.verify`).

Every eigenvalue of the closed loop on the check grid (the spectral abscissa), the damping of the
branches the flaps can move against ``zeta_min``, and the compensator's peak gain.
"""

from __future__ import annotations

import numpy as np

from bridgeflap.design.control.formulation.nlp_tolerances import VIOLATION_TOL
from bridgeflap.design.control.formulation.plant import (
    damping_check,
    damping_check_refined,
    lag_rates,
)
from bridgeflap.design.control.results.records import Verification
from bridgeflap.model.aeroelastic.control import Compensator


def verify(prob, theta, weights=None, refined=False) -> Verification:
    """Check ``theta`` (b2, b1, b0, a2, a1) with flap ``weights`` on ``prob`` (a
    :class:`bridgeflap.design.control.formulation.nlp.DesignProblem`) on its settings' check grid
    ``check_speeds()``.

    ``refined``: on the subset of the check grid of
    :func:`bridgeflap.design.control.formulation.plant.damping_check_refined` (a coarse grid refined
    where a threshold could be reached; the same decisions; ``speeds_m_s`` then lists the speeds
    checked). With ``prob.speed_guard_rel > 0`` (the design model of a start) the damping is
    checked at the guard speed ``speed_max_m_s (1 + speed_guard_rel)`` too, outside the grid's
    arrays (:data:`bridgeflap.design.control.formulation.nlp_tolerances.SPEED_GUARD_REL`).
    """
    s = prob.settings
    U = s.check_speeds()
    parts = prob.A_parts(theta, weights)
    red = prob.reduction(parts[0].shape[0])
    if red is not None:         # exact: the dropped eigenvalues are compensator poles
        parts = (*[red[1] @ (a @ red[0]) for a in parts[:3]], red[2])
    if refined:
        chk = damping_check_refined(parts, U, lag_rates(prob.model), theta, s.zeta_min,
                                    VIOLATION_TOL)
        U = chk["speeds_m_s"]
    else:
        chk = damping_check(parts, U, lag_rates(prob.model), theta, s.zeta_min)
    absc = chk["abscissa_1_s"]
    viol = chk["measure_1_s"]
    max_viol = float(viol.max())
    u_guard = v_guard = float("nan")
    guard = float(getattr(prob, "speed_guard_rel", 0.0))
    if guard > 0:
        u_guard = float(s.speed_max_m_s) * (1.0 + guard)
        v_guard = float(damping_check(parts, [u_guard], lag_rates(prob.model), theta,
                                      s.zeta_min)["measure_1_s"][0])
        max_viol = max(max_viol, v_guard)
    comp = Compensator(*(float(v) for v in theta))
    stable = absc < 0
    stable_to = float(U[-1]) if stable.all() else (
        float(U[np.argmax(~stable) - 1]) if np.argmax(~stable) > 0 else 0.0)
    return Verification(speeds_m_s=U, abscissa_1_s=absc, violation_1_s=viol,
                        max_violation_1_s=max_viol,
                        stable_everywhere=bool(stable.all()), stable_to_m_s=stable_to,
                        max_gain=comp.max_gain(), modes=int(prob.model.open_loop.basis.n),
                        step_m_s=s.check_step_m_s,
                        meets_damping=bool(max_viol <= VIOLATION_TOL),
                        min_damping_ratio=float(chk["zeta"].min()),
                        min_damping_speed_m_s=float(U[int(np.argmin(chk["zeta"]))]),
                        damping_ratio=chk["zeta"], guard_speed_m_s=u_guard,
                        guard_violation_1_s=v_guard)
