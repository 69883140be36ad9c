"""Tests of bridgeflap.model.aero.theodorsen: exact C(k), Sears, T-functions and steady flap
derivatives."""

import numpy as np
import pytest
from scipy.special import jv, yv

from bridgeflap.model.aero.theodorsen import (
    flap_steady_coefficients,
    liepmann_admittance_sq,
    sears,
    sears_admittance_sq,
    t_functions,
    theodorsen,
    unit_admittance_sq,
)
from bridgeflap.model.errors import BridgeflapInputError

# (a) Published values of C(k) = F + iG. k = 0.1, 0.3: docs/humber_data.md#theodorsen-loads (4
# decimals); k = 0.5, 1.0: Bisplinghoff, Ashley & Halfman (1955) table of F, G (4 decimals).
TABULATED_C = [
    (0.1, 0.8319, -0.1723),
    (0.3, 0.6650, -0.1793),
    (0.5, 0.5979, -0.1507),
    (1.0, 0.5394, -0.1003),
]


@pytest.mark.parametrize(("k", "f", "g"), TABULATED_C)
def test_theodorsen_tabulated(k, f, g):
    c = theodorsen(k)
    # Tables are rounded to 4 decimals: half a unit in the last place is 5e-5, plus float slack.
    assert abs(c.real - f) <= 6e-5
    assert abs(c.imag - g) <= 6e-5


def test_theodorsen_limits():
    # C(0) = 1 and C(inf) = 1/2 are returned exactly (special-cased), so equality is exact.
    assert theodorsen(0.0) == 1.0
    assert theodorsen(np.inf) == 0.5
    # Asymptotics C(k) = 1/2 - i/(8k) + O(1/k^2): at k = 1e4 the O(1/k^2) remainder is ~1e-8.
    k = 1.0e4
    assert abs(theodorsen(k) - (0.5 - 1j / (8 * k))) < 1e-7
    # Small k: 1 - C(k) is of order k |ln k| (about 1.8e-7 at k = 1e-8); 5e-7 bounds it with
    # margin while still proving continuity at k = 0 to 7 digits.
    assert abs(theodorsen(1e-8) - 1.0) < 5e-7


def test_theodorsen_vectorised_no_warning_and_conjugate_symmetry():
    k = np.array([0.0, 1e-3, 0.2, 2.0, np.inf])
    c = theodorsen(k)
    assert c.shape == k.shape
    # C(-k) = conj C(k) for a real signal: same formula, so agreement to rounding (1e-15).
    np.testing.assert_allclose(theodorsen(-k), np.conj(c), atol=1e-15)


def test_seed_eq4_equals_hankel_form():
    # (c) Cross-method: seed Eq. (4) in J, Y vs the Hankel form;
    # docs/humber_data.md#theodorsen-loads reports a max difference of 3.5e-16, so 1e-13 leaves room
    # for libm differences between platforms.
    k = np.geomspace(1e-3, 50.0, 400)
    j0, j1, y0, y1 = jv(0, k), jv(1, k), yv(0, k), yv(1, k)
    seed = (j1 - 1j * y1) / ((j1 + y0) - 1j * (y1 - j0))
    np.testing.assert_allclose(theodorsen(k), seed, rtol=0, atol=1e-13)


def test_theodorsen_rejects_complex():
    with pytest.raises(BridgeflapInputError):
        theodorsen(1.0 + 1.0j)


def test_sears_limits_and_modulus():
    # S(0) = 1 exactly (J0(0) = 1, J1(0) = 0, C(0) = 1).
    assert sears(0.0) == 1.0
    # |S|^2 values quoted in docs/humber_data.md#gust-admittance to 3 decimals:
    # tolerance half a unit, 5e-4.
    for k, val in [(0.1, 0.701), (0.5, 0.277), (1.0, 0.152)]:
        assert abs(sears_admittance_sq(k) - val) < 5e-4
    # Large-k behaviour |S| ~ 1/sqrt(2 pi k): at k = 200 the relative correction is O(1/k).
    k = 200.0
    assert abs(np.abs(sears(k)) * np.sqrt(2 * np.pi * k) - 1.0) < 0.01


