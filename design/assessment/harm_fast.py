"""The fast do-no-harm row (:func:`bridgeflap.design.assessment.harm.harm_row`, ``method="fast"``).

Per variant, one modal model of the retained modes (``modes.solve(..., n_modes)``: the lowest
``n_modes`` of each family hold the lowest ``n_modes`` of both together, so the basis, labels and
Rayleigh damping are those of all modes; the lateral family, which the aeroelastic state leaves
out, is neither assembled nor solved), then:

1. **screening** on ``screen_modes`` (the lowest of the same modes): both loops by the fast
   sweep with ``critical_only`` (:func:`bridgeflap.model.stability.sweeps.sweep`);
2. **confirmation** on ``n_modes`` of the loops whose numbers may decide something
   (:func:`bridgeflap.design.assessment.harm.near_decision`, or asked for by
   :func:`bridgeflap.design.assessment.harm.do_no_harm` for the extremes): a loop whose screened
   critical mechanism is divergence, with no flutter crossing within
   :data:`bridgeflap.design.assessment.harm.SCREEN_MARGIN_REL` above it, by :func:`static_crossing`
   (the first root of ``det(K - U^2 Q)`` on ``n_modes``, exact, verified as a stable-to-unstable
   crossing of ``A(U)``); any other loop, or one whose static check fails, by the fast sweep on
   ``n_modes``.

Every sweep reads the first crossing alone: its coarse march ends :data:`STOP_AFTER_REL` past
the first unstable speed (``sweep(..., stop_after_rel=)``), not at the grid's end; the first
crossing is the whole-grid sweep's (tests/test_model/stability/test_stop_after.py).

Every loop's numbers carry their mode count (``open_loop_modes``, ``closed_loop_modes``) and the
screened speeds (``screen_*``) for the a-posteriori check of
:func:`bridgeflap.design.assessment.harm.do_no_harm`.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["LOOPS", "fast_row", "static_crossing"]

#: the two loops of a row, in the order of the row's keys
LOOPS = ("open_loop", "closed_loop")
#: a row reads each loop's first crossing alone, and whether another lies within
#: SCREEN_MARGIN_REL above it (the static path's condition): each sweep's march ends twice
#: that past the first unstable speed (``sweep(..., stop_after_rel=)``), not at the grid's end
STOP_AFTER_REL = 0.03


def _modal(spec, n: int):
    """The vertical and torsional modes of ``spec``, the lowest ``n`` of each: all the
    aeroelastic state uses (the lateral family is not solved)."""
    from bridgeflap.model.structure.fe import assemble
    from bridgeflap.model.structure.modes import solve

    return solve(assemble(spec, lateral=False), int(n))


def static_crossing(system, u_hint: float, margin: float, speed_tol: float = 1e-3):
    """The divergence speed [m/s] of ``system`` from its static condition, verified, or None.

    The first positive root ``U_s`` of ``det(K - U^2 Q)``
    (:func:`bridgeflap.model.stability.hopf_newton.static_roots`; a real eigenvalue of ``A(U)`` is
    zero exactly there, see :func:`bridgeflap.model.stability.hopf_newton ._static_seeded`) must lie
    within ``margin`` (relative) of ``u_hint``, the screened divergence speed; then Newton on ``A(U)
    v = 0`` from it (:func:`bridgeflap.model.stability.hopf_newton .divergence_newton`, converged to
    round-off), a transversal crossing (``d Re/dU > 0``, a well-conditioned eigenvalue), the
    eigenvalue real and changing sign across ``U -+ d``
    (:func:`bridgeflap.model.stability.hopf._check_bracket_sides`), and every other eigenvalue of
    ``A(U)`` (one dense solution) in the left half-plane: the crossing is the stability limit there.
    Flutter below it is excluded by the screening (the caller's condition). None: not verified.
    """
    from bridgeflap.model.stability.hopf import NEAR_DEFECTIVE, BalancedSystem, _check_bracket_sides
    from bridgeflap.model.stability.hopf_newton import (
        FastPathError,
        _inverse_vector,
        divergence_newton,
        static_roots,
    )
    from bridgeflap.model.stability.tracking import _scale, eigen_sensitivity, oscillation_tolerance

    roots = static_roots(system)
    if not roots.size or abs(roots[0] / u_hint - 1.0) > margin:
        return None
    u0 = float(roots[0]) * (1.0 - 1e-9)  # below the root: no exactly singular factorisation
    bal = BalancedSystem(system, float(roots[0]))
    omega_tol = oscillation_tolerance(system)
    try:
        v0 = _inverse_vector(bal, u0, 0.0, real=True)
        u, v, _, _ = divergence_newton(bal, u0, v0.real,
                                       bounds=(u0 * (1 - margin), u0 * (1 + margin)))
        vc = v.astype(complex)
        dlam, _, cond = eigen_sensitivity(bal, u, 0.0, vc)
        if cond < NEAR_DEFECTIVE or not dlam.real > 0:
            return None
        _check_bracket_sides(bal, u, 0.0j, vc, speed_tol, omega_tol, "divergence")
    except (FastPathError, np.linalg.LinAlgError):
        return None
    ev = np.linalg.eigvals(system.A(u))
    k = int(np.argmin(np.abs(ev)))
    if abs(ev[k]) > 1e-8 * _scale(system.A(u)):
        return None  # the Newton point is no eigenvalue of A(u)
    others = np.delete(ev, k)
    if others.size and others.real.max() > 1e-6 * omega_tol:
        return None  # something else is unstable at the crossing
    return float(u)


def _summaries(spec, model, compensator, speeds, n_modes, loops):
    """``{loop: FlutterResult summary}`` of the fast sweep (``critical_only``) on ``n_modes``."""
    from bridgeflap.model.analysis import FlutterResult
    from bridgeflap.model.stability.sweeps import sweep

    systems = {"open_loop": lambda: model.open_loop,
               "closed_loop": lambda: model.system(compensator)}
    out = {}
    for loop in loops:
        system = systems[loop]()
        sw = sweep(system, speeds, method="fast", critical_only=True,
                   stop_after_rel=STOP_AFTER_REL)
        out[loop] = FlutterResult(spec, sw, int(n_modes), "modal", "rfa4",
                                  system.n_states).summary()
    return out


def _static_eligible(summary, crit, margin) -> bool:
    """A screened loop whose critical mechanism is a converged divergence and whose flutter
    crossing is absent or more than ``margin`` above it."""
    u, mech, ok = crit
    if not ok or mech != "divergence" or math.isinf(u):
        return False
    if summary.get("flutter_status") == "no_crossing_in_range":
        return True
    uf = summary.get("flutter_speed_m_s")
    return (summary.get("flutter_status") == "converged" and uf is not None
            and uf > u * (1.0 + margin))


def _crit_of(row, loop):
    """``(speed or inf, mechanism, resolved)`` of one loop of a row (``resolved``: the row's,
    which is true only when both loops are)."""
    u = row[f"{loop}_critical_speed_m_s"]
    return (math.inf if u is None else float(u), row[f"{loop}_mechanism"], bool(row["resolved"]))


def fast_row(spec, controller, speeds, n_modes, speed_max_m_s, screen_modes=None,
             confirm=None, screened=None) -> dict:
    """The fast row of one variant (module docstring).

    ``confirm``: loops to put on ``n_modes`` besides those
    :func:`bridgeflap.design.assessment.harm.near_decision` names (``do_no_harm``'s extremes);
    ``screened``: the row of an earlier call, whose screening is then reused (its loops already on
    ``n_modes`` stay).
    """
    from bridgeflap.design.assessment.harm_verdict import (
        SCREEN_MARGIN_REL,
        _crit,
        _row,
        near_decision,
    )
    from bridgeflap.model.aeroelastic.flaps import closed_loop_model

    n = int(n_modes)
    modal = _modal(spec, n)
    c = controller

    def model_at(m):
        return closed_loop_model(spec, c.flap_strip_positions_m, c.flap_width_m, m, c.chord_m,
                                 c.leading_edge, c.trailing_edge, modal=modal)

    screen = {f"screen_{loop}_critical_speed_m_s": None for loop in LOOPS}
    if screen_modes is None or int(screen_modes) >= n:
        full = _summaries(spec, model_at(n), c.compensator, speeds, n, LOOPS)
        return {**_row({k: _crit(s) for k, s in full.items()}, speed_max_m_s,
                       {k: n for k in LOOPS}), **screen}
    m = int(screen_modes)
    if screened is None:
        sums = _summaries(spec, model_at(m), c.compensator, speeds, m, LOOPS)
        crits = {k: _crit(s) for k, s in sums.items()}
        static_ok = {k: _static_eligible(sums[k], crits[k], SCREEN_MARGIN_REL) for k in LOOPS}
        modes = {k: m for k in LOOPS}
        row = _row(crits, speed_max_m_s, modes)
        screen = {f"screen_{k}_critical_speed_m_s": row[f"{k}_critical_speed_m_s"]
                  for k in LOOPS}
        screen.update({f"screen_{k}_static": static_ok[k] for k in LOOPS})
    else:  # the loops as they stand: screened, or already on n_modes
        row = {k: v for k, v in screened.items() if not k.startswith("screen_")}
        crits = {k: _crit_of(row, k) for k in LOOPS}
        modes = {k: row[f"{k}_modes"] for k in LOOPS}
        static_ok = {k: bool(screened.get(f"screen_{k}_static")) for k in LOOPS}
        screen = {k: v for k, v in screened.items() if k.startswith("screen_")}
    near = near_decision(row, speed_max_m_s)
    todo = tuple(k for k in LOOPS if k in near or (confirm is not None and k in confirm))
    if not todo:
        return {**row, **screen}
    big = model_at(n)  # todo: loops still on the screening's modes
    sweep_loops = []
    todo = tuple(k for k in todo if modes[k] != n)
    if not todo:
        return {**row, **screen}
    for k in todo:
        if static_ok[k]:
            system = big.open_loop if k == "open_loop" else big.system(c.compensator)
            u = static_crossing(system, crits[k][0], SCREEN_MARGIN_REL)
            if u is not None:
                crits[k], modes[k] = (u, "divergence", True), n
                continue
        sweep_loops.append(k)
    for k, s in _summaries(spec, big, c.compensator, speeds, n, sweep_loops).items():
        crits[k], modes[k] = _crit(s), n
    return {**_row(crits, speed_max_m_s, modes), **screen}
