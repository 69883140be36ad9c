"""Multi-model design: the damping constraints of bridge variants, generated lazily.

A multi-model design (``variants > 0``) asks the damping constraint of every movable branch at
every design speed on every variant as well as on the nominal bridge. Written out in full
(``variant_speeds = "all"``) that is ``(1 + variants)`` eigen-decompositions with vectors per
design speed and Ipopt iteration: 9x the nominal eigenvalue work for 8 variants (the card
``design/studies/humber_flaps_multimodel.toml`` took 144 s so, 88 s lazy). Most of them are
slack: the variants are perturbations of one bridge, and where the nominal constraint is
satisfied with room so are theirs. ``variant_speeds = "lazy"`` (default) keeps, per variant,
only the speeds at which its constraint can bind (constraint generation, the same cutting-plane
idea as the nominal bridge's dense-check cuts of :mod:`bridgeflap.design.control.formulation.cuts`):

* **seed** (before the first solve, :func:`seed`): at each design speed the variant whose
  damping measure at the start is the largest, when it exceeds the nominal one (an envelope:
  there the nominal constraint does not cover it). Measured on the multi-model card (one run
  each, deterministic): this seed 88 s; the near-active pairs (below) as the seed instead
  190 s (one start's first rounded solve wandered into the left-out constraints: 80 + 146
  iterations at ~0.7 s, line-search trials evaluating every speed); both 107 s;
* **cuts** (after every round, :func:`round_checks`): every variant is checked on the check
  grid (the refined subset of
  :func:`bridgeflap.design.control.formulation.plant.damping_check_refined`, which keeps the dense
  check's decisions); the worst speed of each run of violations joins that variant's set, and so
  does every design speed at which the variant is near its bound (:data:`NEAR_ACTIVE_REL`; the next
  round would otherwise be free to push it over).

The scenarios' **flap demand** (:mod:`bridgeflap.design.control.solve.scenarios`: the 3 sigma
flap angle and rate within the actuator limits at the scenario's one actuator speed) is generated
alike, per scenario (:func:`demand_checks`): its constraints are built (frozen at the start
design, like the nominal bridge's, :mod:`bridgeflap.design.control.formulation.actuator_demand`)
and evaluated at the start and after every round; a scenario whose demand is above
:data:`DEMAND_NEAR` of a limit joins the NLP and stays. A round counts as feasible only when every
scenario's demand is within the limits on that same integral.

A round of :mod:`bridgeflap.design.control.formulation.cuts` counts as feasible, and a start as
verified, only when every variant passes its check, so a lazy design is held to the same a
posteriori standard as a full one: the constraints left out are verified satisfied, not assumed. The
sets only grow, so the loop cannot cycle.
"""

from __future__ import annotations

import numpy as np

from bridgeflap.design.control.formulation.plant import damping_check, lag_rates

#: A design speed joins a variant's constraint set when, at a round's design, the variant's
#: smallest damping ratio of the movable branches there is below ``(1 + NEAR_ACTIVE_REL)
#: zeta_min`` (0.6 % for zeta_min = 0.5 %), or its damping measure ``Re lambda + zeta_min
#: |lambda|`` is above ``-NEAR_ACTIVE_1_S`` (a real root approaching divergence has damping
#: ratio 1 until it crosses). Measured on the default card with 8 variants: an absolute 1e-3
#: 1/s alone took 54-81 of the 144 pairs (the lightly damped low-speed vertical branches sit
#: at ~-2e-3 1/s with the 1 % structural damping), no fewer rounds.
NEAR_ACTIVE_REL = 0.2
NEAR_ACTIVE_1_S = 1e-4
#: A scenario's flap-demand constraints join the NLP when its 3 sigma flap angle or rate is
#: above this fraction of the limit at the start or after a round. The NLP holds a held
#: scenario to 0.95 of the limit (actuator_demand.DEMAND_BACKOFF); 0.9 leaves a scenario out
#: only with room, so a round seldom pushes one past the limit unseen (that costs a round).
DEMAND_NEAR = 0.9


def lazy(prob) -> bool:
    """Whether ``prob``'s variants (or ``prob``, a variant) carry their own (lazy) speed
    sets (:attr:`bridgeflap.design.control.formulation.nlp.DesignProblem.lazy_speeds`)."""
    return prob.settings.variant_speeds == "lazy"


def speeds_of(variant, speeds) -> np.ndarray:
    """The design speeds [m/s] whose damping constraints ``variant`` (a variant problem)
    carries in the NLP: its own set when lazy, else every design speed ``speeds``."""
    if not lazy(variant):
        return _within(variant, np.asarray(speeds, float))
    return np.array(variant.lazy_speeds, float)


def _within(variant, speeds) -> np.ndarray:
    """The ``speeds`` [m/s] within ``variant``'s own range (its ``speed_max_m_s``: below its
    open-loop critical speed with ``variant_rule = "no_harm"``,
    :mod:`bridgeflap.design.control.solve.scenarios`)."""
    U = np.asarray(speeds, float)
    return U[U <= variant.settings.speed_max_m_s]


def _add(variant, speeds) -> int:
    have = set(variant.lazy_speeds)
    new = [float(u) for u in speeds if float(u) not in have]
    variant.lazy_speeds = sorted(have | set(new))
    return len(new)


