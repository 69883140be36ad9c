"""Tests of the buffeting analysis (model/response/buffeting.py) and its CLI
(design/cli/buffeting.py).

Conventions: spectra one-sided in omega (bridgeflap.model.spectral docstring); heave down, pitch
nose-up. Each tolerance is justified next to its assertion.
"""

import dataclasses
import json

import numpy as np
import pytest
from scipy.integrate import quad

from bridgeflap.design.cli.main import main
from bridgeflap.model.aero.basis import StructuralBasis
from bridgeflap.model.aero.gust import GustField, coherence_projection, gust_field
from bridgeflap.model.aero.wind import admittance_sq
from bridgeflap.model.aeroelastic import statespace
from bridgeflap.model.analysis import bridge_system
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.response.buffeting import CONVERGENCE_TOL, buffeting, reduced_response
from bridgeflap.model.response.simulation import lyapunov_rms
from bridgeflap.model.spectral import white_noise_intensity
from bridgeflap.model.structure.loader import load_bridge


# ----------------------------------------------------------------------------------------------
# shared cases
# ----------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def humber6(humber):
    """Humber with 6 modes (VA1, VS1, VS2, VS3, VA2, TS1): small but with heave and pitch."""
    return bridge_system(humber, 6)[1]


def _flat(level):
    def spectrum(omega, wind_speed):
        return np.full_like(np.asarray(omega, dtype=float), level)

    return spectrum


# ----------------------------------------------------------------------------------------------
# (a) inputs: spectra and admittance
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["busch-panofsky", "von-karman", "kaimal"])
def test_gust_psd_in_omega_integrates_to_sigma_w(kind):
    # int_0^inf G(omega) d omega = (I U)^2 for every spectrum (seed: sigma_w/U = 0.07; the
    # Busch-Panofsky ratio 1.6728 u*^2 is docs/humber_data.md#turbulence-spectrum-and-coherence).
    # quad on a log-substituted integrand (omega up to e^60: the -5/3 tail left out is
    # ~e^-40) is accurate to ~1e-8.
    g = GustField(spectrum=kind, turbulence_intensity=0.07, deck_height_m=30.0)
    U = 17.0

    def integrand(t):
        w = np.exp(t)
        return float(g.psd(np.array([w]), U)[0]) * w

    var, _ = quad(integrand, -25, 60, limit=400, epsabs=0, epsrel=1e-10)  # tail ~ e^(-40)
    assert var == pytest.approx((0.07 * U) ** 2, rel=1e-5)


def test_liepmann_underestimates_sears_within_published_bound():
    # docs/humber_data.md#gust-admittance: Liepmann underestimates |S|^2 by at most 14.5 % (worst
    # near k = 0.24); 0.15 gives 0.5 % room for the rounding of the quoted figure.
    k = np.geomspace(1e-3, 20, 400)
    lie, sea = admittance_sq("liepmann", k), admittance_sq("sears", k)
    assert np.all(lie <= sea * (1 + 1e-12))
    assert np.min(lie / sea) > 1 - 0.15


def test_admittance_ordering_of_rms(humber, humber6):
    # chi^2: Liepmann <= Sears <= 1 pointwise, so the variance integrals keep the order; and
    # the Liepmann/Sears variance ratio is bounded by the pointwise bound (0.85).
    res = {a: buffeting(humber6, [8.0, 20.0], admittance=a, spec=humber).rms_vertical
           for a in ("liepmann", "sears", "unit")}
    assert np.all(res["liepmann"] < res["sears"]) and np.all(res["sears"] < res["unit"])
    assert np.all((res["liepmann"] / res["sears"]) ** 2 > 0.85)


