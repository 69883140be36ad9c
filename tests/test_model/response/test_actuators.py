"""Flap actuator limits and the saturated closed loop in turbulence.

Every test here can fail: the unsaturated simulation must be the project's linear closed loop
(eigenvalues, and the spectral buffeting RMS within the Monte-Carlo error), the limits must
hold, a seed must fix the records, and the synthesised turbulence must have the buffeting
spectrum and coherence. Small models (6 modes) and short records keep them quick.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from bridgeflap.model.aeroelastic.actuator_limits import (
    ACTUATOR_DEFAULTS,
    ActuatorLimits,
    check_actuator_value,
)
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.errors import BridgeflapInputError

MODES = 6
#: the default design (README, `bridgeflap optimise`): K(s) and its 10 flap pairs
K = Compensator(b2=-1.0852, b1=0.2781, b0=-3.8118, a2=0.3097, a1=0.0242)
POSITIONS = (-338.4, -282.0, -225.6, -169.2, -112.8, 112.8, 169.2, 225.6, 282.0, 338.4)
CONTROLLER = Controller(compensator=K, flap_strip_positions_m=POSITIONS, flap_width_m=56.4,
                        flap_chord_m=3.0)
BIG = ActuatorLimits(90.0, 1e4)      # limits no record reaches at 20 m/s: the linear loop


@pytest.fixture(scope="module")
def setup():
    from bridgeflap.model.aero.gust import gust_field
    from bridgeflap.model.aeroelastic.flaps import closed_loop_model
    from bridgeflap.model.response.actuator_sim import SaturatedLoop
    from bridgeflap.model.structure.loader import load_bridge

    spec = load_bridge("humber:box")
    c = CONTROLLER
    model = closed_loop_model(spec, c.flap_strip_positions_m, c.flap_width_m, MODES, c.chord_m,
                              c.leading_edge, c.trailing_edge)
    return spec, model, SaturatedLoop(model, c.compensator), gust_field(spec)


# ------------------------------------------------------------------ limits (card and checks)
def test_card_keys_default_and_refusals():
    from bridgeflap.design.control.settings import load_settings

    s = load_settings("runs/humber_flaps.toml")
    assert s.flap_angle_limit_deg == ACTUATOR_DEFAULTS["flap_angle_limit_deg"] == 20.0
    assert s.flap_rate_limit_deg_s == ACTUATOR_DEFAULTS["flap_rate_limit_deg_s"] == 40.0
    for name, bad in (("flap_angle_limit_deg", 0.0), ("flap_angle_limit_deg", 120.0),
                      ("flap_rate_limit_deg_s", -40.0), ("flap_rate_limit_deg_s", "fast"),
                      ("flap_rate_limit_deg_s", float("inf")), ("flap_angle_limit_deg", True)):
        with pytest.raises(BridgeflapInputError) as exc:
            load_settings(None, **{name: bad})
        assert exc.value.field == name
    with pytest.raises(BridgeflapInputError) as exc:
        ActuatorLimits(bandwidth_rad_s=0.0)
    assert exc.value.field == "actuator_bandwidth_rad_s"
    assert check_actuator_value("flap_angle_limit_deg", 15) == 15.0


def test_design_json_leaves_default_limits_out():
    """The design's JSON settings are unchanged at the default limits (goldens), and name
    them when a card changes them."""
    from dataclasses import asdict

    from bridgeflap.design.control.results.result import ACTUATOR_FIELDS
    from bridgeflap.design.control.settings import load_settings

    s = load_settings(None, flap_rate_limit_deg_s=30.0)
    kept = {k for k, v in asdict(s).items()
            if k not in ACTUATOR_FIELDS or v != ACTUATOR_DEFAULTS[k]}
    assert "flap_rate_limit_deg_s" in kept and "flap_angle_limit_deg" not in kept


# ------------------------------------------------------------------ the unsaturated loop
@pytest.mark.parametrize("speed", [0.0, 20.0, 60.0])
def test_unsaturated_loop_is_the_linear_closed_loop(setup, speed):
    """Eigenvalues: those of bridgeflap.model.aeroelastic.flaps.closed_loop_system, plus -omega_a
    once per flap."""
    _, model, loop, _ = setup
    lam_cl = np.linalg.eigvals(model.system(K).A(speed))
    lam = np.linalg.eigvals(loop.linear_matrix(speed, 10.0))
    assert lam.size == lam_cl.size + loop.nF
    assert max(np.min(np.abs(lam - z)) for z in lam_cl) < 1e-8
    assert np.sum(np.abs(lam + 10.0) < 1e-8) >= loop.nF


def test_large_limits_match_the_spectral_closed_loop_buffeting(setup):
    """Very large limits: the simulated RMS is the spectral closed-loop buffeting RMS.

    Tolerance from the record length: at 20 m/s the per-record RMS of 300 s records scatters
    by 8 % (heave), 11 % (twist) and 6 % (flap angle) (measured over 32 seeds), so the mean
    of 16 records has a standard error of 2.0 / 2.6 / 1.5 %; the start from rest (300 s
    discarded, the slowest root -0.006 1/s) adds up to ~3 % (measured with 1500 s: heave
    0.978, twist 1.018). 10 % is > 3 standard errors plus that. Compared at the main-span strip
    of the spectral maximum (the maximum of noisy strip estimates is biased upwards).
    """
    from bridgeflap.model.response.actuator_sim import simulate_records
    from bridgeflap.model.response.buffeting import reduced_response

    spec, model, loop, gust = setup
    U = 20.0
    from bridgeflap.model.response.buffeting import buffeting

    ref = buffeting(spec, [U], controller=CONTROLLER, n_modes=MODES)
    main, ns = ref.main_span, ref.main_span.size
    jh = int(np.argmax(np.where(main, ref.rms_heave[0], -1.0)))
    jt = int(np.argmax(np.where(main, ref.rms_pitch[0], -1.0)))
    cl = model.system(K)
    flap_ref = reduced_response(cl.A(U), cl.B_gust(U), cl.extras["flap_angle_map"],
                                loop.strip_x, U, gust).rms
    recs = simulate_records(loop, U, gust, BIG, 300.0, list(range(16)))
    assert all(r.diverged_at_s is None for r in recs)
    assert not any(r.angle_saturated.any() or r.rate_saturated.any() for r in recs)
    ms = np.array([r.strip_rms ** 2 for r in recs])
    flap = np.sqrt(np.mean([np.mean(r.beta ** 2, axis=1) for r in recs], axis=0))
    heave = np.sqrt(ms[:, jh].mean()) / ref.rms_heave[0, jh]
    twist = np.sqrt(ms[:, ns + jt].mean()) / ref.rms_pitch[0, jt]
    assert heave == pytest.approx(1.0, abs=0.10)
    assert twist == pytest.approx(1.0, abs=0.10)
    np.testing.assert_allclose(flap, flap_ref, rtol=0.10)
    # the stated standard error holds for these records (else the tolerance means nothing)
    se = ms[:, [jh, ns + jt]].std(axis=0, ddof=1) / np.sqrt(16) / (2 * ms[:, [jh, ns + jt]]
                                                                   .mean(axis=0))
    assert np.all(se < 0.04), se


# ------------------------------------------------------------------ saturation
def test_tiny_angle_limit_holds(setup):
    from bridgeflap.model.response.actuator_sim import simulate

    _, _, loop, gust = setup
    lim = ActuatorLimits(angle_deg=0.05, rate_deg_s=40.0)
    rec = simulate(loop, 20.0, gust, lim, 60.0, seed=3, transient_s=20.0)
    amax = np.deg2rad(0.05)
    assert np.max(np.abs(rec.beta)) <= amax * (1 + 1e-12)
    assert rec.angle_saturated.mean() > 0.05
    assert np.all(np.isfinite(rec.strip_rms))


def test_tiny_rate_limit_holds(setup):
    from bridgeflap.model.response.actuator_sim import simulate

    _, _, loop, gust = setup
    lim = ActuatorLimits(angle_deg=20.0, rate_deg_s=0.1)
    rec = simulate(loop, 20.0, gust, lim, 60.0, seed=3, transient_s=20.0)
    rmax = np.deg2rad(0.1)
    assert np.max(np.abs(rec.rate)) <= rmax * (1 + 1e-12)
    assert rec.rate_saturated.mean() > 0.05
    # the angle is the integral of the limited rate: no step exceeds rmax dt
    assert np.max(np.abs(np.diff(rec.beta, axis=1))) <= rmax * rec.dt * (1 + 1e-6)


def test_same_seed_same_record(setup):
    from bridgeflap.model.response.actuator_sim import simulate

    _, _, loop, gust = setup
    lim = ActuatorLimits(angle_deg=0.2, rate_deg_s=1.0)
    a = simulate(loop, 25.0, gust, lim, 40.0, seed=7, transient_s=10.0)
    b = simulate(loop, 25.0, gust, lim, 40.0, seed=7, transient_s=10.0)
    c = simulate(loop, 25.0, gust, lim, 40.0, seed=8, transient_s=10.0)
    np.testing.assert_array_equal(a.beta, b.beta)
    np.testing.assert_array_equal(a.strip_rms, b.strip_rms)
    assert not np.allclose(a.beta, c.beta)


# ------------------------------------------------------------------ the turbulence
def test_turbulence_has_the_buffeting_spectrum_and_coherence():
    """Welch PSD of the synthesised w against the Busch-Panofsky target; coherence at 50 m.

    2^15 samples at 0.1 s (3277 s): Welch with 1024-sample segments averages ~60 half-
    overlapping segments, a relative standard error of ~1/sqrt(30) = 18 % per bin; averaged
    over bands of 8 bins ~7 %, so 25 % is > 3 standard errors.
    """
    from scipy.signal import welch

    from bridgeflap.model.aero.gust import gust_field
    from bridgeflap.model.aero.turbulence import span_turbulence
    from bridgeflap.model.structure.loader import load_bridge

    gust = gust_field(load_bridge("humber:box"))
    U, h, n = 20.0, 0.1, 2 ** 15
    y = np.array([0.0, 50.0, 1000.0])
    w = span_turbulence(y, lambda om: gust.psd(om, U), U, gust.coherence_decay, n, h, 25.0,
                        seed=5)
    f, S = welch(w, fs=1.0 / h, nperseg=1024, axis=-1)
    G_target = gust.psd(2 * np.pi * f, U)                    # one-sided in omega
    G_sample = S / (2 * np.pi)                               # one-sided in Hz -> omega
    sel = (f > 0.01) & (2 * np.pi * f < 20.0)
    bands = np.array_split(np.flatnonzero(sel), 24)
    for j in range(3):
        ratio = [G_sample[j, b].mean() / G_target[b].mean() for b in bands]
        assert np.allclose(ratio, 1.0, atol=0.25), (j, np.round(ratio, 2))
    om = np.linspace(1e-4, 25.0, 20001)
    G = gust.psd(om, U)
    var = np.trapezoid(G, om)
    np.testing.assert_allclose(w.var(axis=1), var, rtol=0.1)
    rho = np.trapezoid(G * np.exp(-gust.coherence_decay * om * 50.0 / (2 * np.pi * U)), om)
    r_sample = np.mean(w[0] * w[1]) / np.sqrt(w[0].var() * w[1].var())
    assert r_sample == pytest.approx(rho / var, abs=0.05)
    assert abs(np.mean(w[0] * w[2])) / w[0].var() < 0.05     # 1 km apart: uncorrelated


def test_ar1_factor_is_the_cholesky_factor():
    from bridgeflap.model.aero.turbulence import ar1_coherent_phasors

    y = np.array([30.0, 0.0, 5.0, 12.0, 12.0])
    omega, U, c = 0.7, 15.0, 8.0
    R = np.exp(-c * omega * np.abs(y[:, None] - y[None, :]) / (2 * np.pi * U))
    z = ar1_coherent_phasors(y, np.full(4000, omega), U, c, np.random.default_rng(1))
    R_sample = (z.conj().T @ z).real / z.shape[0]
    np.testing.assert_allclose(R_sample, R, atol=0.06)


# ------------------------------------------------------------------ the command
def test_cli_actuators_json_and_table(tmp_path, capsys):
    from bridgeflap.design.cli.main import main
    from bridgeflap.model.aeroelastic.controller_file import save_controller

    path = save_controller(CONTROLLER, tmp_path / "ctrl.toml")
    out = tmp_path / "table.csv"
    rc = main(["actuators", "--controller", str(path), "--bridge", "humber:box", "--modes",
               str(MODES), "--duration-s", "30", "--records", "2", "--speeds", "10,20",
               "--near-critical", "0", "--flap-rate-limit-deg-s", "2", "--out", str(out),
               "--json"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    s = json.loads(cap.out)  # strict JSON (NaN would be refused by emit)
    assert s["status"] == "ok" and s["flap_rate_limit_deg_s"] == 2.0
    assert s["flap_angle_limit_deg"] == 20.0 and "engineering estimate" in s["limits_source"]
    rows = s["speeds"]
    assert [r["speed_m_s"] for r in rows] == [10.0, 20.0]
    for r in rows:
        assert r["peak_flap_rate_deg_s"] <= 2.0 * (1 + 1e-9)
        assert 0.0 <= r["rate_saturated_fraction"] <= 1.0
        assert r["rms_heave_m"] > 0 and r["linear_rms_heave_m"] > 0
    lines = out.read_text().splitlines()
    assert lines[0].startswith("speed_m_s,status,rms_flap_angle_deg") and len(lines) == 3
