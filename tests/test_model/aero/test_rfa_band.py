"""The band-weighted 4-lag RFA ``rfa4-band`` and the unchanged default ``rfa4``.

``rfa4-band`` is the lag form of :mod:`bridgeflap.model.aero.rfa` with the same 4 lags, least
squares weighted 10 on the bridge-flutter band 0.05 <= k <= 0.5
(:data:`bridgeflap.model.aero.rfa.FLUTTER_BAND_K`). Checks: (a) its error on the band and on 0 < k
<= 3 against stated bounds, on an independent grid; (b) the invariants C(0) = 1 and C(inf) = 1/2,
stable sorted poles; (c) the flutter speed of each 2-D case of
:mod:`bridgeflap.model.cases.rfa_cases` within 0.05 % of the exact-Theodorsen p-k (the required
bound), and closer than ``rfa4``; and the default ``rfa4`` has the coefficients it had before.
Measured numbers: ``python runs/rfa_fit/run.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from bridgeflap.design.cli.main import main as cli_main
from bridgeflap.model.aero.rfa import (
    BAND_WEIGHT,
    FLUTTER_BAND_K,
    RFA_NAMES,
    RationalApprox,
    fit_theodorsen,
    get_rfa,
)
from bridgeflap.model.aero.theodorsen import theodorsen
from bridgeflap.model.cases.rfa_cases import RFA_CHECK_CASES, case_system, flutter_gap
from bridgeflap.model.errors import BridgeflapInputError

# Dense independent check grids (not the fitting grid, not band_error's grid).
K_ALL = np.geomspace(1e-6, 3.0, 30001)
K_BAND = np.geomspace(FLUTTER_BAND_K[0], FLUTTER_BAND_K[1], 20001)

#: fit_theodorsen() at commit 1a5b01a (before rfa4-band), printed with repr
RFA4_GAINS = [0.01892434456720269, 0.10860680806104683, 0.2666689734928313, 0.1057998738789192]
RFA4_POLES = [0.0064881159012190005, 0.04956970521178545, 0.18777413540894122, 0.62624662871971]


def _err(approx, k):
    return float(np.max(np.abs(approx.evaluate(k) - theodorsen(k))))


def test_default_rfa4_is_unchanged():
    # The unweighted path runs the same operations as before. The pole locations are weakly
    # determined (a flat least-squares valley), so another BLAS kernel ends the same
    # least_squares run (xtol = ftol = gtol = 1e-12) elsewhere in the valley: on an AMD EPYC
    # with OpenBLAS 0.3.31 (SkylakeX kernel) the coefficients differ from the recorded ones
    # (another CPU) by 3.0e-7 relative, the fit's error by far less. 2e-6 admits that and
    # still fails on a changed fit: the band weight moves them by O(1), see the next test.
    r = get_rfa("rfa4")
    assert r is fit_theodorsen() and r.name == "rfa4"
    np.testing.assert_allclose(r.gains, RFA4_GAINS, rtol=2e-6, atol=0)
    np.testing.assert_allclose(r.poles, RFA4_POLES, rtol=2e-6, atol=0)
    assert r.fit_band is None and r.band_weight == 1.0
    # the statespace and CLI default is still the unweighted fit
    assert RFA_NAMES[0] == "rfa4"


def test_band_fit_error_bounds():
    band, r4 = get_rfa("rfa4-band"), get_rfa("rfa4")
    e_band, e_all = _err(band, K_BAND), _err(band, K_ALL)
    # measured 5.44e-4 on the band (rfa4: 1.13e-3) and 2.99e-3 on 0 < k <= 3 (rfa4: 1.52e-3);
    # bounds: 6e-4 on the band (10 % above the measured, far below rfa4's), and on the whole
    # range the 3.2e-3 of the reference 4-lag fit (docs/humber_data.md#lift-deficiency-...)
    assert e_band < 6e-4
    assert e_band < 0.5 * _err(r4, K_BAND)
    assert e_all < 3.2e-3
    # the stored and reported errors agree with these independent grids (smooth error curve,
    # grid resolution of the peak well below 1e-6)
    rep = band.report()
    assert rep["max_error"] == pytest.approx(e_all, abs=1e-6)
    assert rep["max_error_in_flutter_band"] == pytest.approx(e_band, abs=1e-6)
    assert rep["fit_band_k"] == list(FLUTTER_BAND_K) and rep["fit_band_weight"] == BAND_WEIGHT


def test_band_fit_constraints_and_form():
    r = get_rfa("rfa4-band")
    assert r is fit_theodorsen(4, 3.0, FLUTTER_BAND_K, BAND_WEIGHT)  # cached, one object
    assert r.name == "rfa4-band" and r.n_lags == 4  # same model size as rfa4
    # C(inf) = 1/2: sum A = 1/2 by elimination of the last gain, exact to rounding
    assert abs(r.gains.sum() - 0.5) < 1e-14
    assert abs(r.evaluate_s(1e12) - 0.5) < 1e-10  # next term A beta / s ~ 1e-13
    assert r.evaluate(0.0) == 1.0  # C(0) = 1 identically in the lag form
    assert np.all(r.poles > 0.0) and np.all(np.diff(r.poles) > 0.0)
    with pytest.raises(ValueError):
        r.poles[0] = 1.0  # read-only, as every cached fit


def test_unit_band_weight_is_the_unweighted_fit():
    # The weighted path with weight 1 solves the same least-squares problem from rfa4's own
    # optimum: the same fit to least_squares' tolerance (measured 1.4e-7 relative on a pole).
    a, b = fit_theodorsen(4, 3.0, FLUTTER_BAND_K, 1.0), get_rfa("rfa4")
    np.testing.assert_allclose(a.poles, b.poles, rtol=1e-5)
    np.testing.assert_allclose(a.gains, b.gains, rtol=1e-5)
    assert a.name == "rfa4-band[0.05,0.5]x1"


@pytest.fixture(scope="module")
def gaps():
    return {c: flutter_gap(c, ("rfa4", "rfa4-band")) for c in RFA_CHECK_CASES}


@pytest.mark.parametrize("case", RFA_CHECK_CASES)
def test_2d_flutter_within_0p05_percent_of_exact(gaps, case):
    g = gaps[case]
    assert g["exact_flutter_status"] == "converged"
    band, old = g["rfa"]["rfa4-band"], g["rfa"]["rfa4"]
    assert band["flutter_status"] == old["flutter_status"] == "converged"
    # The required bound, 0.05 %; measured at most 0.031 % (IABSE 1.1a). Crossings are refined
    # to 1e-7 m/s (1e-9 U/(b omega_theta)): below 1e-6 % of the gap.
    assert abs(band["gap_percent"]) < 0.05
    # the diagnosis: the unweighted fit is 0.06-0.13 % off, and the band fit is closer
    assert 0.05 < abs(old["gap_percent"]) < 0.14
    assert abs(band["gap_percent"]) < 0.5 * abs(old["gap_percent"])
    # the C(k) error at the flutter reduced frequency (0.21-0.32 here) is what moved
    assert band["c_error_at_flutter"] < 3e-4 < old["c_error_at_flutter"]


def test_the_exact_reference_does_not_depend_on_the_fit():
    # the p-k uses the exact C(k) on the structure and strip loads: the fit only enters the
    # RFA sweep (same crossing to the Brent tolerance, 1e-7 m/s)
    a = flutter_gap("iabse-1.1a", ("rfa4",))["exact_flutter_speed"]
    b = flutter_gap("iabse-1.1a", ("rfa4-band",))["exact_flutter_speed"]
    assert a == pytest.approx(b, abs=1e-6)


def test_bad_band_inputs():
    for band, field in (((0.5, 0.05), "band"), ((1e-4, 0.5), "band"), ((0.05, 4.0), "band"),
                        ((0.05,), "band"), ("ab", "band")):
        with pytest.raises(BridgeflapInputError) as info:
            fit_theodorsen(4, 3.0, band, 10.0)
        assert info.value.field == field
    for w in (0.0, -1.0, float("nan"), float("inf"), "10"):
        with pytest.raises(BridgeflapInputError) as info:
            fit_theodorsen(4, 3.0, FLUTTER_BAND_K, w)
        assert info.value.field == "band_weight"
    with pytest.raises(BridgeflapInputError):
        RationalApprox(np.array([0.5]), np.array([0.1]), "x", 0.0, 3.0, (0.1, 0.2), 0.0)
    with pytest.raises(BridgeflapInputError) as info:
        case_system("iabse-9z")
    assert info.value.field == "case"


def test_cli_accepts_the_band_fit(capsys):
    import json

    assert cli_main(["rfa", "--name", "rfa4-band", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["name"] == "rfa4-band" and rep["n_lags"] == 4
    assert cli_main(["section", "--mass", "7660", "--inertia", "375000", "--f-heave", "0.117",
                     "--f-torsion", "0.311", "--half-chord", "11", "--aero", "rfa4-band",
                     "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    # model.cases.rfa_cases "section": 48.18311 m/s (exact 48.17628, rfa4 48.21307); 1e-3 m/s is
    # the CLI's default Brent tolerance, and 50x below the rfa4 - rfa4-band difference
    assert out["aero"] == "rfa4-band"
    assert out["flutter_speed_m_s"] == pytest.approx(48.18311, abs=1e-3)


@pytest.mark.slow
def test_humber_band_fit_shift():
    """Humber, 16 modes: exact p-k 69.389 m/s; rfa4 +0.177 %, rfa4-band +0.047 %."""
    from bridgeflap.model import analysis
    from bridgeflap.model.stability import sweeps as stability
    from bridgeflap.model.structure.loader import load_bridge

    spec = load_bridge("humber")
    modal, system = analysis.bridge_system(spec, analysis.DEFAULT_MODES)
    ue = stability.pk_sweep(system, np.arange(0.0, 85.0 + 1e-9, 2.5), speed_tol=1e-5).flutter
    assert ue.status == "converged"
    u = {r: analysis.flutter(spec, np.arange(0.0, 85.0 + 1e-9, 0.5), rfa=r,
                             speed_tol=1e-5).sweep.flutter.speed for r in ("rfa4", "rfa4-band")}
    gap = {r: 100 * (v / ue.speed - 1) for r, v in u.items()}
    # measured +0.1766 % and +0.0466 % (crossings to 1e-5 m/s, 1.4e-5 %); the rfa4 band
    # +-0.005 % pins today's default, the band fit is held to the required 0.05 %
    assert 0.17 < gap["rfa4"] < 0.18
    assert 0.0 < gap["rfa4-band"] < 0.05