# ----------------------------------------------------------------------------------------------
# (b) coherence
# ----------------------------------------------------------------------------------------------
def test_coherence_projection_against_dense_and_limits():
    rng = np.random.default_rng(3)
    y = rng.uniform(0, 1500, 40)  # unsorted on purpose
    V = rng.standard_normal((40, 5))
    w = np.linspace(0.0, 4.0, 9)
    U, c = 12.0, 8.0
    R = np.exp(-c * w[:, None, None] * np.abs(y[:, None] - y[None, :]) / (2 * np.pi * U))
    dense = np.einsum("mr,kmn,ns->krs", V, R, V)
    fast = coherence_projection(y, V, w, U, c)
    # same sums in a different order: round-off only
    assert np.max(np.abs(fast - dense)) <= 1e-12 * np.max(np.abs(dense))
    # c = 0: full coherence, R = 1 1^T
    full = coherence_projection(y, V, w, U, 0.0)
    s = V.sum(axis=0)
    assert np.allclose(full, np.outer(s, s)[None], rtol=1e-13, atol=1e-12)
    # c -> inf: uncorrelated strips (R = I) for omega > 0; at omega = 0 coherence is 1
    none = coherence_projection(y, V, w, U, 1e12)
    assert np.allclose(none[1:], (V.T @ V)[None], rtol=1e-13, atol=1e-12)


def test_coherence_decay_reduces_response(humber, humber6):
    # The dominant VS1 load has a one-signed shape, so its generalised load variance decreases
    # with c; the maximum heave must fall monotonically from full coherence (c = 0) to nearly
    # uncorrelated strips, and the fully coherent value bounds all others.
    cs = [0.0, 6.0, 8.0, 10.0, 100.0]
    v = [buffeting(humber6, [15.0], coherence_decay=c, spec=humber).rms_vertical[0] for c in cs]
    assert all(a > b for a, b in zip(v, v[1:], strict=False))


# ----------------------------------------------------------------------------------------------
# (a) analytic single-DOF limit and exact white-noise covariance
# ----------------------------------------------------------------------------------------------
def _sdof_basis(n_strip=3):
    m, wn, zeta = 2.0, 2.0, 0.02
    return StructuralBasis(M=np.array([[m]]), C=np.array([[2 * zeta * m * wn]]),
                           K=np.array([[m * wn ** 2]]), phi_h=np.ones((n_strip, 1)),
                           phi_a=np.zeros((n_strip, 1)), strip_length=np.ones(n_strip),
                           strip_x=np.arange(n_strip) * 10.0, labels=("h",))


@pytest.mark.parametrize("decay", [0.0, 1e12])
def test_single_dof_white_noise_closed_form(decay):
    # m x'' + c x' + k x = f with f = sum_i beta w_i, w one-sided flat G0, unit admittance:
    # sigma^2 = pi G_f / (2 k c) with G_f = G0 (n beta)^2 (full coherence) or G0 n beta^2
    # (uncorrelated strips). The buffeting path (B rank-reduced, coherence recursion,
    # adaptive grid) must reproduce it; tolerance 1e-3: trapezoid error on the resonance is
    # below the 5e-3 convergence flag and the tail beyond omega_max = 200 (100 omega_n) is
    # G0 beta^2 n^2 / (3 m^2 omega_max^3) ~ 1e-7 relative.
    basis = _sdof_basis()
    beta, G0, n = 0.7, 0.3, basis.n_strip
    A = np.array([[0.0, 1.0], [-basis.K[0, 0] / 2.0, -basis.C[0, 0] / 2.0]])
    B = np.vstack([np.zeros((1, n)), np.full((1, n), beta / 2.0)])
    C = np.array([[1.0, 0.0]])
    g = GustField(spectrum=_flat(G0), admittance="unit", coherence_decay=decay, half_chord_m=1.0)
    r = reduced_response(A, B, C, basis.strip_x, 10.0, g, omega_max=200.0)
    Gf = G0 * ((n * beta) ** 2 if decay == 0 else n * beta ** 2)
    exact = np.sqrt(np.pi * Gf / (2 * basis.K[0, 0] * basis.C[0, 0]))
    assert r.status == "ok"
    assert r.rms[0] == pytest.approx(exact, rel=1e-3)