def seed(prob, theta, w, speeds, nominal) -> float:
    """The largest damping measure of the variants at ``theta`` on the design ``speeds``
    [1/s]; when lazy, each speed's worst variant joins its set where it exceeds the nominal
    measures ``nominal`` (per speed)."""
    if not prob.variants:
        return -np.inf
    U = np.asarray(speeds, float)
    vals = np.full((len(prob.variants), U.size), -np.inf)
    for i, v in enumerate(prob.variants):   # each variant on its own range
        inside = U <= v.settings.speed_max_m_s
        if inside.any():
            vals[i, inside] = v.constraint_values(theta, U[inside], w)
    if lazy(prob):
        worst = np.argmax(vals, axis=0)
        for j, u in enumerate(U):
            if vals[worst[j], j] > nominal[j]:
                _add(prob.variants[worst[j]], [u])
    return float(vals.max())


def round_checks(prob, theta, w, speeds, tol, worst_per_run) -> tuple[list, int]:
    """Check every variant after a round: ``(verifications, new constraints)``.

    Verifications on the refined check grid; when lazy, the worst speed of each run of
    violations above ``tol`` and every design speed where the variant is near its bound
    (:data:`NEAR_ACTIVE_REL`, :data:`NEAR_ACTIVE_1_S`) join the variant's set (``new
    constraints`` counts the (variant, speed) pairs added). When not lazy the violating check
    speeds are returned through the nominal loop instead (0)."""
    vers = [v.verify(theta, w, refined=True) for v in prob.variants]
    if not lazy(prob):
        return vers, 0
    U = np.asarray(speeds, float)
    new = 0
    for v, ver in zip(prob.variants, vers, strict=True):
        bad = ver.violation_1_s > tol
        cand = worst_per_run(ver.speeds_m_s, bad, ver.violation_1_s) if bad.any() else []
        Uv = _within(v, U)
        near = Uv[_near_active(v, theta, w, Uv)] if Uv.size else []
        new += _add(v, [*cand, *near])
    return vers, new


def _near_active(v, theta, w, U) -> np.ndarray:
    """Mask of the design speeds ``U`` where variant ``v`` is near its damping bound."""
    z = v.settings.zeta_min
    return _near(damping_check(v.A_parts(theta, w), U, lag_rates(v.model), theta, z), z)


def _near(chk, z) -> np.ndarray:
    """Near the bound (or over it): damping ratio below ``(1 + NEAR_ACTIVE_REL) z`` or measure
    above ``-NEAR_ACTIVE_1_S``, per speed of a
    :func:`bridgeflap.design.control.formulation.plant.damping_check`."""
    return (chk["zeta"] < z * (1.0 + NEAR_ACTIVE_REL)) | (chk["measure_1_s"] > -NEAR_ACTIVE_1_S)


def constraint_count(prob, speeds) -> int:
    """(variant, speed) damping-constraint pairs the NLP carries with design ``speeds``."""
    return sum(speeds_of(v, speeds).size for v in prob.variants)


def demand_checks(prob, theta, seed=False) -> tuple[bool, int]:
    """The scenarios' flap demand at ``theta``: ``(every scenario within its limits, scenarios
    newly held)``. Each scenario that carries a demand (``demand_held`` not None) is evaluated
    on its frozen integral (built here at the first call, at ``theta``); one above
    :data:`DEMAND_NEAR` of a limit is held from the next solve on (the set only grows).

    ``seed`` (the start, before the first solve): a scenario is held also when its demand
    exceeds the nominal bridge's own at ``theta`` (an envelope, as the damping seed: the
    nominal constraint, which the first solve will push to its bound, does not cover it).
    Measured on the default card: without the seed none of the 12 scenarios was near at the
    start (a low-gain K), the first solve landed on the nominal-only design and three more
    rounds held 6 scenarios (4 rounds, 129 Ipopt iterations, 36 s of solves)."""
    near = DEMAND_NEAR
    if seed and prob.settings.actuator_design_speeds_m_s and not prob.settings.optimise_placement:
        near = min(near, prob.flap_demand(theta).fraction(theta))
    ok, new = True, 0
    for v in prob.variants:
        if v.demand_held is None:
            continue
        frac = v.flap_demand(theta).fraction(theta)
        ok = ok and frac <= 1.0
        if frac > near and not v.demand_held:
            v.demand_held = True
            new += 1
    return ok, new


def demand_held_count(prob) -> int:
    """Scenarios whose flap-demand constraints the NLP carries."""
    return sum(bool(v.demand_held) for v in prob.variants)


def demand_constraints(prob, th, g, lbg, ubg) -> None:
    """Append the held scenarios' flap-demand constraints (``<= 0``) in ``th`` (the NLP's
    theta symbol) to the NLP's lists ``g``, ``lbg``, ``ubg``."""
    for v in prob.variants:
        if v.demand_held:
            dv = v.flap_demand()
            g.append(dv.constraints(th))
            lbg.append(np.full(4 * len(dv.speeds_m_s), -np.inf))
            ubg.append(np.zeros(4 * len(dv.speeds_m_s)))
