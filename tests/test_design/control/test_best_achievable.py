"""When no design meets the limits, the best one found is reported with every
check it misses (never "no design"), and it is never handed on as a usable controller."""

from __future__ import annotations

import json

from bridgeflap.design.control.search.driver import design
from bridgeflap.design.control.settings import load_settings


def test_infeasible_design_reports_its_best_candidate_and_why():
    # humber:box on 6 modes, 5 flap pairs, one start, coarse grids; a gain limit of 0.05
    # cannot hold zeta_min at every design speed (the open-loop damping is below 0.5 % near
    # flutter), so no start is feasible
    s = load_settings(None, bridge="humber:box", n_modes=6, verification_modes=6, flap_count=5,
                      starts=1, parallel=False, gain_limit=0.05, b_bound=0.05,
                      robust_design_speeds_m_s=(30.0,), robust_speeds_m_s=(30.0,),
                      n_robust_omega=8, design_step_m_s=10.0, check_step_m_s=1.0,
                      cutting_plane_rounds=1, max_iter=30, resolve_max_iter=30,
                      weight_buffeting=0.0, optimise_placement=False, min_flap_counts=(5,))
    res = design(s)
    out = json.loads(json.dumps(res.summary(), allow_nan=False))
    assert res.controller is None and not out["controller_usable"]
    assert out["status"] in ("infeasible", "unverified")
    best = out["best_achievable"]
    assert best["status"] == "best_achievable_not_usable"
    assert best["why_not_usable"] and all(isinstance(w, str) for w in best["why_not_usable"])
    assert set(best["coefficients"]) == {"b2", "b1", "b0", "a2", "a1"}
    assert len(best["flap_positions_m"]) == 5