def test_full_bridge_white_noise_against_lyapunov(humber6, humber):
    # Flat one-sided spectrum G0, unit admittance, c = 0: the input CSD is G0 * 1 1^T, i.e.
    # white noise of intensity Q = pi G0 1 1^T; lyapunov_rms is exact. 2e-3: quadrature flag
    # 5e-3 is conservative (coarsened grid) and the tail beyond 60 rad/s (14x the top mode)
    # decays as omega^-3.
    U, G0 = 20.0, 0.5
    A, B, C = humber6.A(U), humber6.B_gust(U), humber6.C_out
    g = GustField(spectrum=_flat(G0), admittance="unit", coherence_decay=0.0, half_chord_m=11.0)
    r = reduced_response(A, B, C, humber6.basis.strip_x, U, g, omega_max=60.0, n_base=400)
    m = B.shape[1]
    exact = lyapunov_rms(A, B, C, white_noise_intensity(G0 * np.ones((m, m))))
    sel = exact.rms > 1e-6 * exact.rms.max()
    assert np.max(np.abs(r.rms[sel] / exact.rms[sel] - 1)) < 2e-3


# ----------------------------------------------------------------------------------------------
# (c) cross-method: grid convergence, Monte-Carlo, CasADi
# ----------------------------------------------------------------------------------------------
def test_grid_convergence_estimate_is_honest(humber, humber6):
    # A 4x denser grid (twice the cluster width) is the reference; the default grid must agree
    # within its own reported convergence estimate (which compares with a 2x coarser grid).
    speeds = [6.0, 15.0, 25.0]
    res = buffeting(humber6, speeds, spec=humber)
    ref = buffeting(humber6, speeds, spec=humber, n_base=480, peaks_per_mode=161,
                    half_widths=60.0)
    assert all(s == "ok" for s in res.status)
    assert np.all(res.convergence <= CONVERGENCE_TOL)
    err = np.abs(res.rms_vertical / ref.rms_vertical - 1)
    assert np.all(err <= np.maximum(res.convergence, 1e-6))


def test_spectral_against_monte_carlo(humber, humber6):
    # Independent time-domain check: same A, B, C with synthesised correlated turbulence (all
    # 95 strips, Cholesky of s chi^2 R). Accept 3 standard errors of the Monte-Carlo mean plus
    # 1 % for its deterministic bias (midpoint-rule synthesis at d_omega = sigma_min/4 and
    # ZOH with omega_max dt = pi/2).
    U = 15.0
    sp = buffeting(humber6, [U], spec=humber)
    mc = buffeting(humber6, [U], spec=humber, method="monte-carlo", mc_records=12, mc_seed=7)
    se = mc.standard_error_vertical[0]
    assert abs(mc.rms_vertical[0] - sp.rms_vertical[0]) <= 3 * se + 0.01 * sp.rms_vertical[0]
    assert se / mc.rms_vertical[0] < 0.05  # the check has teeth: a few-percent sampling error


@pytest.fixture(scope="module")
def casadi_case(humber, humber6):
    from bridgeflap.model.aeroelastic.symbolic import buffeting_rms_function, build_symbolic

    U = 20.0
    g = gust_field(humber)
    ns = humber6.basis.n_strip
    r = reduced_response(humber6.A(U), humber6.B_gust(U), humber6.C_out, humber6.basis.strip_x,
                         U, g)
    outputs = [int(np.argmax(r.rms[:ns])), ns + int(np.argmax(r.rms[ns:]))]
    sm = build_symbolic(humber, 6)
    fun, omegas = buffeting_rms_function(sm.A_fun, sm.B_fun, [_p(sm)], humber6.C_out,
                                         humber6.basis.strip_x, U, g, outputs)
    return U, g, outputs, fun, omegas, sm


def _numpy_rms(system, U, g, outputs, omegas):
    r = reduced_response(system.A(U), system.B_gust(U), system.C_out, system.basis.strip_x, U,
                         g, omegas=omegas)
    return r.rms[outputs]


