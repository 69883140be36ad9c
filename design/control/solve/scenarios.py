"""Scenario design: the bridges of the stated uncertainty set that a design is held to.

A scenario design (``variants > 0``) imposes the damping constraint on the nominal bridge and on
``variants`` scenario bridges drawn (Sobol', ``variant_seed``) over the stated uncertainty set
(:data:`bridgeflap.design.control.uncertainty.DEFAULT_UNCERTAIN_RANGES` less ``variant_fixed``),
plus the corners of the inputs named in ``variant_corners`` (each at its low or high end, the others
nominal: the bridges whose modes move furthest). Calafiore and Campi's scenario approach; the
certificate comes afterwards, from fresh independent draws
(:mod:`bridgeflap.design.assessment.acceptance`).

With ``variant_rule = "no_harm"`` (the default card) scenario ``j`` is held to *do no harm*: its
closed loop must meet ``zeta_min`` at every speed below its own open-loop critical speed
``U_j`` (times ``1 +`` :data:`NO_HARM_SPEED_MARGIN`, and at most the do-no-harm check's grid end
:data:`NO_HARM_GRID_FACTOR` ``speed_max_m_s``), so its closed-loop critical speed is at least its
open-loop one by construction. ``U_j`` is the last stable speed of the scenario's open loop
(``K = 0``) on the design model's dense check grid, computed once per scenario and process
(:func:`open_loop_limit`). A scenario whose open loop is unstable below
:data:`NO_HARM_MIN_SPEED_M_S` cannot be harmed and carries no constraint. With
``variant_rule = "stable"`` every scenario is held to ``0 .. speed_max_m_s`` like the nominal
bridge (the stronger multi-model requirement).

A scenario's problem is the nominal one on its own bridge with ``speed_max_m_s`` set to its
limit, so the lazy constraint generation of :mod:`bridgeflap.design.control.formulation.variants`
and every check of a round read its own range.

**Actuators on the scenarios.** When the card holds the flap demand
(``actuator_design_speeds_m_s``), scenario ``j`` is held to it too, at one speed: the card's top
actuator design speed, or ``U_j`` when lower (:func:`scenario_demand_speed`). So on every scenario
the flaps stay within their limits up to its own open-loop critical speed (capped at the card's
actuator target): a scenario's usable speed is not below its open-loop one. One speed suffices:
over the actuator range the 3 sigma flap angle grows with the wind speed (measured on three of the
default card's scenarios at its five actuator speeds, 50-74 m/s: the demand rose with the speed on
each; the a posteriori record checks only the one speed). The constraints join the NLP lazily,
per scenario (:func:`bridgeflap.design.control.formulation.variants.demand_checks`).
"""

from __future__ import annotations

from dataclasses import replace
from itertools import product

import numpy as np

__all__ = ["NO_HARM_GRID_FACTOR", "NO_HARM_MIN_SPEED_M_S", "NO_HARM_SPEED_MARGIN",
           "corner_specs", "open_loop_limit", "scenario_demand_speed", "scenario_settings",
           "scenario_specs"]

#: the do-no-harm check sweeps to 1.5 ``speed_max_m_s`` (design.assessment.harm): a scenario is
#: held up to there at most
NO_HARM_GRID_FACTOR = 1.5
#: a scenario's closed loop is held to ``(1 + margin) U_j``: its open-loop ``U_j`` is read on the
#: design model (16 modes); on the 30 modes of the do-no-harm check a critical speed moves by
#: up to 0.70 % (design.assessment.harm_verdict.SCREEN_MARGIN_REL), so 1 % keeps the closed loop
#: above the check's open-loop speed
NO_HARM_SPEED_MARGIN = 0.01
#: below this open-loop critical speed [m/s] a scenario carries no constraint (it is unstable
#: with or without flaps over the whole useful range)
NO_HARM_MIN_SPEED_M_S = 5.0

_LIMITS: dict = {}


