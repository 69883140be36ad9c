"""Tests of bridgeflap.model.aero.wind: vertical turbulence spectra, coherence and admittance."""

import numpy as np
import pytest
from scipy.integrate import quad

from bridgeflap.model.aero.theodorsen import sears_admittance_sq
from bridgeflap.model.aero.wind import (
    SPECTRUM_KINDS,
    admittance_sq,
    busch_panofsky,
    busch_panofsky_omega,
    busch_panofsky_variance_ratio,
    coherence,
    default_length_scale_w,
    friction_velocity_from_intensity,
    kaimal_variance_ratio,
    kaimal_w,
    vertical_spectrum,
    von_karman_w,
)
from bridgeflap.model.errors import BridgeflapInputError

U, Z = 40.0, 30.0  # representative deck wind speed [m/s] and height [m]
# QUADPACK on [0, inf) (variable map to [0, 1]) handles the slowly decaying n^(-5/3) tail and
# reaches ~1e-10 relative here; 1e-7 leaves a wide margin while still resolving the 4th
# significant figure of every variance ratio tested below.
QUAD_RTOL = 1e-7


def _variance_hz(fun):
    val, _ = quad(lambda n: float(fun(n)), 0.0, np.inf, limit=400, epsabs=0.0, epsrel=1e-9)
    return val


def test_busch_panofsky_variance_ratio_by_quadrature():
    # Seed text after Eq. (15): sigma_w^2 ~ 1.67 u*^2;
    # docs/humber_data.md#turbulence-spectrum-and-coherence: 1.6728.
    u_star = 1.3
    var = _variance_hz(lambda n: busch_panofsky(n, U, Z, u_star))
    assert var / u_star**2 == pytest.approx(busch_panofsky_variance_ratio(), rel=QUAD_RTOL)
    assert busch_panofsky_variance_ratio() == pytest.approx(1.6728, abs=5e-5)  # 4 decimals


def test_busch_panofsky_omega_is_seed_eq15_and_same_variance():
    u_star = 2.0
    w = np.geomspace(1e-3, 100.0, 50)
    f = w * Z / (2 * np.pi * U)
    seed = 2 * np.pi / w * u_star**2 * 3.36 * f / (1 + 10 * f ** (5 / 3)) / (4 * np.pi)
    # Same expression rearranged: rounding only (1e-13 relative).
    np.testing.assert_allclose(busch_panofsky_omega(w, U, Z, u_star), seed, rtol=1e-13)
    np.testing.assert_allclose(busch_panofsky_omega(-w, U, Z, u_star), seed, rtol=1e-13)
    # Two-sided in omega: int_{-inf}^{inf} S(omega) d omega = 2 int_0^inf = sigma_w^2.
    half = _variance_hz(lambda x: busch_panofsky_omega(x, U, Z, u_star))
    assert 2 * half == pytest.approx(busch_panofsky_variance_ratio() * u_star**2, rel=QUAD_RTOL)


def test_busch_panofsky_peak_and_finite_at_zero():
    # f S(f) peaks at f = 0.15^0.6 = 0.320 (docs/humber_data.md#turbulence-spectrum-and-coherence);
    # grid spacing 1e-4 relative.
    n = np.geomspace(1e-4, 10.0, 200001)
    fs = n * busch_panofsky(n, U, Z, 1.0)
    assert n[np.argmax(fs)] * Z / U == pytest.approx(0.15**0.6, rel=1e-3)
    assert busch_panofsky(0.0, U, Z, 1.0) == pytest.approx(3.36 * Z / U)


def test_friction_velocity():
    # docs/humber_data.md#turbulence-spectrum-and-coherence: sigma_w/U = 0.07
    # gives u* = 0.0541 U (3 s.f.).
    assert friction_velocity_from_intensity(U, 0.07) / U == pytest.approx(0.0541, abs=5e-5)
    u_star = friction_velocity_from_intensity(U, 0.07)
    assert busch_panofsky_variance_ratio() * u_star**2 == pytest.approx((0.07 * U) ** 2)


