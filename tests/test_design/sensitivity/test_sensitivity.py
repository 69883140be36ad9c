"""Sensitivities of the flutter and divergence speeds (design/sensitivity/local.py).

Coarse mesh (50 m elements) and 10 modes keep each re-solve below 0.3 s. Kinds of test
(STYLE.md): (a) analytic values, (b) invariants, (d) derivatives against finite differences.
"""

import json

import numpy as np
import pytest

from bridgeflap.design.cli.main import main
from bridgeflap.design.sensitivity.local import (
    local_sensitivity,
    ritz_system,
    speed_derivative_ift,
)
from bridgeflap.design.studies.screening import global_sensitivity
from bridgeflap.model.analysis import bridge_system, modal_model
from bridgeflap.model.stability.sweeps import oscillation_tolerance
from bridgeflap.model.structure.loader import load_bridge

COARSE = {"mesh.element_length_m": 50.0}
N_MODES = 10
PARAMS = ("deck.gj_nm2", "cable.main_sag_m", "deck.half_chord_m", "deck.mass_kg_per_m",
          "aero.air_density_kg_m3", "deck.mass_inertia_kgm2_per_m", "damping.ratio")


@pytest.fixture(scope="module")
def local():
    spec = load_bridge("humber").replace(**COARSE)
    return local_sensitivity(spec, PARAMS, speeds="0:120:1", n_modes=N_MODES)


def _row(res, name):
    return next(r for r in res.rows if r["parameter"] == name)


def test_nominal_crossings_converged(local):
    assert local.flutter_status == "converged" and local.divergence_status == "converged"
    # the IFT is evaluated at the refined crossing: Re(lambda) there is zero to the Brent
    # tolerance (1e-7 m/s) times d Re(lambda)/dU (~1e-2 1/s per m/s)
    for r in local.rows:
        assert abs(r["flutter_re_lambda_at_crossing"]) < 1e-7
        assert abs(r["divergence_re_lambda_at_crossing"]) < 1e-7


@pytest.mark.parametrize("name", ["deck.gj_nm2", "cable.main_sag_m", "deck.half_chord_m",
                                  "deck.mass_kg_per_m"])
@pytest.mark.parametrize("q", ["flutter", "divergence"])
def test_ift_matches_finite_differences_of_the_full_pipeline(local, name, q):
    r = _row(local, name)
    ift, fd = r[f"d_{q}_speed"], r[f"d_{q}_speed_fd"]
    # full FD: central step 1e-3 p, truncation O(h^2) ~ 1e-6 relative; Brent tolerance
    # 1e-7 m/s over a speed change 2h p dU/dp >= 0.01 m/s gives <= 1e-5. The IFT uses a
    # central difference of A at 1e-4 p (error ~1e-8) and the first-order modal-subspace
    # rotation (exact to first order). Observed agreement ~3e-5; 1e-3 leaves margin.
    assert ift == pytest.approx(fd, rel=1e-3)


@pytest.mark.parametrize("name", ["deck.gj_nm2", "cable.main_sag_m", "deck.half_chord_m",
                                  "deck.mass_kg_per_m"])
def test_fixed_basis_ift_matches_ritz_finite_differences(local, name):
    r = _row(local, name)
    # same model (nominal Ritz basis) on both sides: only the difference-quotient errors
    # (~1e-5, see above) separate them
    assert r["d_flutter_speed_fixed_basis"] == pytest.approx(r["d_flutter_speed_ritz_fd"],
                                                             rel=1e-3)
    assert r["d_divergence_speed_fixed_basis"] == pytest.approx(
        r["d_divergence_speed_ritz_fd"], rel=1e-3)


def test_parameters_that_do_not_enter_the_fixed_basis_give_identical_variants(local):
    # b and rho enter only the aerodynamic matrices: the mode shapes do not move, so the
    # fixed-basis and moving-basis derivatives coincide (to the difference quotient, 1e-9)
    for name in ("deck.half_chord_m", "aero.air_density_kg_m3"):
        r = _row(local, name)
        assert r["d_flutter_speed"] == pytest.approx(r["d_flutter_speed_fixed_basis"], rel=1e-6)


def test_divergence_scales_exactly_with_air_density_and_ignores_inertia_and_damping(local):
    # static divergence: det(K - U^2 rho Q~) = 0, so U_D ~ rho^(-1/2) exactly: relative
    # derivative -1/2 (central difference of A at 1e-4: error ~1e-8)
    r = _row(local, "aero.air_density_kg_m3")
    assert r["relative_d_divergence_speed"] == pytest.approx(-0.5, abs=1e-6)
    # inertia and damping do not enter the static problem det(K - U^2 Q) = 0 itself; in the
    # truncated modal basis the inertia moves the mode shapes the static problem is projected
    # on, a truncation effect measured at 1.5e-6 (10 modes, 50 m mesh); 1e-5 still fails on
    # any real dependence (GJ's relative derivative is ~0.3)
    for name in ("deck.mass_inertia_kgm2_per_m", "damping.ratio"):
        assert abs(_row(local, name)["relative_d_divergence_speed"]) < 1e-5


