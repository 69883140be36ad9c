"""A diverged solve recovers from the last feasible point inside a trust region
(bridgeflap.design.control.formulation.cuts), and a trust region's bound is never taken for the
solution."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bridgeflap.design.control.formulation.cuts import TRUST_RADIUS
from bridgeflap.design.control.formulation.nlp import DesignProblem
from bridgeflap.design.control.formulation.nlp_tolerances import THETA_SCALE
from bridgeflap.design.control.search.driver import build_model
from bridgeflap.design.control.settings import load_settings

START = np.array([0.0, 0.5, -1.0, 0.05, 0.5])


@pytest.fixture(scope="module")
def small():
    # Humber, 6 modes, 5 flap pairs: the design's code path on small matrices
    s = load_settings(None, n_modes=6, flap_count=5, robust_design_speeds_m_s=(30.0, 60.0),
                      n_robust_omega=8, cutting_plane_rounds=3)
    return s, build_model(s)[1]


def _patch_solve(monkeypatch, alter) -> list:
    """Wrap ``DesignProblem.solve``: each call is recorded as ``(theta0, trust, feasibility)``
    in the returned list, and its result passed through ``alter(res, kw, calls)``."""
    real = DesignProblem.solve
    calls = []

    def solve(self, theta0, speeds, **kw):
        res = real(self, theta0, speeds, **kw)
        calls.append((np.array(theta0, float), kw.get("trust"), kw.get("feasibility")))
        return alter(res, kw, calls)

    monkeypatch.setattr(DesignProblem, "solve", solve)
    return calls


def test_a_diverged_solve_restarts_from_the_anchor_in_a_trust_region(small, monkeypatch):
    s, model = small
    prob = DesignProblem(s, model)

    def alter(res, kw, calls):
        # the first phase-2 solve is declared diverged, as the watchdog would
        if not kw.get("feasibility") and len([c for c in calls if not c[2]]) == 1:
            return replace(res, diverged=True, success=False)
        return res

    calls = _patch_solve(monkeypatch, alter)
    out = prob.solve_with_cuts(START)
    steps = [r.step for r in out.rounds if r.placement is None]
    assert steps[0] == "cuts" and steps[1] == "recovery", steps
    phase2 = [c for c in calls if not c[2]]
    anchor, trust = phase2[1][0], phase2[1][1]
    # restarted from the anchor (the phase-1 point, or the feasible start), not from the
    # diverged iterate, with the first radius
    first = phase2[0][0]
    assert np.array_equal(anchor, first) and trust is not None
    assert trust[1] == TRUST_RADIUS and np.array_equal(trust[0], first)
    # the outcome is a solution of the design problem: off every trust-region bound
    chosen = out.rounds[out.chosen_round]
    assert "trust region's bound" not in chosen.ipopt_status
    assert out.verification.max_violation_1_s <= 1e-6


def test_the_trust_region_bounds_theta_and_is_reported(small):
    s, model = small
    prob = DesignProblem(s, model)
    centre, radius = START, 0.05
    res = prob.solve(START, [0.0, 40.0, 80.0], trust=(centre, radius))
    half = radius * np.maximum(np.abs(centre), THETA_SCALE)
    # Ipopt keeps its iterates within its bounds relaxed by bound_relax_factor (1e-8 times
    # max(1, |bound|)): 1e-7 absolute covers it
    assert np.all(np.abs(res.theta - centre) <= half + 1e-7)
    # a radius this small binds (the optimum is far from the start): reported as such
    assert res.on_trust_bound


def test_a_certificate_of_local_infeasibility_ends_the_loop(small, monkeypatch):
    # Ipopt's Infeasible_Problem_Detected off the trust region's bound, nothing new to cut:
    # the same problem from the same point would end there again, so the loop stops after
    # that solve instead of continuing it (MAX_CONTINUATIONS) or re-solving it as a cut round
    s, model = small
    prob = DesignProblem(s, model)

    def alter(res, kw, calls):
        if not kw.get("feasibility"):     # every phase-2 solve: a local-infeasibility stop
            return replace(res, ipopt_status="Infeasible_Problem_Detected", success=False,
                           on_trust_bound=False)
        return res

    calls = _patch_solve(monkeypatch, alter)
    out = prob.solve_with_cuts(START)
    rounds = [r for r in out.rounds if r.placement is None and "phase 1" not in r.ipopt_status]
    assert len([c for c in calls if not c[2]]) == len(rounds)
    # a round may add cuts found at its solution's checks (a new speed, gain or scenario
    # point makes a new problem); the loop ends on the first round that adds none, and no
    # round continues a locally infeasible solve
    new = [r.new_speeds + r.new_gain_cuts + r.new_robust_cuts + r.new_variant_constraints
           + r.new_demand_scenarios for r in rounds]
    assert new[-1] == 0 and all(n > 0 for n in new[:-1]), new
    assert "continuation" not in [r.step for r in rounds]
    assert all(r.ipopt_status == "Infeasible_Problem_Detected" for r in rounds)
