"""Random-response engine: model/spectral.py, model/response/simulation.py, CasADi form in
model/aeroelastic/symbolic.py.

PSD convention under test (module docstring of bridgeflap.model.spectral): one-sided in omega >= 0,
sigma^2 = int_0^inf G d omega; white noise of intensity Q has G0 = Q / pi (two-sided Q / 2 pi).
"""

import time

import casadi as ca
import numpy as np
import pytest

from bridgeflap.model.aeroelastic.symbolic import casadi_spectral_rms
from bridgeflap.model.response.simulation import lyapunov_rms, simulate_monte_carlo
from bridgeflap.model.spectral import (
    adaptive_frequency_grid,
    exponential_coherence,
    response_psd,
    rms_from_psd,
    separable_csd,
    spectral_rms,
    white_noise_intensity,
)


# ----------------------------------------------------------------------------------------------
# case factories
# ----------------------------------------------------------------------------------------------
def sdof(mass=2.0, omega_n=2.0, zeta=0.02):
    """State space of m x'' + c x' + k x = f; state (x, x'), output x."""
    k = mass * omega_n**2
    c = 2.0 * zeta * mass * omega_n
    A = np.array([[0.0, 1.0], [-k / mass, -c / mass]])
    B = np.array([[0.0], [1.0 / mass]])
    C = np.array([[1.0, 0.0]])
    return A, B, C, k, c


def two_dof(zeta=0.02, stiffness_scale=1.0):
    """2-DOF chain driven by 3 correlated inputs; outputs both displacements and one velocity.

    Returns A, B, C, A1 with dA/d(stiffness_scale) = A1 (A is affine in the scale).
    """
    M = np.diag([1.0, 1.5])
    K0 = np.array([[3.0, -1.0], [-1.0, 2.0]])
    K = stiffness_scale * K0
    # Rayleigh damping with modal damping ~zeta at the two (unscaled) natural frequencies
    w = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K0)).real))
    a0, a1 = np.linalg.solve(np.array([[1 / w[0], w[0]], [1 / w[1], w[1]]]), [2 * zeta] * 2)
    Cd = a0 * M + a1 * K0
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Minv @ K, -Minv @ Cd]])
    A1 = np.block([[np.zeros((2, 2)), np.zeros((2, 2))], [-Minv @ K0, np.zeros((2, 2))]])
    F = np.array([[1.0, 0.5, 0.2], [0.3, 0.8, 1.1]])  # force per unit input
    B = np.vstack([np.zeros((2, 3)), Minv @ F])
    C = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    return A, B, C, A1


STRIP_POSITIONS = np.array([0.0, 4.0, 10.0])  # [m]


def fixed_coherence():
    """Return a constant (frequency-independent) positive-definite coherence matrix of 3 inputs."""
    d = np.abs(STRIP_POSITIONS[:, None] - STRIP_POSITIONS[None, :])
    return np.exp(-d / 8.0)


# ----------------------------------------------------------------------------------------------
# (a) analytic values
# ----------------------------------------------------------------------------------------------
def test_sdof_white_noise_closed_form():
    """sigma_x^2 = pi S0 / (k c) for two-sided force PSD S0 on (-inf, inf) [N^2 per rad/s].

    Equivalent one-sided form (this package's convention): G0 = 2 S0, sigma_x^2 = pi G0 / (2 k c).
    Source: Crandall & Mark (1963), Random Vibration in Mechanical Systems; Newland (1993) §7.
    """
    A, B, C, k, c = sdof()
    S0 = 3.0  # two-sided
    G0 = 2.0 * S0  # one-sided
    exact = np.sqrt(np.pi * S0 / (k * c))
    omega_max = 200.0  # 100 omega_n: truncated tail G0/(3 m^2 omega_max^3) is ~1e-9 relative
    res = spectral_rms(A, B, C, lambda w: np.array([[G0]]), omega_max)
    assert res.status == "ok"
    # quadrature error: the adaptive grid puts ~40 sinh-spaced points across the peak; the brief
    # asks for < 1 %, and the measured agreement is far better (the refinement estimate bounds it)
    assert res.rms[0] == pytest.approx(exact, rel=1e-2)
    assert abs(res.rms[0] / exact - 1.0) < max(10 * res.convergence, 1e-4)
    # Lyapunov with the equivalent intensity Q = pi G0 = 2 pi S0: exact up to round-off of the
    # Bartels-Stewart solve of a 2x2 well-conditioned problem, hence 1e-10
    lyap = lyapunov_rms(A, B, C, white_noise_intensity(G0))
    assert lyap.status == "ok"
    assert lyap.rms[0] == pytest.approx(exact, rel=1e-10)


