"""Layout search (bridgeflap.design.control.search.layout_search): the rounded flap layout against
its neighbours.

(a) the neighbour set of the default design's layout (pure geometry), (b) the rounded
layout's row reproduces the design's own record (the same machinery, a real small design),
(c) the gap and the ranking, (d) a failed solve is a row; the card keys and adoption.
"""

import json

import numpy as np
import pytest

import bridgeflap.design.control.search.driver as driver
import bridgeflap.design.control.solve.start as start
from bridgeflap.design.control.results.records import RobustMargin, StartRecord, Verification
from bridgeflap.design.control.search.layout_search import (
    compare_layouts,
    design_step,
    layout_groups,
    neighbour_layouts,
    relaxed_theta,
)
from bridgeflap.design.control.settings import load_settings
from bridgeflap.model.errors import BridgeflapInputError

#: The default card's 25 candidates and the default design's 18 flap pairs (README).
CANDIDATES = (np.arange(25) - 12) * 56.4
DEFAULT_LAYOUT = [s * 56.4 * k for k in range(4, 13) for s in (-1, 1)]


def _record(positions, margin, verified=True, start=0):
    ver = Verification(speeds_m_s=np.zeros(1), abscissa_1_s=-np.ones(1),
                       violation_1_s=-np.ones(1), max_violation_1_s=-1.0,
                       stable_everywhere=True, stable_to_m_s=85.0, max_gain=10.0, modes=6,
                       step_m_s=1.0, meets_damping=True)
    rob = RobustMargin(speeds_m_s=np.array([30.0]), t_inf=np.array([1.0 / margin]),
                       peak_omega_rad_s=np.array([1.0]), peaks=((),), margin=margin)
    return StartRecord(start=start, theta0=(0.0,) * 5, ipopt_status="Solve_Succeeded",
                       success=True, time_s=0.0, theta=(0.1, 0.2, -1.0, 0.05, 0.5),
                       stable_to_m_s=85.0, max_gain=10.0, meets_damping=True, gain_ok=True,
                       verified=verified, robust=rob, verification=ver,
                       flap_positions_m=tuple(float(x) for x in positions))


def test_neighbours_of_the_default_layout_differ_by_one_mirror_pair():
    # (a) 25 candidates = 12 mirror pairs + the centre flap (13 groups); the default layout
    # holds 9 of them (18 flaps), so 9 removals and 4 additions, all symmetric
    rows = neighbour_layouts(CANDIDATES, DEFAULT_LAYOUT)
    base = rows[0]["mask"]
    assert rows[0]["kind"] == "rounded" and base.sum() == 18
    flips = [r for r in rows if r["group"] is not None]
    assert len(flips) == 13 and len({r["group"] for r in flips}) == 13
    assert sum(r["kind"].startswith("remove") for r in flips) == 9
    assert sum(r["kind"].startswith("add") for r in flips) == 4
    for r in flips:
        m = r["mask"]
        np.testing.assert_array_equal(m, m[::-1])       # symmetric about mid-span
        diff = np.flatnonzero(m != base)
        # exactly one group: a mirror pair (x, -x), or the centre flap alone
        assert sorted(CANDIDATES[diff]) == pytest.approx(
            [0.0] if r["group_radius_m"] == 0.0 else
            [-r["group_radius_m"], r["group_radius_m"]], abs=1e-9)
        assert m.sum() == base.sum() + (len(diff) if r["kind"] == "add" else -len(diff))
    # the centred contiguous blocks of g - 1, g, g + 1 = 8, 9, 10 groups: 15, 17, 19 flaps
    blocks = [r for r in rows if r["kind"] == "block"]
    assert [int(b["mask"].sum()) for b in blocks] == [15, 17, 19]
    for b in blocks:
        on = np.abs(CANDIDATES[b["mask"] > 0.5])
        assert on.max() == pytest.approx(56.4 * (b["mask"].sum() - 1) / 2, abs=1e-9)
    assert len(rows) == 1 + 13 + 3
    # independent weights: one candidate per group, 25 single flips
    single = neighbour_layouts(CANDIDATES, DEFAULT_LAYOUT, symmetric=False, blocks=-1)
    assert len(single) == 26
    assert all(np.abs(r["mask"] - base).sum() == 1 for r in single[1:])


def test_neighbour_set_edge_cases():
    # a block equal to a flip keeps one row (kind "+block"); the only group is never removed
    rows = neighbour_layouts([-56.4, 0.0, 56.4], [-56.4, 0.0, 56.4])
    assert [r["kind"] for r in rows] == ["rounded", "remove", "remove+block"]
    one = neighbour_layouts([-56.4, 0.0, 56.4], [0.0], blocks=-1)
    assert [r["kind"] for r in one] == ["rounded", "add"]
    assert layout_groups([-56.4, 0.0, 56.4]).shape == (3, 2)
    with pytest.raises(BridgeflapInputError, match="not a candidate"):
        neighbour_layouts(CANDIDATES, [10.0, -10.0])
    with pytest.raises(BridgeflapInputError, match="splits a mirror pair"):
        neighbour_layouts(CANDIDATES, [56.4])