def test_relative_derivative_is_unit_free():
    """Expressing GJ in GN m^2 (p' = p / 1e9) leaves (p/U) dU/dp unchanged."""
    spec = load_bridge("humber").replace(**COARSE)
    nominal = modal_model(spec)
    _, system = bridge_system(spec, N_MODES, modal=nominal)
    from bridgeflap.design.sensitivity.local import critical_speeds

    U = critical_speeds(system, np.arange(0.0, 121.0, 1.0))["flutter_speed_m_s"]
    p0 = spec.deck.gj_nm2
    tol = oscillation_tolerance(system)
    dA_dU = system.A1 + 2 * U * system.A2
    out = {}
    for scale in (1.0, 1e-9, 1e3):  # N m^2, GN m^2, mN m^2
        def A_of(value, scale=scale):
            return ritz_system(spec.replace(**{"deck.gj_nm2": value / scale}), nominal,
                               N_MODES).A(U)

        d, _ = speed_derivative_ift(A_of, dA_dU, system.A(U), p0 * scale, "flutter", tol)
        out[scale] = (d, p0 * scale / U * d)
    # absolute derivative transforms as 1/unit, relative one is invariant; the relative step
    # makes the difference quotient identical up to floating-point rounding (1e-9)
    for scale in (1e-9, 1e3):
        assert out[scale][0] * scale == pytest.approx(out[1.0][0], rel=1e-6)
        assert out[scale][1] == pytest.approx(out[1.0][1], rel=1e-6)


def test_morris_through_the_batch_runner(tmp_path):
    ranges = {"deck.gj_nm2": (3.0e11, 4.5e11), "aero.coherence_decay": (6.0, 10.0)}
    res = global_sensitivity("humber", ranges, method="morris", n=2, out_dir=tmp_path / "gsa",
                             scheduler="serial", progress=False,
                             case_options={"speeds": "0:120:2", "modes": 8})
    assert (res.cases, res.failed) == (6, 0)  # n (k + 1) cases
    f = res.indices["flutter_speed_m_s"]
    assert f["status"] == "ok"
    # coherence decay enters only buffeting: no elementary effect on flutter, exactly
    assert f["aero.coherence_decay"]["mu_star"] == 0.0
    assert f["deck.gj_nm2"]["mu_star"] > 0.1  # m/s over a 50 % GJ range
    b = res.band["divergence_speed_m_s"]
    assert b["min"] <= b["p05"] <= b["p50"] <= b["p95"] <= b["max"]
    assert json.loads((tmp_path / "gsa" / "batch.json").read_text())["succeeded"] == 6
    # the Morris indices are written next to table.csv, with units in the column names
    import pandas as pd

    table = pd.read_csv(tmp_path / "gsa" / "indices.csv")
    row = table[(table.output == "flutter_speed_m_s") & (table.parameter == "deck.gj_nm2")]
    assert row.mu_star_m_s.iloc[0] == f["deck.gj_nm2"]["mu_star"]
    assert {"sigma_m_s", "mu_star_m_s_conf"} <= set(table.columns)
    json.loads(json.dumps(res.to_dict(), allow_nan=False))


def test_cli_contract_and_bad_parameter(tmp_path, capsys):
    rc = main(["sensitivity", "--parameters", "deck.half_chord_m", "--modes", "6",
               "--speeds", "0:120:2", "--json", "--plot", str(tmp_path / "t.png")])
    assert rc == 0
    out = json.loads(capsys.readouterr().out, parse_constant=pytest.fail)  # strict JSON
    d = out["derivatives"]["deck.half_chord_m"]
    assert set(d) >= {"value_si", "d_flutter_speed_m_s_per_unit", "d_flutter_speed_m_s_per_unit_fd"}
    assert d["d_flutter_speed_m_s_per_unit"] == pytest.approx(d["d_flutter_speed_m_s_per_unit_fd"],
                                                              rel=1e-3)
    assert out["flutter_speed_m_s"] > 0
    # the kink check: one-sided slopes over 5 % and the flag, in strict JSON
    assert isinstance(d["kink"], bool) and isinstance(out["kinked_parameters"], list)
    assert {"d_flutter_speed_m_s_per_unit_minus", "d_flutter_speed_m_s_per_unit_plus",
            "flutter_kink", "flutter_kink_reason"} <= set(d)
    assert out["settings"]["rel_step_kink"] == 0.05
    assert (tmp_path / "t.png").stat().st_size > 0
    # the result object: unit-named derivative keys, strict JSON, a table with units
    from bridgeflap.design.sensitivity.local import local_sensitivity
    from bridgeflap.model.structure.loader import load_bridge

    res = local_sensitivity(load_bridge("humber"), ["deck.half_chord_m"], "0:120:2", 6)
    dd = json.loads(json.dumps(res.to_dict(), allow_nan=False))["derivatives"]
    key = "d_flutter_speed_m_s_per_unit"
    assert dd["deck.half_chord_m"][key] == d[key]
    assert "d_flutter_speed_m_s_per_unit_fd" in res.to_dataframe().columns
    assert "dUF/dp IFT" in res.table()
    rc = main(["sensitivity", "--parameters", "deck.nonsense", "--plot", str(tmp_path / "u.png")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "deck.nonsense" in err
    assert not (tmp_path / "u.png").exists()