def test_sears_leading_edge_reference_same_modulus():
    # (b) Invariant: changing the gust reference point only multiplies S by exp(-ik).
    k = np.geomspace(1e-3, 10, 50)
    s_le = sears(k) * np.exp(-1j * k)
    np.testing.assert_allclose(np.abs(s_le), np.abs(sears(k)), rtol=1e-14)


def test_liepmann_underestimates_sears_by_at_most_14_5_percent():
    # docs/humber_data.md#gust-admittance: Liepmann underestimates |S|^2 by up
    # to 14.5 % near k = 0.24.
    k = np.geomspace(1e-4, 20.0, 20000)
    ratio = liepmann_admittance_sq(k) / sears_admittance_sq(k)
    deficit = 1.0 - ratio.min()
    # Worst case stated to 3 significant figures (14.5 %): window +-0.1 % absolute.
    assert 0.144 < deficit < 0.146
    # Location quoted as k ~ 0.24 (2 s.f.): the grid resolves it to 0.05 %.
    assert abs(k[np.argmin(ratio)] - 0.24) < 0.01
    # "Underestimates" holds except for a sub-0.1 % overshoot at high k (k > 3): bound it.
    assert ratio.max() < 1.001
    assert np.all(ratio[k < 3.0] <= 1.0)


def test_unit_admittance():
    k = np.array([0.0, 0.1, 10.0])
    np.testing.assert_array_equal(unit_admittance_sq(k), np.ones(3))
    assert liepmann_admittance_sq(0.0) == 1.0


def test_t_functions_trailing_edge_all_vanish():
    # c = +1: mu = 0, s = 0, so every T except the hinge-moment constant T14 is exactly 0
    # (T14 = 1/16 + a c / 2 does not depend on the flap chord). Rounding only: 1e-15.
    for a in (0.0, -0.4):
        t = t_functions(1.0, a=a)
        for key, val in t.items():
            if key == "T14":
                assert val == pytest.approx(1.0 / 16.0 + 0.5 * a)
            else:
                assert abs(val) < 1e-15, key


def test_t_functions_leading_edge_reduce_to_pitch_terms():
    # c = -1: the flap is the whole plate, so with a = -1 the flap terms equal the pitch terms
    # of Theodorsen's loads (docs/humber_data.md#flap-loads-and-t-functions check 1).
    # Closed-form identities: 1e-12.
    a = -1.0
    t = t_functions(-1.0, a=a)
    tol = 1e-12
    assert abs(-t["T4"] - np.pi) < tol
    assert abs(-t["T1"] - np.pi) < tol
    assert abs(t["T10"] / np.pi - 1.0) < tol
    assert abs(t["T11"] / (2 * np.pi) - (0.5 - a)) < tol
    assert abs(t["T4"] + t["T10"]) < tol
    c = -1.0
    assert abs((t["T1"] - t["T8"] - (c - a) * t["T4"] + 0.5 * t["T11"]) / np.pi - 1.5) < tol
    assert abs(-(t["T7"] + (c - a) * t["T1"]) / np.pi - (0.125 + a**2)) < tol


def test_t_functions_vectorised_and_range():
    c = np.linspace(-1, 1, 7)
    t = t_functions(c)
    assert all(v.shape == c.shape for v in t.values())
    np.testing.assert_array_equal(t["T6"], t["T2"])
    with pytest.raises(BridgeflapInputError):
        t_functions(1.2)


