"""The kink check of the local sensitivities (design/sensitivity/ift.py ``kink_check``): a
derivative that does not describe the speed a few per cent away is flagged.

Synthetic speeds ``U(p)`` with a known shape (fast), the table and the tornado of a flagged row,
and the Humber case that motivated the check (slow: seven sweeps of 30 modes).
"""

import json

import numpy as np
import pytest

from bridgeflap.design.sensitivity.ift import (
    KINK_ABS_TOL,
    KINK_REL_TOL,
    KINK_STEP,
    SensitivityResult,
    kink_check,
)

P0, U0, H = 5.0e11, 70.0, KINK_STEP * 5.0e11


def _check(u, d_ift, labels=("TS1", "TS1", "TS1")):
    return kink_check(P0, H, u(P0), u(P0 - H), u(P0 + H), d_ift, labels)


def test_a_v_shaped_minimum_at_the_nominal_value_is_flagged():
    # U = U0 (1 + 0.5 |p/p0 - 1|): one-sided relative slopes -0.5 and +0.5; the derivative an
    # IFT returns at such a point is either side's or near zero (Humber's GJ: -0.003)
    def u(p):
        return U0 * (1 + 0.5 * abs(p / P0 - 1))

    for d_ift in (0.0, -0.003 * U0 / P0, 0.5 * U0 / P0):
        c = _check(u, d_ift)
        assert c["kink"] is True, c
        assert c["relative_derivative_minus"] == pytest.approx(-0.5, rel=1e-9)
        assert c["relative_derivative_plus"] == pytest.approx(0.5, rel=1e-9)
        assert c["derivative_plus"] == pytest.approx(0.5 * U0 / P0, rel=1e-9)
        assert "vs IFT" in c["kink_reason"]
    # without a derivative the two one-sided slopes are compared with each other
    assert _check(u, np.nan)["kink"] is True


def test_a_kink_inside_the_step_but_off_the_nominal_value_is_flagged():
    # the branch switch at 0.97 p0 (Humber's lies at 0.90-0.95 GJ): the derivative at p0 is the
    # right branch's slope, +0.5; over the -5 % step the mean slope is only (0.03 - 0.02) / 0.05
    # * 0.5 = 0.1 (of U0; relative to U(p0) = 1.015 U0: 0.1 / 1.015)
    def u(p):
        return U0 * (1 + 0.5 * abs(p / P0 - 0.97))

    c = _check(u, 0.5 * U0 / P0)
    assert c["relative_derivative_minus"] == pytest.approx(0.1 / 1.015, rel=1e-9)
    assert c["kink"] is True and c["kink_reason"].startswith("one-sided -step 0.0985 ")


@pytest.mark.parametrize("slope, curvature", [(0.3, 0.0), (0.3, 0.5), (-0.6, 2.0), (0.0, 0.3)])
def test_a_smooth_speed_is_not_flagged(slope, curvature):
    # U = U0 (1 + s x + c x^2), x = p/p0 - 1: the one-sided relative slopes are s -+ c h, off
    # the derivative s by c h = 0.015 .. 0.1 here, inside 0.02 + 0.25 |s| (a flat minimum
    # with c = 0.5 would be flagged: 0.025 > 0.02)
    def u(p):
        x = p / P0 - 1
        return U0 * (1 + slope * x + curvature * x * x)

    c = _check(u, slope * U0 / P0)
    assert c["kink"] is False and c["kink_reason"] == ""
    assert c["relative_derivative_plus"] - slope == pytest.approx(curvature * KINK_STEP, rel=1e-6)
    assert _check(u, np.nan)["kink"] is False


def test_the_tolerance_is_the_stated_one():
    # a one-sided slope just inside / just outside 0.02 + 0.25 |D| (relative units)
    d = 0.4
    tol = KINK_ABS_TOL + KINK_REL_TOL * d
    for off, flagged in ((0.99 * tol, False), (1.01 * tol, True)):
        def u(p, off=off):
            x = p / P0 - 1
            return U0 * (1 + d * x + (off * x if x > 0 else 0.0))

        assert _check(u, d * U0 / P0)["kink"] is flagged