def _p(sm, damping=1.0, density=1.0):
    """Relative parameters of the symbolic model with damping and air density scaled."""
    p = np.ones(len(sm.parameters))
    p[sm.parameters.index("damping.ratio")] = damping
    p[sm.parameters.index("aero.air_density_kg_m3")] = density
    return p


def test_casadi_matches_numpy_and_rebuilt_systems(humber, humber6, casadi_case):
    U, g, outputs, fun, omegas, sm = casadi_case
    # nominal: same grid, same trapezoid rule, different linear algebra -> round-off (1e-9)
    nominal = np.array(fun(_p(sm))).ravel()
    np.testing.assert_allclose(nominal, _numpy_rms(humber6, U, g, outputs, omegas), rtol=1e-9)
    # exact reparametrisation: rebuild the numeric system with rho x 1.1 and C x 1.3
    # (damping.ratio scales the Rayleigh damping, diagonal in the modes)
    basis = dataclasses.replace(humber6.basis, C=1.3 * humber6.basis.C)
    a = humber.aero
    rebuilt = statespace.build(basis, humber.deck.half_chord_m, 1.1 * a.air_density_kg_m3,
                               added_inertia=a.added_inertia,
                               lift_slope_buffeting=a.lift_slope_buffeting,
                               moment_slope_buffeting=a.moment_slope_buffeting)
    np.testing.assert_allclose(np.array(fun(_p(sm, 1.3, 1.1))).ravel(),
                               _numpy_rms(rebuilt, U, g, outputs, omegas), rtol=1e-9)


def test_casadi_gradient_against_finite_differences(casadi_case):
    import casadi as ca

    _, _, _, fun, _, sm = casadi_case
    p = ca.MX.sym("p", len(sm.parameters))
    jac = ca.Function("drms_dp", [p], [ca.jacobian(fun(p), p)])
    cols = [sm.parameters.index("damping.ratio"), sm.parameters.index("aero.air_density_kg_m3")]
    J = np.array(jac(_p(sm)))[:, cols]
    h = 1e-4
    fd = np.column_stack([
        (np.array(fun(_p(sm) + h * e)).ravel() - np.array(fun(_p(sm) - h * e)).ravel())
        / (2 * h) for e in np.eye(len(sm.parameters))[cols]])
    # central differences: truncation O(h^2 f''') ~ 1e-8 relative, round-off 1e-16/h ~ 1e-12
    np.testing.assert_allclose(J, fd, rtol=1e-6, atol=1e-12 * np.abs(J).max())
    # physics: more damping lowers the response, more air (C_L' rho) raises the heave
    assert J[0, 0] < 0 and J[0, 1] > 0


# ----------------------------------------------------------------------------------------------
# (b) invariants near flutter
# ----------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_rms_grows_to_flutter_then_nan(humber):
    # built-in Humber: flutter at 69.50 m/s governs (16 modes; the model updating;
    # spectral abscissa -3.4e-4 1/s at 69.4 m/s, +1.7e-3 at 70 m/s, measured)
    speeds = [40.0, 50.0, 60.0, 64.0, 66.0, 68.0, 69.0, 69.4, 70.0, 75.0]
    res = buffeting(humber, speeds, n_modes=16)  # the 16-mode numbers above (default: 30)
    stable = np.array([s != "unstable" for s in res.status])
    assert stable[:8].all() and not stable[8:].any()
    # status follows the spectral abscissa exactly
    assert np.array_equal(~stable, res.spectral_abscissa >= 0)
    for arr in (res.rms_vertical, res.rms_torsion):
        assert np.all(np.diff(arr[stable]) > 0)  # grows monotonically; never clipped
        assert np.all(np.isnan(arr[~stable]))
    assert res.rms_torsion[7] > 5 * res.rms_torsion[3]  # unbounded growth is visible
    with pytest.raises(BridgeflapInputError, match="speeds"):
        buffeting(humber, [20.0, 72.0], n_modes=16, allow_unstable=False)