@pytest.mark.parametrize("c", [0.0, 0.5, 8.0 / 11.0, 0.9])
def test_steady_te_flap_thin_aerofoil(c):
    # (c) Independent steady thin-aerofoil (Glauert) flap result, as in [CODE-1] static_flap.m
    # (docs/humber_data.md#flap-loads-and-t-functions check 3): dC_L/dbeta = 2(arccos c + sqrt(1 -
    # c^2)) and dC_M,1/4/dbeta = -(1/2)(1 + c) sqrt(1 - c^2).
    # Transfer to mid-chord: C_M,mid = C_M,1/4 + C_L / 4. Analytic identity: 1e-12.
    lift, moment = flap_steady_coefficients(c)
    s = np.sqrt(1 - c * c)
    assert abs(lift - 2 * (np.arccos(c) + s)) < 1e-12
    cm_quarter = -0.5 * (1 + c) * s
    assert abs(moment - (cm_quarter + lift / 4)) < 1e-12


# docs/humber_data.md#flap-loads-and-t-functions table: (hinge c, TE dCL, TE dCM_mid, LE dCL,
# LE dCM_mid), 3 decimals.
FLAP_TABLE = [
    (1 - 6.0 / 22.0, 2.886, 0.129, 0.140, 0.129),  # 3 m flap on 2b = 22 m
    (1 - 6.0 / 28.5, 2.549, 0.088, 0.094, 0.088),  # 3 m flap on 28.5 m
    (0.6, 3.455, 0.224, 0.255, 0.224),  # 20 % chord
]


@pytest.mark.parametrize(("c", "te_cl", "te_cm", "le_cl", "le_cm"), FLAP_TABLE)
def test_flap_table_values(c, te_cl, te_cm, le_cl, le_cm):
    # Table rounded to 3 decimals: half a unit is 5e-4; 6e-4 allows for float rounding at
    # the boundary.
    te = flap_steady_coefficients(c, edge="trailing")
    le = flap_steady_coefficients(-c, edge="leading")
    assert abs(te.lift_slope - te_cl) < 6e-4
    assert abs(te.moment_slope_mid - te_cm) < 6e-4
    assert abs(le.lift_slope - le_cl) < 6e-4
    assert abs(le.moment_slope_mid - le_cm) < 6e-4


def test_le_flap_classical_lift_and_same_moment():
    # LE-flap lift 2(theta_h - sin theta_h), cos theta_h = -e (classical thin-aerofoil);
    # the mid-chord moment equals the mirror TE flap's (antisymmetry of the camber line).
    # Both are closed-form identities: 1e-12.
    for e in (-0.9, -0.6, -0.2):
        le = flap_steady_coefficients(e, edge="leading")
        th = np.arccos(-e)
        assert abs(le.lift_slope - 2 * (th - np.sin(th))) < 1e-12
        assert abs(le.moment_slope_mid - flap_steady_coefficients(-e).moment_slope_mid) < 1e-12


def test_flap_degenerate_hinges():
    # A flap spanning the whole chord is a rigid pitch: steady dC_L = 2 pi and (lift at the
    # quarter chord) dC_M,mid = pi/2; a zero-chord flap gives nothing. Exact limits of the
    # T-functions (mu = pi or 0, s = 0): rounding only, 1e-12.
    pitch = (2 * np.pi, np.pi / 2)
    np.testing.assert_allclose(flap_steady_coefficients(-1.0, "trailing"), pitch, atol=1e-12)
    np.testing.assert_allclose(flap_steady_coefficients(1.0, "leading"), pitch, atol=1e-12)
    np.testing.assert_allclose(flap_steady_coefficients(1.0, "trailing"), (0, 0), atol=1e-12)
    np.testing.assert_allclose(flap_steady_coefficients(-1.0, "leading"), (0, 0), atol=1e-12)


def test_flap_bad_input():
    with pytest.raises(BridgeflapInputError):
        flap_steady_coefficients(0.5, edge="middle")
    with pytest.raises(BridgeflapInputError):
        flap_steady_coefficients(-1.5, edge="trailing")
    with pytest.raises(BridgeflapInputError):
        flap_steady_coefficients(1.01, edge="leading")
