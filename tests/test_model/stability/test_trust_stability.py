"""Trustworthy stability answers: verified crossings, grid-aware static
divergence, second-critical branch and damping slope, labels from U = 0, branch-switch flags.

Kinds of check (STYLE.md): cross-grid agreement (a coarse grid gives the fine grid's crossing),
invariants (a converged crossing changes the sign of its own branch, independently re-checked
here with plain eigenvalue calls), the status contract, and unit tests of pure functions.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from bridgeflap.design.batch.branch_flags import flag_branch_neighbours
from bridgeflap.design.cli.main import main as cli_main
from bridgeflap.model import analysis
from bridgeflap.model.aeroelastic import statespace
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.cases.section import section_basis
from bridgeflap.model.stability import crossings
from bridgeflap.model.stability import sweeps as stability

SPEED_TOL = 1e-3  # default Brent xtol of sweep / pk_sweep [m/s]
# two refinements of the same root, each within xtol of it (plus the 1e-12 rtol): 2 xtol apart
SAME_ROOT = 2 * SPEED_TOL

# IABSE TG3.1 step 1.1a 2-DOF section of the Great Belt East Bridge (../shared GREAT_BELT_DATA.md)
GREAT_BELT = dict(mass=22740.0, inertia=2.47e6, f_heave=0.100, f_torsion=0.278, half_chord=15.5)
# Humber-like section of the golden cases (tests/golden/cases.py _SECTION)
HUMBER_SECTION = dict(mass=7660.0, inertia=375000.0, f_heave=0.117, f_torsion=0.311,
                      half_chord=11.0)
# deck plus cables (test_aeroelastic.py::test_section_tool_aero_options_agree): flutter 65.65
# m/s, static divergence 84.81 m/s
HUMBER_CABLES = dict(mass=12460.0, inertia=9.56e5, f_heave=0.1166, f_torsion=0.2979,
                     half_chord=11.0)


def _section_system(c):
    basis = section_basis(c["mass"], c["inertia"], c["f_heave"], c["f_torsion"],
                          c["half_chord"], 0.0)
    return statespace.build(basis, c["half_chord"], 1.225, rfa="rfa4")


def _section_argv(c):
    return ["section", "--mass", str(c["mass"]), "--inertia", str(c["inertia"]), "--f-heave",
            str(c["f_heave"]), "--f-torsion", str(c["f_torsion"]), "--half-chord",
            str(c["half_chord"])]


@pytest.fixture(scope="module")
def coarse_system(coarse_humber):
    """Coarse Humber (47 m mesh), 16 modes: divergence 76.00 m/s (static)."""
    return analysis.bridge_system(coarse_humber, analysis.DEFAULT_MODES)[1]


@pytest.fixture(scope="module")
def coarse_fine(coarse_system):
    """The reference sweep on the default 0.5 m/s grid."""
    return stability.sweep(coarse_system, np.arange(0.0, 120.0 + 1e-9, 0.5))


# ----------------------------------------------------------------- A2: p-k on a coarse grid


@pytest.mark.parametrize("case", [GREAT_BELT, HUMBER_SECTION, HUMBER_CABLES],
                         ids=["great_belt", "humber", "humber_cables"])
def test_pk_on_a_coarse_grid_finds_the_fine_grid_crossing(case):
    """0:400:50 used to let the two branches collapse onto one root (Great Belt: 85.01 m/s
    "converged" against 76.53 m/s; Humber-like: "no crossing" against 48.18 m/s; with cables:
    79.40 m/s "converged" against 65.65 m/s)."""
    system = _section_system(case)
    fine = stability.pk_sweep(system, np.arange(0.0, 150.0, 0.5))
    coarse = stability.pk_sweep(system, np.arange(0.0, 400.0 + 1e-9, 50.0))
    assert fine.flutter.status == coarse.flutter.status == stability.CONVERGED
    assert coarse.flutter.speed == pytest.approx(fine.flutter.speed, abs=SAME_ROOT)
    assert coarse.flutter.label == fine.flutter.label == "pitch"
    # the branches stay distinct at every grid speed (no collapse onto one root): their
    # separation is a sizeable fraction of the eigenvalue, far above round-off
    gap = np.abs(coarse.branches[0] - coarse.branches[1])
    assert np.all(gap > 0.05 * np.abs(coarse.branches).max(axis=0))
    # the verified crossing solves its own frozen-C equation (k consistent) to round-off
    assert coarse.residual <= stability.PK_RESIDUAL_TOL
    assert coarse.exact_residual <= stability.PK_RESIDUAL_TOL


def test_section_cli_exact_on_a_coarse_grid(capsys):
    """``section --aero exact --speeds 0:400:50`` gives the 0.5 m/s-grid p-k speed converged."""
    argv = _section_argv(GREAT_BELT) + ["--aero", "exact"]
    assert cli_main(argv + ["--speeds", "0:400:50", "--json"]) == 0
    coarse = json.loads(capsys.readouterr().out)
    assert cli_main(argv + ["--speeds", "0:150:0.5", "--json"]) == 0
    fine = json.loads(capsys.readouterr().out)
    assert coarse["flutter_status"] == fine["flutter_status"] == "converged"
    assert coarse["flutter_speed_m_s"] == pytest.approx(fine["flutter_speed_m_s"], abs=SAME_ROOT)
    assert coarse["critical_branch_label"] == "pitch"
    assert coarse["critical_branch_label_source"] == "tracking"


def test_section_static_divergence_off_the_grid_is_null(capsys):
    """``section --aero exact --speeds 0:40:1`` reported divergence 84.81 m/s "converged"."""
    argv = _section_argv(HUMBER_CABLES) + ["--aero", "exact", "--json"]
    assert cli_main(argv + ["--speeds", "0:40:1"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["divergence_speed_m_s"] is None and out["divergence_static_speed_m_s"] is None
    assert out["divergence_status"] == out["divergence_static_status"] == stability.NO_CROSSING
    assert cli_main(argv + ["--speeds", "0:100:1"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["divergence_status"] == stability.CONVERGED
    assert out["divergence_speed_m_s"] == pytest.approx(84.809, abs=1e-3)  # docstring above


def test_pk_grid_that_starts_unstable_is_not_converged():
    """A p-k grid starting above the flutter speed (48.18 m/s) has no crossing to locate."""
    res = stability.pk_sweep(_section_system(HUMBER_SECTION), np.arange(60.0, 120.0, 5.0))
    assert res.flutter.status == stability.UNSTABLE_AT_FIRST and np.isnan(res.flutter.speed)


# ----------------------------------------------------------------- A2: RFA sweep verification


def _recheck_sign_change(system, speed, omega_tol):
    """Independent check: the oscillatory eigenvalue of A(U) nearest the critical one keeps
    continuity over +-d and changes the sign of its real part (eigvals only)."""
    d = max(10 * SPEED_TOL, 1e-3 * speed)
    lam = np.linalg.eigvals(system.A(speed))
    osc = lam[np.abs(lam.imag) > omega_tol]
    crit = osc[np.argmax(osc.real)]
    out = []
    for u in (speed - d, speed + d):
        mu = np.linalg.eigvals(system.A(u))
        dist = np.sort(np.abs(mu - crit))
        # continuity: the nearest eigenvalue is clearly nearer than the next one
        assert dist[0] < 0.5 * dist[1]
        out.append(mu[np.argmin(np.abs(mu - crit))])
    assert out[0].real < 0 < out[1].real
    return (out[1].real - out[0].real) / (2 * d)


@pytest.mark.parametrize("grid", ["0:85:0.5", "0:85:10", "0:400:50", "60:85:0.5"])
def test_every_converged_crossing_is_verified_and_labelled_from_zero(coarse_system, coarse_fine,
                                                                     grid):
    """A6: on coarse and late-starting grids the critical branch is still TS1 (it was VA2 for a
    grid from 60 m/s), from tracking; A2: the crossing is the fine grid's and re-checks."""
    from bridgeflap.design.io.options import parse_range

    sw = stability.sweep(coarse_system, parse_range(grid, "speeds", 0.0))
    assert sw.flutter.status == stability.CONVERGED
    assert sw.flutter.speed == pytest.approx(coarse_fine.flutter.speed, abs=SAME_ROOT)
    assert sw.critical_branch == "TS1" and sw.flutter.label_source == "tracking"
    assert sw.divergence.status == stability.CONVERGED
    assert sw.divergence.speed == pytest.approx(coarse_fine.divergence.speed, abs=SAME_ROOT)
    slope = _recheck_sign_change(coarse_system, sw.flutter.speed,
                                 stability.oscillation_tolerance(coarse_system))
    # the reported slope is a secant over the same +-d bracket: equal to round-off
    assert sw.flutter.re_slope_per_m == pytest.approx(slope, rel=1e-6)