def test_kaimal_and_von_karman_variances():
    u_star = 1.1
    var = _variance_hz(lambda n: kaimal_w(n, U, Z, u_star))
    assert var / u_star**2 == pytest.approx(kaimal_variance_ratio(), rel=QUAD_RTOL)
    # Kaimal's ratio: closed-form Beta integral, 2 * 5.3^-0.6 * (0.6 pi)/sin(0.6 pi) = 1.4573.
    assert kaimal_variance_ratio() == pytest.approx(1.4573, abs=1e-4)
    sigma, length = 2.5, 12.0
    var = _variance_hz(lambda n: von_karman_w(n, U, sigma, length))
    # Exact von Karman constant: integrates to sigma^2 analytically; quadrature error only.
    assert var == pytest.approx(sigma**2, rel=QUAD_RTOL)
    # Low-frequency limit S(0) = 4 sigma^2 L / U (definition of the integral scale).
    assert von_karman_w(0.0, U, sigma, length) == pytest.approx(4 * sigma**2 * length / U)


def test_von_karman_default_length_scale_puts_peak_at_busch_panofsky_peak():
    length = default_length_scale_w(Z)
    n = np.geomspace(1e-4, 10.0, 200001)
    peak_vk = n[np.argmax(n * von_karman_w(n, U, 1.0, length))]
    peak_bp = n[np.argmax(n * busch_panofsky(n, U, Z, 1.0))]
    assert peak_vk == pytest.approx(peak_bp, rel=1e-3)  # grid spacing ~5e-5 relative


@pytest.mark.parametrize("kind", SPECTRUM_KINDS)
def test_vertical_spectrum_scaled_to_intensity(kind):
    intensity = 0.07
    var = _variance_hz(lambda n: vertical_spectrum(kind, n, U, Z, intensity))
    assert var == pytest.approx((intensity * U) ** 2, rel=QUAD_RTOL)


def test_vertical_spectrum_input_errors():
    with pytest.raises(BridgeflapInputError) as info:
        vertical_spectrum("davenport", 0.1, U, Z, 0.07)
    assert info.value.field == "spectrum"
    with pytest.raises(BridgeflapInputError):
        vertical_spectrum("kaimal", 0.1, U, Z, 0.0)
    with pytest.raises(BridgeflapInputError):
        vertical_spectrum("kaimal", 0.1, -1.0, Z, 0.07)
    with pytest.raises(BridgeflapInputError):
        vertical_spectrum("kaimal", 0.1, U, Z, 0.07, length_scale=10.0)
    with pytest.raises(BridgeflapInputError):
        vertical_spectrum("busch-panofsky", -0.1, U, Z, 0.07)
    # Explicit length scale is honoured for von Karman: S(0) = 4 sigma^2 L / U.
    s0 = vertical_spectrum("von_karman", 0.0, U, Z, 0.07, length_scale=20.0)
    assert s0 == pytest.approx(4 * (0.07 * U) ** 2 * 20.0 / U)


def test_coherence_limits():
    n = np.array([0.0, 0.1, 1.0])
    # Zero separation or zero frequency: fully coherent (exactly 1).
    np.testing.assert_array_equal(coherence(n, 0.0, U, 8.0), 1.0)
    assert coherence(0.0, 500.0, U, 8.0) == 1.0
    # Large separation: decorrelated; exp(-8 * 1 * 1e4 / 40) underflows towards 0.
    assert coherence(1.0, 1e4, U, 8.0) < 1e-100
    # Seed Eq. (16) in omega: exp(-c L omega / (2 pi U)), same number (rounding, 1e-15).
    w = 2 * np.pi * 0.3
    assert coherence(0.3, 50.0, U, 7.0) == pytest.approx(np.exp(-7.0 * 50.0 * w / (2 * np.pi * U)))
    # Symmetric in the sign of the separation and monotone decreasing in n.
    assert coherence(0.3, -50.0, U, 7.0) == coherence(0.3, 50.0, U, 7.0)
    assert np.all(np.diff(coherence(np.linspace(0, 2, 20), 30.0, U, 7.0)) < 0)


def test_admittance_kinds():
    k = np.array([0.0, 0.1, 1.0])
    np.testing.assert_array_equal(admittance_sq("unit", k), 1.0)
    np.testing.assert_allclose(admittance_sq("liepmann", k), 1 / (1 + 2 * np.pi * k))
    np.testing.assert_allclose(admittance_sq("sears", k), sears_admittance_sq(k))
    with pytest.raises(BridgeflapInputError) as info:
        admittance_sq("davenport", k)
    assert info.value.field == "admittance"