#: A small placement card (humber:box, 6 modes, 3 candidates, short solves): the code paths
#: of the default design in ~7 s per start.
SMALL = {"bridge": "humber:box", "n_modes": 6, "verification_modes": 6, "flap_count": 3,
         "flap_positions_m": (),
         "robust_design_speeds_m_s": (30.0, 60.0), "n_robust_omega": 8,
         "optimise_placement": True, "design_step_m_s": 10.0, "cutting_plane_rounds": 1,
         "placement_cut_rounds": 0, "max_iter": 20, "resolve_max_iter": 20,
         "robust_speeds_m_s": (30.0, 60.0), "check_step_m_s": 1.0}


@pytest.fixture(scope="module")
def small_design():
    s = load_settings(**SMALL)
    return s, driver.run_start(s, driver.NOMINAL_START, 0)


def test_a_start_says_its_ipopt_iterations_with_the_time_left(small_design):
    # the progress function observes only: the same record as without it
    s, rec = small_design
    lines = []
    said = driver.run_start(s, driver.NOMINAL_START, 0, say=lines.append)
    assert said.theta == rec.theta and said.iterations == rec.iterations
    cap = s.iteration_cap()
    its = [ln for ln in lines if ln.startswith("start 0: ")]
    # the first line at the first iteration (a solve may end before a tenth of its cap)
    assert its[0] == f"start 0: Ipopt running (at most {cap} iterations)"
    its = its[1:]
    assert its and all(f"Ipopt iterations of at most {cap}" in ln for ln in its)
    # a line at every tenth of the cap (counted over all the start's Ipopt solves)
    every = max(1, cap // 10)
    assert [int(ln.split()[2]) for ln in its] == [every * (k + 1) for k in range(len(its))]
    assert its[0].endswith("left)")


def test_rounded_row_reproduces_the_designs_own_record(small_design):
    # (b) the rounded layout re-solved by compare_layouts from the K run_start started its
    # rounded step from (the relaxed solve's chosen round) is the design's own record: the
    # same function (solve_fixed_layout), the same start, Ipopt deterministic with one BLAS
    # thread -- equal to round-off; 1e-9 relative leaves room for a summation order change
    s, rec = small_design
    assert rec.weights_continuous is not None and not rec.failed
    th0 = relaxed_theta(rec)
    assert th0 is not None
    comp = compare_layouts(s, rec.flap_positions_m, th0, weights=rec.weights_continuous)
    row = comp.rows[0]
    assert row.kind == "rounded" and row.record.verified == rec.verified
    assert row.record.robust_margin == pytest.approx(rec.robust_margin, rel=1e-9)
    np.testing.assert_allclose(row.record.theta, rec.theta, rtol=1e-9, atol=1e-12)
    assert row.record.stable_to_m_s == rec.stable_to_m_s
    assert row.record.max_gain == pytest.approx(rec.max_gain, rel=1e-9)
    # every layout is a row with a status, the relaxed weight of each flipped group is shown
    n = len(neighbour_layouts(s.positions(), rec.flap_positions_m))
    assert len(comp.rows) == n
    assert all(r.record.ipopt_status for r in comp.rows)
    assert all(np.isfinite(r.weight_relaxed) for r in comp.rows if r.group is not None)
    json.dumps(comp.to_dict(), allow_nan=False)


def test_gap_and_ranking(monkeypatch):
    # (c) margins chosen per layout: the gap is 100 (m - m0) / m0 against the rounded row,
    # only verified rows are ranked, the best verified neighbour is reported
    s = load_settings(flap_count=5, flap_positions_m=(), optimise_placement=True)
    # 5 candidates, all fitted: the rounded layout (5 flaps), the centre removed (4), the
    # +-56.4 m pair removed (3, outer), the +-112.8 m pair removed (3, the inner block)
    margins = {5: 0.40, 4: 0.50, 3: 0.30}              # flap count -> margin
    inner = 0.90                                        # the block: best, but not verified

    def fake(settings, positions, theta0, index=0, spec=None, variants=()):
        n, is_block = len(positions), max(abs(p) for p in positions) < 60.0
        return _record(positions, inner if is_block else margins[n], not is_block, index)

    monkeypatch.setattr(start, "layout_record", fake)
    comp = compare_layouts(s, s.positions(), np.zeros(5))
    assert [r.kind for r in comp.rows] == ["rounded", "remove", "remove", "remove+block"]
    r5, r4, r3, blk = comp.rows
    assert r5.gap_pct == 0.0
    assert r4.gap_pct == pytest.approx(100 * (0.50 - 0.40) / 0.40, rel=1e-12)
    assert r3.gap_pct == pytest.approx(100 * (0.30 - 0.40) / 0.40, rel=1e-12)
    assert np.isnan(blk.gap_pct) and blk.rank is None
    assert [r4.rank, r5.rank, r3.rank] == [1, 2, 3]
    assert comp.best_record.robust_margin == 0.50
    assert comp.best_layout_is_rounded is False and comp.status == "ok"
    assert comp.best_neighbour_gap_pct == pytest.approx(25.0, rel=1e-12)
    d = comp.to_dict()
    assert d["best_layout_is_rounded"] is False and d["rows"][d["best_row"]]["rank"] == 1
    json.dumps(d, allow_nan=False)
    # the rounded layout best: the gap of the best neighbour is negative
    margins[5] = 0.60
    comp = compare_layouts(s, s.positions(), np.zeros(5))
    assert comp.best == 0 and comp.best_layout_is_rounded is True
    assert comp.best_neighbour_gap_pct == pytest.approx(100 * (0.50 - 0.60) / 0.60, rel=1e-12)


def test_failed_solve_is_a_row(monkeypatch):
    # (d) every neighbour's solve raises: each is a row "failed: ...", with its layout; the
    # rounded layout (the design's record) stays the best; strict JSON throughout
    s = load_settings(flap_count=5, flap_positions_m=(), optimise_placement=True)

    def boom(*args, **kw):
        raise RuntimeError("solver exploded")

    monkeypatch.setattr(start, "solve_fixed_layout", boom)
    rounded = _record(s.positions(), 0.4)
    comp = compare_layouts(s, s.positions(), np.zeros(5), rounded_record=rounded)
    assert len(comp.rows) == len(neighbour_layouts(s.positions(), s.positions()))
    failed = comp.rows[1:]
    assert failed and all(r.record.ipopt_status == "failed: solver exploded" for r in failed)
    assert all(r.record.flap_positions_m and not r.record.verified for r in failed)
    assert comp.status == "no_neighbour_verified" and comp.best_layout_is_rounded is True
    d = comp.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["rows"][1]["status"] == "failed: solver exploded" and d["rows"][1]["theta"] is None
    assert "failed: solver exploded" in comp.table()


def test_design_step_adopts_only_when_asked(monkeypatch):
    # the optimise step: the rounded row is the design's record (not re-solved); adoption
    # replaces the chosen start by the better neighbour (start index kept) only with the key
    # parallel off: the monkeypatched solver is a local function (no worker process)
    s = load_settings(flap_count=5, flap_positions_m=(), optimise_placement=True,
                      layout_neighbours=True, parallel=False)
    best = _record(s.positions(), 0.4, start=3)

    def fake(settings, positions, theta0, index=0, spec=None, variants=()):
        return _record(positions, 0.5 if len(positions) == 3 else 0.3, True, index)

    monkeypatch.setattr(start, "layout_record", fake)
    got, status, table = design_step(s, best, "unverified")
    assert got is best and status == "unverified" and table["adopted"] is False
    assert table["best_layout_is_rounded"] is False
    got, status, table = design_step(load_settings(
        flap_count=5, flap_positions_m=(), optimise_placement=True, layout_neighbours=True,
        layout_adopt=True,
        parallel=False),
        best, "converged")
    assert table["adopted"] is True and status == "converged"
    assert got.start == 3 and len(got.flap_positions_m) == 3 and got.robust_margin == 0.5
    assert design_step(load_settings(), best, "converged") == (best, "converged", None)


def test_card_keys_are_checked():
    assert load_settings().layout_neighbours is False
    with pytest.raises(BridgeflapInputError, match="^layout_neighbours: must be true or false"):
        load_settings(layout_neighbours="yes")
    with pytest.raises(BridgeflapInputError, match="^layout_adopt: needs layout_neighbours"):
        load_settings(layout_adopt=True)


@pytest.mark.slow
def test_design_reports_layout_neighbours_in_its_summary():
    # the whole design with the card key on the small card: the summary carries the table
    # (strict JSON), its rounded row is the chosen start's record, and the key is shown in
    # the settings only when set (older records stay as they were)
    from bridgeflap.design.control.search.driver import design

    s = load_settings(**SMALL, starts=1, layout_neighbours=True, min_flap_counts=(3,))
    res = design(s)
    out = res.summary()
    json.dumps(out, allow_nan=False)
    table = out["layout_neighbours"]
    assert table["rows"][0]["kind"] == "rounded" and table["adopted"] is False
    # the layout rows carry the margin at the robust speeds (the headline is the speed grid's)
    assert table["rows"][0]["robust_margin"] == out["robust_margin_at_robust_speeds"]
    assert out["settings"]["layout_neighbours"] is True
    assert "layout_adopt" not in out["settings"]
    assert "layout neighbours (K re-optimised)" in res.extras["phase_times_s"]