def test_flat_one_sided_spectrum_equals_lyapunov_sdof():
    """Convention check: flat one-sided G0 in spectral_rms <-> Q = pi G0 in lyapunov_rms."""
    A, B, C, _, _ = sdof(zeta=0.05)
    G0 = 0.7
    spec = spectral_rms(A, B, C, lambda w: np.array([[G0]]), 400.0)
    lyap = lyapunov_rms(A, B, C, np.pi * G0)
    # 5e-4: quadrature + truncated tail (~1e-9), well above the measured ~1e-6
    assert spec.rms[0] == pytest.approx(lyap.rms[0], rel=5e-4)


# ----------------------------------------------------------------------------------------------
# (c) cross-method agreement
# ----------------------------------------------------------------------------------------------
def test_two_dof_correlated_white_spectral_vs_lyapunov():
    """2-DOF, 3 inputs with a fixed coherence matrix: quadrature vs exact Lyapunov."""
    A, B, C, _ = two_dof()
    R = fixed_coherence()
    G0 = 0.5
    spec = spectral_rms(A, B, C, lambda w: G0 * R, omega_max=300.0)
    lyap = lyapunov_rms(A, B, C, white_noise_intensity(G0 * R))
    assert spec.status == "ok" and lyap.status == "ok"
    # displacements: tail ~ omega_max^-3, negligible; velocity: its PSD decays as omega^-2, so the
    # tail beyond omega_max is ~ G0 |F_eff|^2 / (m^2 omega_max) ~ 1e-3 of the variance:
    # displacement outputs within 1e-3, velocity within 2e-3 (half the variance deficit)
    np.testing.assert_allclose(spec.rms[:2], lyap.rms[:2], rtol=1e-3)
    np.testing.assert_allclose(spec.rms[2], lyap.rms[2], rtol=2e-3)


def test_full_csd_matches_auto_psd_and_schur_matches_modal():
    """Auto-PSD equals the diagonal of the full CSD; modal and Schur paths agree."""
    A, B, C, _ = two_dof()
    coh = exponential_coherence(STRIP_POSITIONS, decay_coefficient=8.0, wind_speed=20.0)
    csd = separable_csd(lambda w: 1.0 / (1.0 + w**2), coh, admittance_squared=lambda w: 0.8)
    omegas = np.linspace(0.0, 5.0, 57)
    auto = response_psd(A, B, C, omegas, csd)
    full = response_psd(A, B, C, omegas, csd, full=True)
    schur = response_psd(A, B, C, omegas, csd, method="schur")
    # same arithmetic up to reordering: round-off only
    np.testing.assert_allclose(auto, np.einsum("kpp->kp", full).real, rtol=1e-12)
    # Hermitian output CSD (invariant)
    np.testing.assert_allclose(full, np.conj(np.swapaxes(full, 1, 2)), atol=1e-14)
    # modal (cond(V) ~ 1e1) vs Schur: both backward stable here, agreement ~1e-13
    np.testing.assert_allclose(schur, auto, rtol=1e-10, atol=1e-14 * np.max(auto))


def test_monte_carlo_vs_spectral():
    """Time-domain simulation with synthesised correlated turbulence (docs/methods.md#buffeting)."""
    A, B, C, _ = two_dof(zeta=0.05)
    coh = exponential_coherence(STRIP_POSITIONS, decay_coefficient=8.0, wind_speed=10.0)

    def s(w):
        return 0.4 / (1.0 + (w / 3.0) ** 2)

    omega_top = 10.0  # band limit of the synthesis; the spectral integral uses the same limit
    T0 = 1200.0  # period of the synthesised records [s]
    d_omega = 2.0 * np.pi / T0
    omegas = (np.arange(int(omega_top / d_omega)) + 0.5) * d_omega
    t0 = time.perf_counter()
    mc = simulate_monte_carlo(
        A, B, C, omegas, s, coh, dt=0.05, duration=400.0, seed=12345, n_records=24
    )
    elapsed = time.perf_counter() - t0
    spec = spectral_rms(A, B, C, separable_csd(s, coh), omega_max=omegas[-1] + 0.5 * d_omega)
    assert mc.status == "ok" and spec.status == "ok"
    assert elapsed < 10.0
    # sampling error dominates: ZOH with midpoint input has bias (omega dt)^2/24 < 1e-3 at the
    # modes, the midpoint-rule synthesis with d_omega / (zeta omega_n) < 0.1 is exact to ~1e-6;
    # so the MC mean must lie within 3 standard errors (a 99.7 % band for a normal estimate)
    z = np.abs(mc.rms - spec.rms) / mc.standard_error
    assert np.all(z < 3.0), (mc.rms, spec.rms, mc.standard_error)
    # and the standard error must be meaningful (a few percent, not zero or huge)
    assert np.all(mc.standard_error / mc.rms < 0.05)
    assert np.all(mc.standard_error / mc.rms > 1e-4)