def test_a_jump_of_the_indicator_is_not_a_converged_crossing():
    """A pair that turns oscillatory with Re > 0 makes the flutter indicator jump from -0.1 to
    +0.1 at U = 5 without a root; Brent homes in on the jump, and the verification refuses it."""

    class Jump:
        """A(U): a stable pair -0.1 +- 1i and a block 0.1 +- sqrt(5 - U) (real, then complex)."""

        def A(self, u):
            c = 5.0 - u
            return np.array([[-0.1, 1.0, 0, 0], [-1.0, -0.1, 0, 0],
                             [0, 0, 0.1, 1.0], [0, 0, c, 0.1]])

    system = Jump()
    speeds = np.arange(0.0, 10.0 + 1e-9, 1.0)
    omega_tol = 1e-3
    vals = np.array([stability.flutter_function(system, u, omega_tol) for u in speeds])
    tracked = np.array([np.linalg.eigvals(system.A(u)) for u in speeds]).T
    c = crossings._locate(system, speeds, vals, SPEED_TOL, omega_tol, "flutter", tracked)
    assert c.status == stability.UNVERIFIED and np.isnan(c.speed)
    assert c.bracket == (5.0, 6.0) and c.reason


def test_unverified_crossing_below_a_converged_one_leaves_no_governing_speed():
    s = {"flutter_speed_m_s": float("nan"), "flutter_status": stability.UNVERIFIED,
         "flutter_bracket_m_s": [60.0, 70.0],
         "divergence_speed_m_s": 70.8, "divergence_status": stability.CONVERGED}
    out = analysis.critical_speed(s)
    assert np.isnan(out["critical_speed_m_s"])
    assert out["critical_mechanism"] == "flutter unverified_crossing"
    # above the converged limit it does not matter: divergence governs
    s["flutter_bracket_m_s"] = [75.0, 80.0]
    assert analysis.critical_speed(s) == {"critical_speed_m_s": 70.8,
                                          "critical_mechanism": "divergence"}