def corner_specs(settings, base) -> list:
    """The corners of ``settings.variant_corners`` (low/high of each, the others at ``base``'s
    values), in a fixed order (low before high, first input slowest)."""
    from bridgeflap.design.control.uncertainty import DEFAULT_UNCERTAIN_RANGES

    names = tuple(settings.variant_corners)
    return [base.replace(**dict(zip(names, vals, strict=True)))
            for vals in product(*(DEFAULT_UNCERTAIN_RANGES[n] for n in names))] if names else []


def scenario_specs(settings, base) -> list:
    """The scenario bridges of a design: the corners (:func:`corner_specs`), then ``variants``
    Sobol' draws (:func:`bridgeflap.design.control.review.checks.sample_variants`)."""
    from bridgeflap.design.control.review.checks import sample_variants

    return corner_specs(settings, base) + sample_variants(settings, base, settings.variants,
                                                          settings.variant_seed)


def open_loop_limit(settings, spec, model) -> float:
    """The last stable speed [m/s] of ``spec``'s open loop on the dense check grid to
    ``NO_HARM_GRID_FACTOR speed_max_m_s`` (the grid end when stable throughout), on ``model``
    (the design model on ``spec``; the flaps play no part at ``K = 0``). Cached per process."""
    from bridgeflap.design.control.formulation.nlp import DesignProblem

    key = (repr(spec), int(model.open_loop.basis.n), float(settings.speed_max_m_s),
           float(settings.check_step_m_s))
    if key not in _LIMITS:
        top = replace(settings, speed_max_m_s=NO_HARM_GRID_FACTOR * settings.speed_max_m_s,
                      optimise_placement=False, compensator_damping_min=0.0,
                      objective="margin")
        ver = DesignProblem(top, model, numeric=True).verify(
            np.array([0.0, 0.0, 0.0, 1.0, 1.0]), refined=True)
        _LIMITS[key] = float(top.speed_max_m_s if ver.stable_everywhere else ver.stable_to_m_s)
    return _LIMITS[key]


def open_loop_limits(settings, specs) -> dict:
    """:func:`open_loop_limit` of every scenario in ``specs`` on its design model, as the
    entries of this process's cache (``{key: speed}``): a worker's share, which the design's
    process then adopts (:func:`adopt_limits`) before it builds the scenario problems."""
    from bridgeflap.design.control.formulation.problem_model import build_model

    out = {}
    for spec in specs:
        model = build_model(settings, spec=spec)[1]
        open_loop_limit(settings, spec, model)
        out.update({k: v for k, v in _LIMITS.items() if k[0] == repr(spec)})
    return out


def adopt_limits(entries: dict) -> None:
    """Add the cache ``entries`` of :func:`open_loop_limits` (from a worker) to this process's."""
    _LIMITS.update(entries)


def scenario_demand_speed(settings, open_loop_m_s=None) -> tuple:
    """The actuator design speed [m/s] of a scenario (module docstring): ``()`` when the card
    holds no flap demand, else ``(min(top, open_loop_m_s),)`` with ``top`` the card's largest
    ``actuator_design_speeds_m_s`` (``open_loop_m_s`` None: ``top``)."""
    if not settings.actuator_design_speeds_m_s:
        return ()
    top = float(max(settings.actuator_design_speeds_m_s))
    return (top if open_loop_m_s is None else float(min(top, open_loop_m_s)),)


def scenario_settings(settings, spec, model):
    """The settings of scenario ``spec``'s problem (module docstring), or None when it carries
    no constraint."""
    if settings.variant_rule != "no_harm":
        return replace(settings, actuator_design_speeds_m_s=scenario_demand_speed(settings))
    u = open_loop_limit(settings, spec, model)
    if u < NO_HARM_MIN_SPEED_M_S:
        return None
    top = NO_HARM_GRID_FACTOR * settings.speed_max_m_s
    # a scenario's problem carries constraints and checks only: the objective's own settings
    # (the critical-speed search's range) do not apply to it
    return replace(settings, speed_max_m_s=float(min(u * (1.0 + NO_HARM_SPEED_MARGIN), top)),
                   objective="margin",
                   actuator_design_speeds_m_s=scenario_demand_speed(settings, u))
