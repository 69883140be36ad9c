"""IABSE TG3.1 section benchmarks 1.1a and 1.1c (bridgeflap.model.cases.section_cases,
model/bridges/iabse).

Tolerances:

* 1.1a, its own convention (flat plate without the apparent-inertia moment): 0.2 %. The
  exact p-k on the closed-form derivatives is 77.480 m/s (+0.04 %); the 4-lag Roger fit's
  error per derivative is at most 2.1e-3 (reported) and moves the speed by 4e-5; the reference
  is quoted to 4 figures (77.45, +-0.006 %). 0.2 % is the required bound and leaves 0.15 %.
* 1.1a with the apparent-inertia moment kept: the exact answer is 0.3 % below the reference
  (77.24 m/s): checked as -0.27 % +- 0.05 %.
* 1.1c: 1 %. The tables are 7 measured points per derivative, linearly interpolated; the
  2-lag Roger fit's error on the flutter-governing derivatives (H1-H4, A1-A4) is 3-12 % of
  their load terms (their kinks are not rational), which moves the RFA speed 0.36 % from the
  exact p-k on the same tables; the exact p-k is 0.12 % from the reference, which is quoted to
  3 figures (72.3, +-0.07 %). Sum 0.55 % < 1 %.
* In-wind torsional-branch points of wawi's tests (f to 2 %, from their 0.3-0.5 % rounding
  and the p-k flavour; the damping ratios are not compared: wawi's own tolerance on them is
  10-25 %).
"""

from __future__ import annotations

import numpy as np
import pytest

from bridgeflap.model.cases.section_cases import (
    SECTION_CASES,
    load_section_case,
    section_case_flutter,
    section_system,
)
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.stability import sweeps as stability


@pytest.fixture(scope="module")
def results():
    return {("iabse-1.1a", None): section_case_flutter(load_section_case("iabse-1.1a")),
            ("iabse-1.1a", True): section_case_flutter(load_section_case("iabse-1.1a", True)),
            ("iabse-1.1c", None): section_case_flutter(load_section_case("iabse-1.1c"))}


def test_cases_load_by_name():
    assert SECTION_CASES == ("iabse-1.1a", "iabse-1.1c")
    a = load_section_case("iabse-1.1a")
    assert a.basis.n == 2 and a.phi_p is None and a.reference_speed_m_s == 77.45
    f = np.sqrt(np.diag(a.basis.K) / np.diag(a.basis.M)) / (2 * np.pi)
    assert f == pytest.approx([0.100, 0.278], abs=5e-4)  # wawi's 0.100 / 0.278 Hz
    c = load_section_case("iabse-1.1c")
    assert c.basis.n == 3 and c.phi_p is not None and c.derivatives.lateral
    with pytest.raises(BridgeflapInputError, match="bridge"):
        load_section_case("iabse-9z")
    with pytest.raises(BridgeflapInputError, match="added_inertia"):
        load_section_case("iabse-1.1c", True)


def test_iabse_11a_own_convention(results):
    r = results[("iabse-1.1a", None)]
    assert r["rfa_flutter_status"] == r["pk_flutter_status"] == stability.CONVERGED
    assert abs(r["pk_relative_to_reference"]) < 2e-3
    assert abs(r["rfa_relative_to_reference"]) < 2e-3
    assert r["pk_flutter_frequency_hz"] == pytest.approx(0.194, abs=1e-3)  # 1.216 rad/s
    assert r["rfa"]["fit_max_relative_error"] < 5e-3


def test_iabse_11a_apparent_inertia_kept(results):
    r = results[("iabse-1.1a", True)]
    assert r["pk_relative_to_reference"] == pytest.approx(-2.7e-3, abs=5e-4)
    own = results[("iabse-1.1a", None)]
    assert r["pk_flutter_speed_m_s"] < own["pk_flutter_speed_m_s"]


def test_iabse_11c(results):
    r = results[("iabse-1.1c", None)]
    assert r["rfa_flutter_status"] == r["pk_flutter_status"] == stability.CONVERGED
    assert abs(r["pk_relative_to_reference"]) < 1e-2
    assert abs(r["rfa_relative_to_reference"]) < 1e-2
    lags = r["rfa"]["lag_poles_pbar"]
    assert all(g > 0 for g in lags)
    assert set(r["rfa"]["fit_relative_error"]) == {f"{f}{i}" for f in "HAP" for i in range(1, 7)}


@pytest.mark.parametrize("name, speed, f_hz", [
    ("iabse-1.1a", 45.0, 0.2561), ("iabse-1.1a", 60.0, 0.2340), ("iabse-1.1a", 75.0, 0.1994),
    ("iabse-1.1c", 45.0, 0.2488), ("iabse-1.1c", 60.0, 0.2275), ("iabse-1.1c", 72.0, 0.2049),
])
def test_in_wind_torsion_branch(name, speed, f_hz):
    system, _ = section_system(name)
    pk = stability.pk_sweep(system, np.linspace(0.0, speed, 31))
    j = list(pk.branch_labels).index("pitch")
    f = abs(pk.branches[j, -1].imag) / (2 * np.pi)
    assert f == pytest.approx(f_hz, rel=2e-2)