# ----------------------------------------------------------------- A3: static divergence


def test_static_divergence_has_a_status_and_is_null_off_the_grid(coarse_system, coarse_fine):
    u_static = coarse_fine.divergence_static_speed
    assert 75.0 < u_static < 77.0      # 76.00 m/s measured (built-in 75.95 m/s)
    s = coarse_fine.summary()
    assert s["divergence_static_status"] == stability.CONVERGED
    assert s["divergence_static_speed_m_s"] == u_static
    # the grid ends below: no number (it was 84.8 m/s for --speeds 0:40:1)
    low = stability.sweep(coarse_system, np.arange(0.0, 40.0 + 1e-9, 1.0)).summary()
    assert low["divergence_static_status"] == stability.NO_CROSSING
    assert np.isnan(low["divergence_static_speed_m_s"])
    # the grid starts above it
    assert stability.static_status(u_static, np.array([77.0, 80.0])) == \
        stability.UNSTABLE_AT_FIRST
    assert stability.static_status(float("nan"), np.array([0.0, 80.0])) == stability.NO_CROSSING


def test_closed_loop_static_divergence_includes_the_compensator(coarse_humber):
    """Through the facade: the closed-loop static check uses K(0) = b0 (-1 rad/rad on nine
    20 m flap pairs moves divergence by +0.75 m/s) and agrees with the closed-loop sweep; the
    open-loop value is the flap-less one."""
    ctrl = Controller(Compensator(0.0, 0.0, -1.0, 0.1, 0.5), tuple(np.arange(-400.0, 401, 100)),
                      20.0)
    res = analysis.closed_loop_flutter(coarse_humber, ctrl, np.arange(0.0, 120.0 + 1e-9, 1.0),
                                       n_modes=10)
    cl, ol = res.base.sweep, res.open_loop.sweep
    assert cl.divergence.status == ol.divergence.status == stability.CONVERGED
    # the static flap loads move the root far beyond the Brent tolerance (measured +0.75)
    assert cl.divergence_static_speed - ol.divergence_static_speed > 0.5
    # same root two ways: determinant condition vs real eigenvalue crossing (xtol 1e-3 m/s)
    assert cl.divergence.speed == pytest.approx(cl.divergence_static_speed, abs=SAME_ROOT)
    assert ol.divergence.speed == pytest.approx(ol.divergence_static_speed, abs=SAME_ROOT)
    s = res.summary()
    assert s["divergence_static_speed_m_s"] == cl.divergence_static_speed