def test_casadi_expression_matches_numpy():
    """CasADi (MX and SX) spectral RMS equals the numpy quadrature on the same grid."""
    A, B, C, _ = two_dof()
    coh = exponential_coherence(STRIP_POSITIONS, decay_coefficient=8.0, wind_speed=15.0)
    csd = separable_csd(lambda w: 1.0 / (1.0 + w**2), coh)
    omegas = adaptive_frequency_grid(A, 20.0, n_base=40, peaks_per_mode=21)
    S = np.stack([csd(w) for w in omegas])
    A_sym = ca.MX.sym("A", 4, 4)
    expr = casadi_spectral_rms(A_sym, B, C, omegas, S)
    f = ca.Function("rms", [A_sym], [expr])
    rms_ca = np.asarray(f(A)).ravel()
    rms_np = rms_from_psd(omegas, response_psd(A, B, C, omegas, S))
    ref = spectral_rms(A, B, C, S, omegas=omegas, refine=False).rms
    # same quadrature on the same grid; differences are round-off of different (real 2n vs
    # complex modal) linear algebra on a well-conditioned 4x4 system: 1e-10 relative
    np.testing.assert_allclose(rms_ca, rms_np, rtol=1e-10)
    np.testing.assert_allclose(ref, rms_np, rtol=1e-14)
    # SX variant builds the same expression
    A_sx = ca.SX.sym("A", 4, 4)
    f_sx = ca.Function("rms_sx", [A_sx], [casadi_spectral_rms(A_sx, B, C, omegas, S)])
    np.testing.assert_allclose(np.asarray(f_sx(A)).ravel(), rms_np, rtol=1e-10)


def test_casadi_complex_csd_matches_numpy():
    """A CSD with an imaginary part (non-symmetric real cross-spectra) is handled exactly."""
    A, B, C, _ = two_dof()
    omegas = np.linspace(0.0, 6.0, 61)
    rng = np.random.default_rng(3)
    G = rng.standard_normal((3, 3)) + 1j * rng.standard_normal((3, 3))
    base = G @ G.conj().T  # Hermitian positive definite with complex off-diagonals
    S = np.stack([base / (1.0 + w**2) for w in omegas])
    A_sym = ca.MX.sym("A", 4, 4)
    f = ca.Function("rms", [A_sym], [casadi_spectral_rms(A_sym, B, C, omegas, S)])
    rms_np = rms_from_psd(omegas, response_psd(A, B, C, omegas, S))
    np.testing.assert_allclose(np.asarray(f(A)).ravel(), rms_np, rtol=1e-10)


# ----------------------------------------------------------------------------------------------
# (d) derivative check
# ----------------------------------------------------------------------------------------------
def test_casadi_gradient_vs_finite_difference():
    """Derivative of the RMS w.r.t. a stiffness scale: CasADi AD vs central differences."""
    p0 = 1.0
    A0, B, C, A1 = two_dof(stiffness_scale=p0)
    coh = exponential_coherence(STRIP_POSITIONS, decay_coefficient=8.0, wind_speed=15.0)
    csd = separable_csd(lambda w: 1.0 / (1.0 + w**2), coh)
    omegas = adaptive_frequency_grid(A0, 20.0, n_base=40, peaks_per_mode=21)
    S = np.stack([csd(w) for w in omegas])
    p = ca.MX.sym("p")
    A_expr = ca.DM(A0 - p0 * A1) + p * ca.DM(A1)  # A(p) = A0 + (p - p0) A1
    rms = casadi_spectral_rms(A_expr, B, C, omegas, S)
    jac = ca.Function("drms_dp", [p], [ca.jacobian(rms, p)])
    grad = np.asarray(jac(p0)).ravel()

    def rms_np(pv):
        return rms_from_psd(omegas, response_psd(A0 + (pv - p0) * A1, B, C, omegas, S))

    h = 1e-5
    fd = (rms_np(p0 + h) - rms_np(p0 - h)) / (2 * h)
    # central differences: truncation error h^2 f'''/6 (measured ~1e-8 relative: the resonance
    # peaks move across the fixed grid points as p changes, so f''' is large), round-off
    # eps |f| / h ~ 2e-16 / 1e-5 = 2e-11 relative. 1e-6 leaves a 100x margin and still catches any
    # wrong term (a missing Im part or weight is an O(1) error).
    np.testing.assert_allclose(grad, fd, rtol=1e-6, atol=1e-12 * np.max(np.abs(fd)))
    assert np.all(np.abs(grad) > 1e-6)  # non-trivial derivative