def test_unstable_reported_not_clipped_small(humber, humber6):
    # fast version with 6 modes: find a stable and an unstable speed from the abscissa
    res = buffeting(humber6, [30.0, 200.0], spec=humber)
    assert res.status[0] in ("ok", "unconverged") and res.status[1] == "unstable"
    assert np.isnan(res.rms_vertical[1]) and np.isfinite(res.rms_vertical[0])
    with pytest.raises(BridgeflapInputError, match="flutter"):
        buffeting(humber6, [30.0, 200.0], spec=humber, allow_unstable=False)


def test_bad_inputs(humber6, humber):
    with pytest.raises(BridgeflapInputError, match="turbulence_intensity"):
        buffeting(humber6, [10.0], spec=humber, turbulence_intensity=0.0)
    with pytest.raises(BridgeflapInputError, match="spectrum"):
        buffeting(humber6, [10.0], spec=humber, spectrum="davenport")
    with pytest.raises(BridgeflapInputError, match="speeds"):
        buffeting(humber6, [0.0, 10.0], spec=humber)


def test_zero_gain_controller_equals_open_loop(humber):
    # K(s) = 0: the flaps stay at zero, so the closed loop has the open-loop response; the
    # extra (uncontrollable, unobservable) compensator states change nothing but round-off
    # and the grid (peaks of the extra states), hence the 2 x convergence-flag tolerance.
    from bridgeflap.model.aeroelastic.control import Compensator, Controller

    ctrl = Controller(Compensator(0.0, 0.0, 0.0, 0.1, 0.5), (0.0, 100.0), 3.0)
    cl = buffeting(humber, [12.0], controller=ctrl, n_modes=6)
    ol = buffeting(humber, [12.0], n_modes=6)
    assert cl.inputs["controller"] is True
    assert cl.rms_vertical[0] == pytest.approx(ol.rms_vertical[0], rel=2 * CONVERGENCE_TOL)


# ----------------------------------------------------------------------------------------------
# CLI
# ----------------------------------------------------------------------------------------------
def test_cli_json_contract(capsys):
    code = main(["buffeting", "--json", "--speeds", "10:12:2", "--modes", "6",
                 "--admittance", "sears", "--coherence-decay", "6"])
    out = capsys.readouterr().out
    assert code == 0
    data = json.loads(out)
    for key in ("speeds_m_s", "rms_vertical_m", "rms_torsion_rad", "rms_vertical_over_width",
                "status", "convergence", "grid_points", "inputs"):
        assert key in data
    assert data["speeds_m_s"] == [10.0, 12.0]
    assert data["inputs"]["admittance"] == "sears" and data["inputs"]["coherence_decay"] == 6.0
    assert data["status"] == ["ok", "ok"]
    width = 2 * load_bridge("humber").deck.half_chord_m  # the normalising 2b
    np.testing.assert_allclose(np.array(data["rms_vertical_over_width"]) * width,
                               data["rms_vertical_m"], rtol=1e-12)


def test_cli_unstable_null(capsys):
    code = main(["buffeting", "--json", "--speeds", "30,200", "--modes", "6",
                 "--allow-unstable"])
    data = json.loads(capsys.readouterr().out)
    assert code == 0 and data["status"][1] == "unstable" and data["rms_vertical_m"][1] is None


@pytest.mark.parametrize("argv, field", [
    (["--speeds", "30,200", "--modes", "6"], "speeds"),
    (["--spectrum", "davenport"], "arguments"),
    (["--turbulence-intensity", "0"], "turbulence-intensity"),
    (["--turbulence-intensity", "-0.1"], "turbulence-intensity"),
    (["--speeds", "0:5:1"], "speeds"),
])
def test_cli_bad_input_exit_2(capsys, argv, field):
    code = main(["buffeting", "--json", *argv])
    cap = capsys.readouterr()
    assert code == 2
    assert cap.out == ""
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"bridgeflap: error: {field}")