# ----------------------------------------------------------------- A5: second branch, slope


def test_second_critical_branch_and_damping_slope(coarse_system, coarse_fine):
    sw = coarse_fine
    s = sw.summary()
    assert s["critical_branch_label"] == "TS1"
    # the next tracked oscillatory branch to cross on 0:120: TA1 near 107 m/s
    assert s["second_flutter_status"] == stability.CONVERGED
    assert s["second_critical_branch_label"] not in ("", "TS1")
    assert s["flutter_speed_m_s"] < s["second_flutter_speed_m_s"] <= 120.0
    j = sw.branch_labels.index(s["second_critical_branch_label"])
    u2 = s["second_flutter_speed_m_s"]
    i = np.searchsorted(sw.speeds, u2)
    # its own tracked branch changes sign in the grid interval holding the refined speed
    assert sw.branches[j, i - 1].real < 0 <= sw.branches[j, i].real
    # damping slope: d zeta/dU from the tracked TS1 branch's damping ratios on the grid
    # (central difference over +-0.5 m/s; O(h^2) error, a few per cent of the slope here)
    k = sw.branch_labels.index("TS1")
    i = np.searchsorted(sw.speeds, s["flutter_speed_m_s"])
    z = sw.damping_ratios()[k]
    fd = (z[i] - z[i - 1]) / (sw.speeds[i] - sw.speeds[i - 1])
    assert s["flutter_damping_slope_s_per_m"] == pytest.approx(fd, rel=0.05)
    assert s["flutter_damping_slope_s_per_m"] < -stability.HARD_ONSET_DAMPING_SLOPE_S_PER_M
    assert s["flutter_onset"] == "hard"


def test_onset_classification_threshold():
    w = 2 * np.pi * 0.2
    hard = stability.Crossing(70.0, 0.2, stability.CONVERGED, re_slope_per_m=2e-3 * w)
    soft = stability.Crossing(70.0, 0.2, stability.CONVERGED, re_slope_per_m=0.5e-3 * w)
    assert hard.damping_slope_s_per_m() == pytest.approx(-2e-3, rel=1e-12)
    assert (hard.onset(), soft.onset()) == ("hard", "soft")
    assert stability.Crossing(np.nan, np.nan, stability.NO_CROSSING).onset() == ""