# ----------------------------------------------------------------------------------------------
# (b) invariants and numerics
# ----------------------------------------------------------------------------------------------
def test_grid_convergence_lightly_damped():
    """Zeta = 0.5 %: refining the adaptive grid changes the RMS by < 0.5 %."""
    A, B, C, _ = two_dof(zeta=0.005)
    coh = exponential_coherence(STRIP_POSITIONS, decay_coefficient=8.0, wind_speed=25.0)
    csd = separable_csd(lambda w: 2.0 / (1.0 + (w / 2.0) ** 2) ** (5 / 6), coh)
    res = spectral_rms(A, B, C, csd, omega_max=50.0)
    assert res.status == "ok"
    assert res.convergence < 5e-3
    # independent refinement: twice the base points and the per-peak points
    finer = spectral_rms(A, B, C, csd, omega_max=50.0, n_base=400, peaks_per_mode=81)
    np.testing.assert_allclose(res.rms, finer.rms, rtol=5e-3)
    # and for white input the Lyapunov value is the reference (tail of the displacements and of
    # the velocity only matters above omega_max; 1e-3 / 3e-3 as in the 2-DOF white test)
    R = fixed_coherence()
    spec = spectral_rms(A, B, C, lambda w: R, omega_max=300.0)
    lyap = lyapunov_rms(A, B, C, white_noise_intensity(R))
    np.testing.assert_allclose(spec.rms[:2], lyap.rms[:2], rtol=1e-3)
    np.testing.assert_allclose(spec.rms[2], lyap.rms[2], rtol=3e-3)


def test_grid_contains_peaks_and_bounds():
    """The adaptive grid spans [0, omega_max] and samples every half-power band."""
    A, _, _, _ = two_dof(zeta=0.005)
    lam = np.linalg.eigvals(A)
    grid = adaptive_frequency_grid(A, 10.0)
    assert grid[0] == 0.0 and grid[-1] == 10.0
    assert np.all(np.diff(grid) > 0)
    for ev in lam[lam.imag > 0]:
        near = grid[np.abs(grid - ev.imag) < abs(ev.real)]
        assert near.size >= 5  # several points inside the half-power band of each peak


def test_unstable_system_reports_nan():
    """Unstable A: status "unstable" and NaN from all three methods, no exception."""
    A, B, C, _, _ = sdof()
    A_unstable = A.copy()
    A_unstable[1, 1] = +0.1  # negative damping: flutter-like growing oscillation
    res = spectral_rms(A_unstable, B, C, lambda w: np.array([[1.0]]), 10.0)
    assert res.status == "unstable"
    assert np.all(np.isnan(res.rms)) and np.isnan(res.convergence)
    assert res.max_real_eig > 0
    lyap = lyapunov_rms(A_unstable, B, C, 1.0)
    assert lyap.status == "unstable" and np.all(np.isnan(lyap.rms))
    omegas = np.linspace(0.1, 5.0, 50)
    mc = simulate_monte_carlo(
        A_unstable, B, C, omegas, lambda w: 1.0, lambda w: np.eye(1), 0.1, 10.0, seed=1
    )
    assert mc.status == "unstable" and np.all(np.isnan(mc.rms))


def test_rms_grows_towards_instability_without_clipping():
    """As damping -> 0 (flutter), sigma^2 = pi G0 / (2 k c) grows like 1/zeta; not clipped."""
    previous = 0.0
    for zeta in (0.05, 0.01, 0.002, 0.0005):
        A, B, C, k, c = sdof(zeta=zeta)
        res = spectral_rms(A, B, C, lambda w: np.array([[1.0]]), 200.0)
        exact = np.sqrt(np.pi / (2 * k * c))
        assert res.rms[0] == pytest.approx(exact, rel=1e-2)
        assert res.rms[0] > previous
        previous = res.rms[0]


def test_coherence_invariants():
    """Eq. (16) coherence: unit diagonal, symmetric, 1 at omega = 0, published form."""
    coh = exponential_coherence(STRIP_POSITIONS, decay_coefficient=10.0, wind_speed=30.0)
    R = coh(2.0)
    np.testing.assert_allclose(np.diag(R), 1.0)
    np.testing.assert_allclose(R, R.T)
    np.testing.assert_allclose(coh(0.0), np.ones((3, 3)))  # full coherence at omega = 0
    # Eq. (16): R_12 = exp(-c omega L / (2 pi U))
    assert R[0, 1] == pytest.approx(np.exp(-10.0 * 2.0 * 4.0 / (2 * np.pi * 30.0)), rel=1e-14)
