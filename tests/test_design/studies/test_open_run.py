"""A finished run folder read back (``bridgeflap.design.open_run``) and the results' common face."""

from __future__ import annotations

import numpy as np
import pytest

from bridgeflap import design
from bridgeflap.model.errors import BridgeflapInputError

CHEAP = {"speeds": "0:120:4", "modes": 4, "truncation_check": False}


@pytest.fixture(scope="module")
def doe(tmp_path_factory):
    config = design.doe_from_dict({
        "name": "t", "bridge": "humber", "analysis": "flutter", "options": CHEAP,
        "design": {"kind": "full_factorial", "levels": 2},
        "parameters": {"deck.gj_nm2": [4.7e11, 7.1e11], "cable.main_sag_m": [110.0, 125.0]}})
    out = tmp_path_factory.mktemp("doe") / "out"
    return design.run_doe(config, out_dir=out, scheduler="serial", progress=False)


def test_doe_to_xarray_has_cases_and_parameter_coordinates(doe):
    ds = doe.to_xarray()
    assert ds.sizes["case"] == 4
    assert set(np.unique(ds["deck.gj_nm2"].values)) == {4.7e11, 7.1e11}
    assert "divergence_speed_m_s" in ds and list(ds["status"].values) == ["ok"] * 4


def test_open_run_reads_a_doe_folder_back(doe):
    run = design.open_run(doe.out_dir)
    assert run.kind == "doe" and run.cases == 4 and run.failed == 0
    assert isinstance(run.summary()["cases"], int)
    assert run.to_dataframe().shape[0] == 4
    assert "| case_id" in run.table()
    assert run.to_xarray().sizes["case"] == 4
    assert hasattr(run.plot(), "savefig")
    with pytest.raises(AttributeError, match="headline numbers"):
        run.casess  # noqa: B018 - a misspelt headline name raises


def test_open_run_refuses_a_folder_it_did_not_write(tmp_path):
    (tmp_path / "mine.txt").write_text("x")
    with pytest.raises(BridgeflapInputError, match="not a bridgeflap output folder"):
        design.open_run(tmp_path)
    with pytest.raises(BridgeflapInputError, match="no such folder"):
        design.open_run(tmp_path / "missing")


def test_summary_is_plain_python_and_plot_is_a_figure():
    from bridgeflap import model

    res = model.flutter("humber", np.arange(0.0, 100.0, 2.0), n_modes=6, sweep_method="fast")
    s = res.summary()
    assert not any(isinstance(v, np.generic) for v in s.values())
    assert res.critical_speed_m_s == s["critical_speed_m_s"] and res.critical_speed_m_s > 0
    assert hasattr(res.plot(), "savefig")
    assert isinstance(model.modal_model("humber").table(), str)


def _marked(folder, kind="study"):
    from bridgeflap.design.io.outputs import write_marker

    folder.mkdir()
    write_marker(folder, kind)
    return folder


@pytest.mark.parametrize("content", [b'{"status": "ok", "cas', b"[1, 2, 3]",
                                     b"\x89PNG\r\n\x1a\n\xff\xfe"],
                         ids=["truncated", "list", "binary"])
def test_open_run_refuses_a_corrupt_summary_in_one_line(tmp_path, content):
    run = _marked(tmp_path / "run")
    (run / "summary.json").write_bytes(content)
    before = sorted(p.name for p in run.iterdir())
    with pytest.raises(BridgeflapInputError) as info:
        design.open_run(run)
    text = str(info.value)
    assert info.value.field == "folder" and "summary.json" in text and "\n" not in text
    assert sorted(p.name for p in run.iterdir()) == before  # nothing touched


def test_corrupt_result_files_are_one_line_naming_the_file(tmp_path):
    run = _marked(tmp_path / "run")
    (run / "results").mkdir()
    (run / "results" / "flutter.json").write_bytes(b'{"critical_speed_m_s": 6')
    (run / "results" / "flutter.nc").write_bytes(b"CDF\x01 not really netCDF")
    (run / "statuses.json").write_bytes(b'"flutter"')
    rec = design.open_run(run)
    for call, field in ((rec.results, "results/flutter.json"),
                        (lambda: rec.dataset("flutter"), "results/flutter.nc"),
                        (rec.statuses, "statuses.json")):
        with pytest.raises(BridgeflapInputError) as info:
            call()
        assert info.value.field == field and "\n" not in str(info.value), str(info.value)


@pytest.fixture(scope="module")
def doe_with_crossings(tmp_path_factory):
    """The DOE tutorial's 2 x 2 design: 6 modes to 120 m/s find a divergence speed in every
    case (4 modes, as ``doe`` above, find none: nothing to colour)."""
    config = design.doe_from_dict({
        "name": "gj_sag", "bridge": "humber", "analysis": "flutter",
        "options": {"speeds": "0:120:2", "modes": 6, "truncation_check": False},
        "design": {"kind": "full_factorial", "levels": 2},
        "parameters": {"deck.gj_nm2": [4.7e11, 7.1e11], "cable.main_sag_m": [110.0, 125.0]}})
    out = tmp_path_factory.mktemp("doe6") / "out"
    return design.run_doe(config, out_dir=out, scheduler="serial", progress=False)


def test_open_run_plots_a_doe_over_its_inputs_not_the_case_number(doe_with_crossings):
    """A DOE folder read back plots as the DOE result does: x and y are its two inputs."""
    import matplotlib.pyplot as plt

    doe = doe_with_crossings
    output = "divergence_speed_m_s"
    values = doe.to_dataframe()[output].astype(float)
    assert np.isfinite(values).all()  # else the plot below would have nothing to colour
    ax = design.open_run(doe.out_dir).plot(output=output).axes[0]
    assert ax.get_xlabel() == "deck.gj_nm2" and ax.get_ylabel() == "cable.main_sag_m"
    # the four cases sit at the corners of the 2 x 2 design (exact: the inputs are written as
    # given), not at case numbers 0..3
    points = {tuple(p) for p in np.asarray(ax.collections[0].get_offsets())}
    assert points == {(gj, sag) for gj in (4.7e11, 7.1e11) for sag in (110.0, 125.0)}
    # coloured by the output: the same numbers as the table (read back from the same JSON)
    assert np.array_equal(np.sort(np.asarray(ax.collections[0].get_array())), np.sort(values))
    same = doe.plot(output=output).axes[0]
    assert (same.get_xlabel(), same.get_ylabel(), same.get_title()) == (
        ax.get_xlabel(), ax.get_ylabel(), ax.get_title())
    plt.close("all")