def test_flutter_summary_has_the_humber_keys(coarse_humber):
    """The hook for ``flutter --bridge iabse-1.1a``: the keys of the Humber flutter summary."""
    from bridgeflap.design.cli.derivatives import section_case_result
    from bridgeflap.model import analysis

    humber = analysis.flutter(coarse_humber, np.linspace(0.0, 80.0, 41), n_modes=4).summary()
    res = section_case_result("iabse-1.1a", np.linspace(0.0, 120.0, 61))
    s = res.summary()
    assert set(s) - {"section_case"} == set(humber)
    assert s["flutter_status"] == stability.CONVERGED
    assert s["flutter_speed_m_s"] == pytest.approx(77.45, rel=2e-3)  # as test_iabse_11a_own...
    assert s["section_case"]["pk_flutter_status"] == stability.CONVERGED


def _write_case(tmp_path, table_rows, **over):
    import json

    case = {"dofs": ["heave", "pitch"], "mass_kg_per_m": [22740.0, 2.47e6],
            "stiffness_n_per_m2": [8977.39216323088, 7536093.564553846], "damping_ratio": 0.003,
            "chord_m": 31.0, "air_density_kg_m3": 1.22,
            "derivatives": {"kind": "scanlan-table", "file": "ads.csv", "argument": "vred_hz"}}
    case.update(over)
    (tmp_path / "ads.csv").write_text("\n".join(table_rows) + "\n")
    path = tmp_path / "deck.json"
    path.write_text(json.dumps(case))
    return str(path)


def test_user_section_file_with_a_scanlan_table(tmp_path):
    """A user's table: the flat plate tabulated at 40 reduced velocities reproduces 1.1a.

    Linear interpolation in v between points 2.5 % apart and the 2-lag default fit of a table
    leave the p-k within 0.1 % and the RFA within 0.3 % of the closed-form 77.48 m/s."""
    from bridgeflap.model.aero.derivatives import convert_argument, flat_plate

    vr = np.geomspace(2.0, 60.0, 40)
    vals = flat_plate(31.0).values(convert_argument(vr, "vred_hz", "K"))
    names = ["H1", "H2", "H3", "H4", "A1", "A2", "A3", "A4"]
    rows = ["# flat plate", "vred_hz," + ",".join(names)]
    rows += [",".join([repr(float(vr[i]))] + [repr(float(vals[n][i])) for n in names])
             for i in range(vr.size)]
    r = section_case_flutter(load_section_case(_write_case(tmp_path, rows)))
    assert r["pk_flutter_speed_m_s"] == pytest.approx(77.48, rel=1e-3)
    assert r["rfa_flutter_speed_m_s"] == pytest.approx(77.48, rel=3e-3)
    assert np.isnan(r["reference_flutter_speed_m_s"])


def test_user_section_file_bad_input(tmp_path):
    rows = ["vred_hz,H1,A2", "5,1,2", "10,2,", "15,3,4"]
    with pytest.raises(BridgeflapInputError, match=r"derivatives\.A2.*NaN"):
        load_section_case(_write_case(tmp_path, rows))
    with pytest.raises(BridgeflapInputError, match="mass_kg_per_m"):
        load_section_case(_write_case(tmp_path, ["vred_hz,H1", "5,1", "10,2"],
                                      mass_kg_per_m=[1.0]))
    with pytest.raises(BridgeflapInputError, match="derivatives.argument"):
        load_section_case(_write_case(tmp_path, ["vred_hz,H1", "5,1", "10,2"],
                                      derivatives={"kind": "scanlan-table", "file": "ads.csv",
                                                   "argument": "rpm"}))
    with pytest.raises(BridgeflapInputError, match="bridge"):
        load_section_case(str(tmp_path / "missing.json"))


def test_two_dof_section_with_lateral_derivatives(tmp_path):
    """A 2-DOF section on the 1.1c tables ignores the lateral derivatives: the lateral mode of
    1.1c barely couples (measured 72.25 against 72.21 m/s, 0.05 %; bound 0.3 %)."""
    import json
    from importlib import resources

    csv_text = resources.files("bridgeflap.model.bridges").joinpath(
        "iabse", "storebaelt_polimi_ads.csv").read_text("utf-8")
    (tmp_path / "sb.csv").write_text(csv_text)
    d = json.loads(resources.files("bridgeflap.model.bridges").joinpath(
        "iabse", "iabse-1.1c.json").read_text("utf-8"))
    d.update(dofs=["heave", "pitch"], mass_kg_per_m=d["mass_kg_per_m"][1:],
             stiffness_n_per_m2=d["stiffness_n_per_m2"][1:],
             derivatives={"kind": "polimi-table", "file": "sb.csv"})
    (tmp_path / "sb2.json").write_text(json.dumps(d))
    two = section_case_flutter(load_section_case(str(tmp_path / "sb2.json")))
    three = section_case_flutter(load_section_case("iabse-1.1c"))
    assert two["pk_flutter_speed_m_s"] == pytest.approx(three["pk_flutter_speed_m_s"], rel=3e-3)