def test_a_branch_switch_or_a_lost_crossing_within_the_step_is_flagged():
    def u(p):
        return U0 * (1 + 0.3 * (p / P0 - 1))

    c = _check(u, 0.3 * U0 / P0, labels=("TS1", "VS3", "TS1"))
    assert c["kink"] is True and "critical branch TS1 at p, - VS3" in c["kink_reason"]
    c = kink_check(P0, H, U0, np.nan, u(P0 + H), 0.3 * U0 / P0)
    assert c["kink"] is True and "no crossing at p-step" in c["kink_reason"]
    # no nominal speed: not assessed
    assert kink_check(P0, H, np.nan, U0, U0)["kink"] is None


def _result(kinked: bool) -> SensitivityResult:
    row = {"parameter": "deck.gj_nm2", "value": P0, "d_flutter_speed": 0.0,
           "relative_d_flutter_speed": -0.003, "relative_d_divergence_speed": 0.3,
           "relative_d_flutter_speed_minus": -0.17, "relative_d_flutter_speed_plus": 0.087,
           "flutter_kink": kinked, "divergence_kink": False,
           "flutter_kink_reason": "one-sided -0.17, +0.087 vs IFT -0.003" if kinked else "",
           "divergence_kink_reason": "", "kink": kinked}
    other = {**row, "parameter": "deck.half_chord_m", "relative_d_flutter_speed": 0.8,
             "flutter_kink": False, "flutter_kink_reason": "", "kink": False}
    return SensitivityResult("humber", 69.5, 90.0, "converged", "converged", 30, (row, other),
                             {"rel_step_kink": KINK_STEP})


def test_table_summary_and_tornado_mark_the_flagged_input(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    res = _result(True)
    text = res.table()
    assert "deck.gj_nm2: UF: one-sided" in text
    # the kink column: UF on the flagged row, - on the other
    assert text.splitlines()[2].split()[-1] == "UF" and text.splitlines()[3].split()[-1] == "-"
    s = json.loads(json.dumps(res.to_dict(), allow_nan=False))
    assert s["kinked_parameters"] == ["deck.gj_nm2"]
    assert s["derivatives"]["deck.gj_nm2"]["kink"] is True
    assert "relative_d_flutter_speed_minus" in res.to_dataframe().columns
    ax = res.plot().axes[0]
    labels = [t.get_text() for t in ax.get_yticklabels()]
    assert "deck.gj_nm2 (kink)" in labels and "deck.half_chord_m" in labels
    assert any("one-sided" in t.get_text() for t in ax.get_legend().get_texts())
    # nothing flagged: no mark, no note
    clean = _result(False)
    assert "(kink)" not in [t.get_text() for t in clean.plot().axes[0].get_yticklabels()]
    assert "does not describe" not in clean.table()
    assert clean.summary()["kinked_parameters"] == []


@pytest.mark.slow
def test_humber_gj_is_flagged(coarse_humber):
    """Humber's GJ sits at the bottom of a V in U_F(GJ): the derivative is near zero while 5 %
    of GJ moves U_F by ~0.4-0.9 % (coarse mesh, 30 modes: 70.11 / 69.51 / 69.81 m/s at
    0.95 / 1 / 1.05 GJ). About 15 s."""
    from bridgeflap.design.sensitivity.local import local_sensitivity

    res = local_sensitivity(coarse_humber, ("deck.gj_nm2",), speeds="0:100:1", n_modes=30)
    r = res.rows[0]
    assert abs(r["relative_d_flutter_speed"]) < 0.02
    assert r["relative_d_flutter_speed_minus"] < -0.1 < 0.05 < r["relative_d_flutter_speed_plus"]
    assert r["flutter_kink"] is True and r["kink"] is True
    assert res.summary()["kinked_parameters"] == ["deck.gj_nm2"]
    json.dumps(res.to_dict(), allow_nan=False)