def test_sensitivity_rows_say_their_branch(coarse_humber):
    from bridgeflap.design.sensitivity.local import local_sensitivity

    res = local_sensitivity(coarse_humber, ("deck.gj_nm2",), speeds="0:90:1", n_modes=10,
                            check=True)
    row = res.rows[0]
    assert row["flutter_valid_within_branch"] == res.critical_branch_label == "TS1"
    assert row["divergence_valid_within_branch"] == res.divergence_branch_label != ""
    # a 0.1 % step in GJ does not switch branches on the nominal Humber
    assert row["flutter_fd_same_branch"] is True
    d = res.summary()["derivatives"]["deck.gj_nm2"]
    assert d["flutter_valid_within_branch"] == "TS1"


# ----------------------------------------------------------------- branch-switch flags


def test_flags_on_a_factorial_design():
    # 3 x 3 grid in (sag, gj); the branch switches from TS1 to VS3 between sag levels 1 and 2
    rows = [{"sag": s, "gj": g, "critical_branch_label": "TS1" if s < 121 else "VS3"}
            for s in (118.0, 120.0, 122.5) for g in (4e11, 5e11, 6e11)]
    flags = flag_branch_neighbours(rows, ["sag", "gj"])
    assert all(f["neighbour_rule"] == "factorial" for f in flags)
    switched = [r["sag"] for r, f in zip(rows, flags, strict=True) if f["branch_switch_neighbour"]]
    # rows on both sides of the switch are flagged, the far level is not
    assert sorted(set(switched)) == [120.0, 122.5]
    i = rows.index({"sag": 120.0, "gj": 5e11, "critical_branch_label": "TS1"})
    assert flags[i]["neighbour_branches"] == ["VS3"]
    assert flags[i]["neighbour_rows"] == [i + 3]  # one level up in sag, same gj


def test_flags_on_a_scattered_design_and_missing_labels():
    rng = np.random.default_rng(1)
    x = rng.uniform(size=(30, 2))
    rows = [{"a": 1e11 * a, "b": b, "critical_branch_label": "TS1" if a < 0.5 else "TA1"}
            for a, b in x]
    rows[0]["critical_branch_label"] = ""  # a failed case: neither flagged nor a witness
    flags = flag_branch_neighbours(rows, ["a", "b"], k=3)
    assert flags[0]["neighbour_rule"] == "k_nearest"
    assert not flags[0]["branch_switch_neighbour"]
    for r, f in zip(rows[1:], flags[1:], strict=True):
        # normalised distance: a row far from the switch at a = 0.5 has only same-branch
        # neighbours (the 3 nearest of 30 uniform points lie within ~0.25 of it)
        if abs(r["a"] / 1e11 - 0.5) > 0.3:
            assert not f["branch_switch_neighbour"]
    assert any(f["branch_switch_neighbour"] for f in flags)
    assert all("" not in f["neighbour_branches"] for f in flags)
    assert flag_branch_neighbours([], ["a"]) == []
    with pytest.raises(ValueError):
        flag_branch_neighbours(rows, ["a"], design="nope")


def test_grid_starting_at_a_denormal_speed(coarse_humber):
    """A grid whose first speed is the smallest subnormal float (found by hypothesis 6.170 in
    the property test): tracking from U = 0 used to overflow the predictor's slope. The result
    must equal that of the grid starting at exactly 0 (the first point differs by 5e-324 m/s,
    far below any eigenvalue change: 1e-9 relative)."""
    import numpy as np

    from bridgeflap.model.analysis import flutter

    u = np.arange(0.0, 100.01, 5.0)
    v = u.copy()
    v[0] = 5e-324
    a, b = (flutter(coarse_humber, g, n_modes=10).summary() for g in (u, v))
    for k in ("flutter_speed_m_s", "divergence_speed_m_s"):
        assert (a[k] is None and b[k] is None) or abs(a[k] - b[k]) <= 1e-9 * abs(a[k]), k
    assert a["flutter_status"] == b["flutter_status"]
