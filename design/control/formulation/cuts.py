"""The cutting-plane loop of the compensator NLP
(:meth:`bridgeflap.design.control.formulation.nlp.DesignProblem.solve_with_cuts`).

Phase 1 (feasibility, no robust epigraph) from an infeasible start, then warm-started
re-solves with damping-speed, gain and robust cuts and robust peak tracking; the best round
is returned and every round recorded (docstrings of
:mod:`bridgeflap.design.control.formulation.nlp`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from bridgeflap.design.control.formulation import variants
from bridgeflap.design.control.formulation.loop_algebra import compensator_damped
from bridgeflap.design.control.formulation.nlp_tolerances import (
    GAIN_BACKOFF,
    ROBUST_CLUSTER_STEP,
    ROBUST_CUTS_PER_SPEED,
    VIOLATION_TOL,
)
from bridgeflap.design.control.results.records import CutRound, CutsOutcome
from bridgeflap.model.aeroelastic.control import Compensator

#: Round 0 warm-started (monotone barrier from
#: ``design.control.formulation.nlp_tolerances.WARM_MU_INIT``) when its start is feasible (a
#: feasible start, or phase 1's first feasible iterate). Measured on the default card (``python -m
#: bench.design``, 2 starts): Ipopt's adaptive barrier in round 0 crawled to its 80-iteration cap
#: from phase 1's point (start 0: gamma_T 40.7 against a dense peak of 4.5, then 77-103 more
#: iterations in round 1). Warm: 424 + 554 -> 289 + 274 iterations, both starts on the same design
#: (margin 0.3228 / 0.3230). With the card's former 20 robust frequencies per band the effect was
#: mixed (start 0 393 -> 276, start 1 315 -> 582 into another basin); with 60 it is not. Tried and
#: dropped: re-solves started from the previous multipliers (warm_start_init_point): 313 iterations
#: and another design.
WARM_FIRST = True
#: Recovery of a diverged solve. A re-solve stopped by the divergence watchdog
#: (``design.control.formulation.ipopt_hooks.DIVERGE_LEVEL``) has left the basin of the design: its
#: iterate is no warm start. The loop restarts from the *anchor* -- the last point that met the
#: damping and the gain limit (a feasible round, or phase 1's feasible point) -- inside a trust
#: region on theta of relative half-width ``TRUST_RADIUS * TRUST_SHRINK**k`` for the k-th recovery
#: (``max(|theta_i|, THETA_SCALE_i)`` the unit), at most ``MAX_RECOVERIES`` times. A solution
#: on the trust region's bound is not yet a solution of the design problem: the next solve is
#: re-centred there (a "trust step", at most ``MAX_TRUST_STEPS``), and a design ends only on a
#: solution off the bound. Measured before (one start, no recovery): on an AVX-512 CPU the
#: default card's round 0 left its basin (gain 34.9, flutter 43.9 m/s), round 1 restarted from
#: that iterate and left it again, and the design ended ``infeasible``; the same problem with
#: numpy's AVX-512 kernels switched off converged.
#: Every phase-2 solve from a feasible point runs in a trust region (radius ``TRUST_RADIUS``,
#: re-centred at each solution that lies on its bound, and at each cut round), not only after a
#: divergence: the path then moves in bounded steps from the same point on every machine.
#: Measured on the default card (16 modes, 12 scenarios; this 2-core Xeon with AVX-512): without
#: it, round 0 from phase 1's point left its basin at iteration 25 as found, but not with the
#: model perturbed by 1e-9, and the two runs ended on designs 0.034 m/s and 3.5 % of margin
#: apart (and on a Zen 5 CPU in none); with it, numpy's AVX-512 kernels on and off and the
#: perturbed models end on one design (``python -m bench.reproducible``), in fewer Ipopt
#: phase-2 Ipopt iterations (111 against 133 as found).
TRUST_FROM_START = True
MAX_RECOVERIES = 3
TRUST_RADIUS = 0.5
TRUST_SHRINK = 0.5
MAX_TRUST_STEPS = 6
#: A trust step from a feasible solution on the region's bound doubles the radius, up to
#: ``TRUST_RADIUS_MAX`` (the usual trust-region update: the model held where it was trusted).
#: Measured on the default card with the scenarios' flap demand: at a fixed radius the design
#: took three trust steps (4 solves, 140 Ipopt iterations, 71 s)
TRUST_GROW = 2.0
TRUST_RADIUS_MAX = 2.0
#: A solve stopped by its iteration cap (not diverged) is continued from its iterate with the
#: same cuts (a "continuation", at most this many, not counted as cut rounds): a capped iterate
#: is not a solution, and the loop ends on a converged solve where the budget allows.
#: Measured before: the quick form of a card (2 cut rounds) ended on a capped iterate, and which
#: one depended on the CPU (margins 0.168 and 0.080 on one card, AVX-512 on and off).
MAX_CONTINUATIONS = 4
#: Ipopt statuses that certify a local infeasibility (a stationary point of the constraint
#: violation). Such a solve off the trust region's bound, with nothing new to cut, ends the
#: loop: neither a continuation nor another round of the same problem moves it. Measured on
#: the quick card's deck with GJ -10 % and mass -5 % (3 sigma flap angle 22 deg against 20 deg
#: at 74 m/s): before, the loop continued that solve three times and re-solved it once as a
#: cut round, each ending Infeasible_Problem_Detected again (8 solves, 610 Ipopt iterations);
#: with the rule, 4 solves and 448 iterations, the same status, binding limit and best design
#: (its coefficients within 3e-6 relative, along the flat optimum).
LOCALLY_INFEASIBLE = ("Infeasible_Problem_Detected",)


def solve_with_cuts(prob, theta0, weights0=None) -> CutsOutcome:
    """Solve ``prob`` (a :class:`bridgeflap.design.control.formulation.nlp.DesignProblem`) with
    phase 1 and cutting planes; see
    :meth:`bridgeflap.design.control.formulation.nlp.DesignProblem.solve_with_cuts`."""
    s = prob.settings
    speeds = list(prob.settings.design_speeds())
    history = []
    theta = np.asarray(theta0, float)
    w = prob.weights if weights0 is None else np.asarray(weights0, float)
    gamma = None
    res = ver = rob = None
    kept = []
    use_rob = s.weight_robust > 0 and (bool(s.robust_design_speeds_m_s)
                                       or bool(s.robust_speeds_m_s))
    # the scenarios' flap demand, built and evaluated at the start: those near a limit, or
    # above the nominal bridge's own demand, are held from the first solve on
    # (variants.demand_checks)
    variants.demand_checks(prob, theta, seed=True)
    nominal0 = prob.constraint_values(theta, sorted(speeds), w)
    # the variants' largest measure; lazy: each speed's worst variant seeds its set
    viol0 = max(float(np.max(nominal0)),
                variants.seed(prob, theta, w, sorted(speeds), nominal0))
    if viol0 > 0:
        ph1 = prob.solve(theta, np.array(sorted(speeds)), weights0=w, feasibility=True)
        ver1 = prob.verify(ph1.theta, ph1.weights, refined=True)
        history.append(CutRound(
            round=0, ipopt_status=ph1.ipopt_status, iterations=ph1.iterations,
            theta=tuple(float(v) for v in ph1.theta), time_s=ph1.time_s,
            n_speeds=len(speeds), max_violation_1_s=ver1.max_violation_1_s,
            max_gain=ver1.max_gain, gamma_T_frobenius=float("nan"),
            dense_t_peak=float("nan"), n_robust_points=0,
            n_gain_points=len(prob.omega_grid()), new_speeds=0, new_gain_cuts=0,
            new_robust_cuts=0, eig_time_per_speed_s=ph1.eig_time_per_speed_s,
            placement="phase 1 (feasibility, no robust epigraph)", history=ph1.history))
        # the phase-1 point is a fallback candidate when it meets damping and gain:
        # re-solves that diverge from it under the robust cuts must not turn a
        # feasible point into "infeasible"; used only when no round is feasible, and as the
        # restart point after a divergence then (b = 14.25 m Humber, 3 m flaps: every round
        # of the rounded layout diverged or broke the gain limit, its phase-1 point held both)
        # Not with design variants: their lazy sets are grown by the rounds' checks only.
        ph1_kept = None
        if (ver1.max_violation_1_s <= VIOLATION_TOL and ver1.max_gain <= s.gain_limit
                and compensator_damped(ph1.theta, s.compensator_damping_min)
                and not getattr(prob, "variants", ())):
            rob1 = (prob.robust_margin(ph1.theta, speeds=prob.robust_check_speeds(),
                                       weights=ph1.weights, peaks=ROBUST_CUTS_PER_SPEED)
                    if use_rob and _a2_ok(ph1.theta) else None)
            ph1_kept = (ph1, ver1, rob1, dict(speeds=sorted(speeds), robust_cuts=list(
                prob.robust_cuts), gain_cuts=list(prob.gain_cuts)), True,
                rob1.peak if rob1 is not None else float("nan"), False)
        # phase 2 from the phase-1 point when it is less violating than the start
        if float(np.max(ph1.constraints_eig_1_s)) < viol0:
            theta, w = ph1.theta, ph1.weights
        nominal1 = prob.constraint_values(theta, sorted(speeds), w)
        feasible0 = max(float(np.max(nominal1)),
                        variants.seed(prob, theta, w, sorted(speeds), nominal1)) <= 0
    else:
        feasible0 = True
        ph1_kept = None
    off = len(history)          # the phase-1 record, if any, precedes the rounds
    # the anchor of a recovery: the last point that met the damping (nominal, and the
    # variants' sets in force) and the gain limit -- phase 1's point, then each feasible round
    anchor = (np.array(theta), np.array(w), gamma) if feasible0 else None
    trust, step, recoveries, trust_steps, cut_rounds = None, "cuts", 0, 0, 0
    continuations = 0
    if TRUST_FROM_START and anchor is not None:
        trust = (np.array(theta), TRUST_RADIUS)
    rnd = -1
    while True:
        rnd += 1
        # round 0 from a feasible point is warm-started like the re-solves (WARM_FIRST)
        n_var = variants.constraint_count(prob, sorted(speeds))
        n_dem = variants.demand_held_count(prob)
        res = prob.solve(theta, np.array(sorted(speeds)), weights0=w, gamma0=gamma,
                         warm=rnd > 0 or (WARM_FIRST and feasible0),
                         max_iter=s.resolve_max_iter if rnd > 0 else s.max_iter,
                         trust=trust)
        theta, w = res.theta, res.weights
        gamma = res.gamma_T if use_rob else None
        # the rounds on the refined subset of the check grid (the same decisions and worst
        # speeds, design.control.formulation.plant.damping_check_refined); the chosen round is
        # re-checked on the dense grid below. Variants: checked alike; when lazy, their violating
        # and near-active speeds join their own sets (design.control.formulation.variants)
        ver = prob.verify(theta, w, refined=True)
        vvers, new_variant = variants.round_checks(prob, theta, w, sorted(speeds),
                                                   VIOLATION_TOL, _worst_per_run)
        dem_ok, new_dem = variants.demand_checks(prob, theta)
        eig_ok = all(vv.max_violation_1_s <= VIOLATION_TOL for vv in [ver, *vvers])
        # the compensator's pole damping (an algebraic NLP constraint, met to Ipopt's
        # tolerance) counts with the gain: a round that breaks it is not feasible
        gain_ok = (ver.max_gain <= s.gain_limit
                   and compensator_damped(theta, s.compensator_damping_min))
        rob_ok, new_rob = True, []
        rob = None
        if use_rob and _a2_ok(theta):
            rob = prob.robust_margin(theta, speeds=prob.robust_check_speeds(), weights=w,
                                     peaks=ROBUST_CUTS_PER_SPEED)
            lim = gamma * (1.0 + s.robust_cut_tol)
            rob_ok = bool(rob.peak <= lim)
            for U, pk in zip(rob.speeds_m_s, rob.peaks, strict=True):
                new_rob += [(float(U), om * (1.0 + k * ROBUST_CLUSTER_STEP))
                            for om, v in pk if v > lim for k in (-2, -1, 0, 1, 2)]
            if not rob_ok:
                # peak tracking: the dense peak of every speed joins too (the resonance
                # it sits on moves with theta; a point on it keeps the bound honest there)
                new_rob += [(float(U), float(om))
                            for U, om in zip(rob.speeds_m_s, rob.peak_omega_rad_s,
                                             strict=True)]
            new_rob = [c for c in dict.fromkeys(new_rob) if c not in prob.robust_cuts]
        new_gain = []
        if not gain_ok:
            comp = Compensator(*(float(v) for v in theta))
            wst = comp.stationary_frequencies()
            new_gain = [float(x) for x in wst
                        if abs(comp.frequency_response(x)) > s.gain_limit
                        * (1.0 - GAIN_BACKOFF) and float(x) not in prob.gain_cuts]
        new_speeds = []
        if not eig_ok:      # the variants' too when they share the design speeds ("all")
            checks = [ver] if variants.lazy(prob) else [ver, *vvers]
            new_speeds = sorted({u for vv in checks for u in _worst_per_run(
                vv.speeds_m_s, vv.violation_1_s > VIOLATION_TOL, vv.violation_1_s)
                if u not in speeds})
            if ver.guard_violation_1_s > VIOLATION_TOL and ver.guard_speed_m_s not in speeds:
                new_speeds = sorted({*new_speeds, ver.guard_speed_m_s})   # SPEED_GUARD_REL
        peak = rob.peak if rob else float("nan")
        history.append(CutRound(
            round=rnd, ipopt_status=res.ipopt_status + (
                " (on the trust region's bound)" if res.on_trust_bound else ""),
            iterations=res.iterations,
            theta=tuple(float(v) for v in theta), time_s=res.time_s, n_speeds=len(speeds),
            max_violation_1_s=ver.max_violation_1_s, max_gain=ver.max_gain,
            gamma_T_frobenius=res.gamma_T, dense_t_peak=peak,
            n_robust_points=len(prob.robust_function(
                analytic=not s.optimise_placement)[1]) if use_rob else 0,
            n_gain_points=len(prob.omega_grid()), new_speeds=len(new_speeds),
            new_gain_cuts=len(new_gain), new_robust_cuts=len(new_rob),
            eig_time_per_speed_s=res.eig_time_per_speed_s, history=res.history,
            n_variant_constraints=n_var, new_variant_constraints=new_variant,
            n_demand_scenarios=n_dem, new_demand_scenarios=new_dem, scenario_demand_ok=dem_ok,
            step=step, trust_radius=float(trust[1]) if trust is not None else float("nan")))
        # a solution on the trust region's bound is no candidate: the problem has no such bound
        kept.append((res, ver, rob, dict(speeds=sorted(speeds), robust_cuts=list(
            prob.robust_cuts), gain_cuts=list(prob.gain_cuts)),
            eig_ok and gain_ok and dem_ok and not res.on_trust_bound, peak,
            rob is not None and rob_ok))
        if eig_ok and gain_ok and dem_ok and not res.diverged:
            anchor = (np.array(theta), np.array(w), gamma)
        # every check holds: done -- unless Ipopt ran out of iterations (a bound that holds
        # at a capped iterate, e.g. gamma_T 40.7 against a dense peak of 4.5, is not the
        # optimum) or the solution lies on the trust region's bound: then the next round
        # continues it warm-started
        if (eig_ok and gain_ok and dem_ok and rob_ok and res.success
                and not res.on_trust_bound) or not _a2_ok(theta):
            break
        new_cuts = bool(new_speeds or new_gain or new_rob or new_variant or new_dem)
        if res.diverged:
            # the watchdog stopped a re-solve stalled far outside the feasible set: recover
            # from the anchor inside a trust region (MAX_RECOVERIES); with no anchor (no
            # feasible point yet) from the best round so far, once
            recoveries += 1
            if recoveries > MAX_RECOVERIES or (anchor is None and recoveries > 1):
                break
            if anchor is None:
                bres = _best(kept, ph1_kept, s.robust_cut_tol)[0][0]
                anchor = (np.array(bres.theta), np.array(bres.weights),
                          bres.gamma_T if use_rob else None)
            theta, w, gamma = (np.array(anchor[0]), np.array(anchor[1]), anchor[2])
            trust = (np.array(theta), TRUST_RADIUS * TRUST_SHRINK ** (recoveries - 1))
            step = "recovery"
        elif (res.ipopt_status in LOCALLY_INFEASIBLE and not new_cuts
              and not res.on_trust_bound):
            # Ipopt's certificate of local infeasibility off the trust region's bound: the
            # same problem from the same point ends there again (LOCALLY_INFEASIBLE)
            break
        elif (not res.success and (not new_cuts or cut_rounds == s.cutting_plane_rounds)
              and continuations < MAX_CONTINUATIONS):
            # capped short of convergence with nothing new to cut: continue the same problem
            continuations += 1
            if trust is not None:
                trust = (np.array(theta), trust[1])
            step = "continuation"
        elif res.on_trust_bound:
            trust_steps += 1
            if trust_steps > MAX_TRUST_STEPS:
                break
            # re-centred; after a feasible step the region grows (TRUST_GROW)
            grow = TRUST_GROW if eig_ok and gain_ok and dem_ok else 1.0
            trust = (np.array(theta), min(trust[1] * grow, TRUST_RADIUS_MAX))
            step = "trust step"
        else:
            # No early stop for a re-solve that ran out of iterations with a worse dense
            # peak (a speed lever, tried): on the default design it never fired (548 Ipopt
            # iterations with and without it), and a capped round can be followed by
            # converging ones (the earlier code's start 1: rounds 3-5 after a capped round 2,
            # margin 0.357). No new cut: stop, unless the solve ran out of iterations short
            # of the checks -- then the next round continues it (re-solve to convergence)
            if cut_rounds == s.cutting_plane_rounds or not (new_cuts or not res.success):
                break
            cut_rounds += 1
            if trust is not None:   # after a recovery the region follows the iterate
                trust = (np.array(theta), trust[1])
            step = "cuts"
        speeds.extend(new_speeds)
        prob.gain_cuts.extend(new_gain)
        prob.robust_cuts.extend(new_rob)
    # a re-solve sees only the sample points and can land on a design whose dense peak
    # (or gain, damping) is worse than before the cuts: return the best round --
    # feasible (damping and gain) first, then the smallest dense peak of sigma_max(T); peaks
    # within robust_cut_tol of the smallest feasible one count as equal, and among those a
    # round whose bound gamma_T holds is preferred (its margin is certified by the NLP too)
    (res, ver, rob, cuts, _, _, _), ibest = _best(kept, ph1_kept, s.robust_cut_tol)
    chosen = ibest + off if ibest >= 0 else 0   # -1: the phase-1 point (history[0])
    ver = prob.verify(res.theta, res.weights)   # the chosen round's dense check (a posteriori)
    return CutsOutcome(
        solve=res, verification=ver, robust=rob,
        rounds=tuple(replace(h, chosen=i == chosen) for i, h in enumerate(history)),
        chosen_round=chosen, design_speeds_m_s=tuple(cuts["speeds"]),
        gain_ok=bool(ver.max_gain <= s.gain_limit),
        robust_bound_holds=(bool(rob is not None and rob.peak
                                 <= res.gamma_T * (1.0 + s.robust_cut_tol))
                            if use_rob else None),
        robust_cuts=tuple(tuple(c) for c in cuts["robust_cuts"]),
        gain_cuts=tuple(cuts["gain_cuts"]))


def _best(kept, ph1, tol):
    """``(entry, index)`` of the best kept round (:func:`_ranker`); when no round meets
    damping and gain but the phase-1 point does, that point with index -1 (a fallback only:
    a feasible round always wins, so a design that has one is unchanged)."""
    if ph1 is not None and not any(k[4] for k in kept):
        return ph1, -1
    i = min(range(len(kept)), key=_ranker(kept, tol))
    return kept[i], i


def _ranker(kept, tol):
    """Sort key of the kept rounds, best first: feasible (damping and gain), then Ipopt
    converged, then the smallest dense peak of sigma_max(T), peaks within ``tol`` of the
    smallest feasible one counting as equal and among those a round whose bound gamma_T holds
    first, then the latest."""
    feas = [pk for _, _, _, _, ok, pk, _ in kept if ok and np.isfinite(pk)]
    tie = min(feas) * (1.0 + tol) if feas else -np.inf

    def rank(i):
        res, _, _, _, ok, pk, holds = kept[i]
        # a converged solve before an iterate cut off by a limit (no decision on the latter)
        return (not ok, not res.success, not (holds and pk <= tie),
                pk if np.isfinite(pk) else np.inf, -i)
    return rank


def _worst_per_run(U, bad, viol) -> list[float]:
    """The worst speed in each run of consecutive violations."""
    out, i = [], 0
    while i < len(U):
        if bad[i]:
            j = i
            while j + 1 < len(U) and bad[j + 1]:
                j += 1
            out.append(float(U[i + int(np.argmax(viol[i:j + 1]))]))
            i = j + 1
        else:
            i += 1
    return out


def _a2_ok(theta) -> bool:
    return bool(theta[3] > 0 and theta[4] > 0)
