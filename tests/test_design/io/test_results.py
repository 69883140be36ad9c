"""Results as data: strict-JSON ``to_dict``, unit-named ``to_dataframe``, xarray/NetCDF.

Every check here is exact (JSON round trip with ``allow_nan=False``; NetCDF stores float64
bit for bit), so no tolerances are needed beyond ``np.testing.assert_array_equal``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from bridgeflap.model.analysis import erection, flutter, modal_model
from bridgeflap.model.results import UNIT_SUFFIXES, UNITLESS_COLUMNS, jsonable, sweep_dataset

SPEEDS = np.arange(0.0, 90.0, 2.0)


def strict_round_trip(d) -> dict:
    """``json.loads(json.dumps(d, allow_nan=False))``: raises on NaN/inf or non-JSON types."""
    return json.loads(json.dumps(d, allow_nan=False))


def assert_units(frame) -> None:
    """Every column is a label/status/count or ends in a unit (or a dimensionless suffix)."""
    for col in frame.columns:
        stem = col.split(".")[-1]
        ok = (stem in UNITLESS_COLUMNS or stem.endswith(UNIT_SUFFIXES)
              or stem.startswith(("relative_", "ratio_")))
        assert ok, f"column {col!r} carries no unit"


@pytest.fixture(scope="module")
def flutter_result(coarse_humber):
    return flutter(coarse_humber, SPEEDS, n_modes=6)


def test_jsonable_strict():
    d = jsonable({"a": np.float64("nan"), "b": np.array([1.0, np.inf]), 3: np.int64(2),
                  "c": 1 + 2j})
    assert strict_round_trip(d) == {"a": None, "b": [1.0, None], "3": 2,
                                    "c": {"real": 1.0, "imag": 2.0}}


def test_flutter_result_as_data(flutter_result):
    d = strict_round_trip(flutter_result.to_dict())
    assert d["flutter_status"] == "converged"
    assert strict_round_trip(flutter_result.sweep.to_dict())["flutter_speed_m_s"] > 0
    df = flutter_result.to_dataframe()
    assert_units(df)
    sw = flutter_result.sweep
    assert len(df) == sw.branches.shape[0] * SPEEDS.size
    assert set(df.columns) >= {"speed_m_s", "branch", "frequency_hz", "damping_ratio",
                               "real_part_1_s"}
    # the frame is the sweep's own numbers (branch k, speed i)
    row = df[(df.branch == sw.branch_labels[1]) & (df.speed_m_s == SPEEDS[3])].iloc[0]
    assert row.real_part_1_s == sw.branches[1, 3].real
    assert row.frequency_hz == sw.frequencies_hz()[1, 3]
    assert "|" in flutter_result.table()


def test_sweep_netcdf_round_trip(flutter_result, tmp_path):
    import xarray as xr

    from bridgeflap.design.io.files import atomic_save_netcdf

    ds = flutter_result.to_xarray()
    assert ds.speed_m_s.attrs["units"] == "m/s"
    assert ds.frequency_hz.attrs["units"] == "Hz"
    assert ds.attrs["bridge"] == "humber"
    path = atomic_save_netcdf(tmp_path / "sweep.nc", ds)
    with xr.open_dataset(path, engine="scipy") as back:
        back.load()
    np.testing.assert_array_equal(back.real_part_1_s.values, ds.real_part_1_s.values)
    np.testing.assert_array_equal(back.speed_m_s.values, SPEEDS)
    assert list(back.branch.values) == list(flutter_result.sweep.branch_labels)
    assert back.attrs["flutter_speed_m_s"] == ds.attrs["flutter_speed_m_s"]
    assert sweep_dataset(flutter_result.sweep).sizes["branch"] == 6


def test_modes_as_data(coarse_humber):
    modal = modal_model(coarse_humber, 12)
    d = strict_round_trip(modal.to_dict())
    assert d["modes"][0]["frequency_hz"] > 0
    df = modal.to_dataframe()
    assert_units(df)
    assert list(df.label[:1]) == [modal.modes[0].label]
    shapes = modal.deck_shapes()
    assert shapes["shape"].shape == (len(modal.modes), shapes["node_x_m"].size)


def test_erection_as_data(coarse_humber):
    res = erection(coarse_humber, [0.5, 1.0], np.arange(0.0, 80.0, 4.0), n_modes=4)
    strict_round_trip(res.to_dict())
    df = res.to_dataframe()
    assert_units(df)
    assert list(df.stage)[-1] == "completed bridge"
    assert len(df) == 3


def test_buffeting_as_data(coarse_humber):
    from bridgeflap.model.response.buffeting import buffeting

    res = buffeting(coarse_humber, [10.0, 20.0], n_modes=4)
    strict_round_trip(res.to_dict())
    df = res.to_dataframe()
    assert_units(df)
    np.testing.assert_array_equal(df.rms_vertical_m.to_numpy(), res.rms_vertical)


def test_batch_rows_are_flat():
    from pathlib import Path

    from bridgeflap.design.batch.runner import BatchResult

    rows = ({"case_id": "c0", "params": {"deck.mass_kg_m": 1.0}, "status": "ok", "error": None,
             "result": {"critical_speed_m_s": 60.0, "x": {"y_m": float("nan")}},
             "elapsed_s": 0.5},)
    res = BatchResult(1, 1, 0, Path("table.csv"), rows)
    df = res.to_dataframe()
    assert list(df.columns) == ["case_id", "status", "deck.mass_kg_m", "critical_speed_m_s",
                                "x.y_m", "elapsed_s", "error"]
    assert df.critical_speed_m_s[0] == 60.0
    assert_units(df)
    strict_round_trip(res.to_dict())


def test_design_result_is_strict_json():
    from bridgeflap.design.control.results.result import DesignResult
    from bridgeflap.design.control.settings import DesignSettings
    from bridgeflap.model.aeroelastic.control import Compensator, Controller

    ctrl = Controller(Compensator(0.0, 0.1, -0.5, 0.01, 0.2), (-56.4, 0.0, 56.4), 56.4)
    res = DesignResult("failed", DesignSettings(), None, ctrl, (), None, np.array([0.0, 1.0]),
                       np.array([np.nan, -1.0]), None, 1.0)
    s = res.summary()  # no NaN even before json.dumps
    assert strict_round_trip(s)["max_gain"] is None
    assert strict_round_trip(res.to_dict()) == strict_round_trip(s)
    bode = res.compensator_response([0.1, 1.0])
    assert_units(bode)
    # scipy.signal.freqs against the compensator's own K(j omega), to rounding
    np.testing.assert_allclose(bode.gain_rad_per_rad,
                               np.abs(ctrl.compensator.frequency_response(bode.omega_rad_s)),
                               rtol=1e-13)
