"""Notebook views of every public result: a short ``repr`` (under 2 kB: the
dataclass default printed every eigenvalue, 165 kB for a FlutterResult), an HTML table for
Jupyter, and ``.plot()`` drawing data.

The results are built cheaply: the analyses on the coarse Humber mesh with 4-6 modes and
coarse grids, the batch and design records from their constructors with a few rows (their
views read only the record, not how it was computed). No tolerances: the checks are sizes and
presence.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

# design.studies.experiments.DoeResult below
import bridgeflap.design.studies.experiments  # noqa: F401
from bridgeflap import design, model
from bridgeflap.model.results import REPR_LIMIT, ResultData

SPEEDS = np.arange(0.0, 90.0, 2.0)
CONTROLLER = model.Controller(model.Compensator(-1.0852, 0.2781, -3.8118, 0.3097, 0.0242),
                              (-112.8, 112.8), 56.4)
OK_ROW = {"case_id": "case-0000", "params": {"deck.gj_nm2": 4.7e11, "cable.main_sag_m": 110.0},
          "status": "ok", "error": None, "elapsed_s": 0.5,
          "result": {"flutter_speed_m_s": 60.0, "divergence_speed_m_s": 70.0}}
BAD_ROW = {**OK_ROW, "case_id": "case-0001", "status": "failed", "result": None,
           "error": "BridgeflapError: no modes",
           "params": {"deck.gj_nm2": 7.1e11, "cable.main_sag_m": 125.0}}


@pytest.fixture(scope="module")
def analyses(coarse_humber):
    """The model's public analyses on the coarse mesh (about 15 s in all)."""
    spec = coarse_humber
    fl = model.flutter(spec, SPEEDS, n_modes=6)
    _, system = model.bridge_system(spec, 4)
    return {
        "flutter": fl, "sweep": fl.sweep,
        "modal": model.modal_model(spec, 6),
        "erection": model.erection(spec, [0.5, 1.0], np.arange(0.0, 80.0, 4.0), n_modes=4),
        "frequency_ratio": model.frequency_ratio(spec, [0.5, 1.0]),
        "buffeting": model.buffeting(spec, [10.0, 20.0], n_modes=4),
        "plant": model.plant_data(spec, 30.0, n_modes=4),
        "closed_loop": model.closed_loop_flutter(spec, CONTROLLER, SPEEDS, n_modes=4),
        "convergence": model.mode_convergence(spec, SPEEDS, counts=(4, 6)),
        "pk": model.pk_sweep(system, SPEEDS),
        "mode_shape": model.flutter_mode_shape(spec, SPEEDS, 6),
    }


def records(fl) -> dict:
    """The batch, design and study records, from their constructors."""
    from bridgeflap.design.assessment.accept import AcceptanceResult
    from bridgeflap.design.assessment.erection_control import ErectionControlResult
    from bridgeflap.design.assessment.failsafe import FailSafeResult
    from bridgeflap.design.assessment.harm import HarmResult
    from bridgeflap.design.batch.runner import BatchResult
    from bridgeflap.design.sensitivity.local import SensitivityResult
    from bridgeflap.design.studies.screening import GlobalSensitivityResult
    from bridgeflap.design.studies.study import StudyResult, study_from_dict

    rows = (OK_ROW, BAD_ROW)
    config = design.doe_from_dict({
        "name": "gj_sag", "bridge": "humber", "analysis": "flutter",
        "design": {"kind": "full_factorial", "levels": 2},
        "parameters": {"deck.gj_nm2": [4.7e11, 7.1e11], "cable.main_sag_m": [110.0, 125.0]}})
    harm_rows = tuple({"open_loop_critical_speed_m_s": 70.0,
                       "closed_loop_critical_speed_m_s": u, "closed_over_open": u / 70.0,
                       "harmed": u < 70.0, "resolved": True, "stable_to_design_speed": u > 85}
                      for u in (60.0, 80.0, 90.0, 95.0))
    crit = {"critical_speed_m_s": 75.0, "critical_mechanism": "flutter", "resolved": True}
    pairs = tuple({"pair": i, "position_m": x, "critical_speed_m_s": u,
                   "critical_mechanism": "flutter", "over_intact": u / 90.0,
                   "over_open_loop": u / 75.0, "resolved": True, "critical_beyond_grid": False,
                   "critical_speed_lower_bound_m_s": None, "stable_to_design_speed": u > 85.0}
                  for i, (x, u) in enumerate(((-112.8, 80.0), (112.8, 88.0))))
    stage = {"erected_fraction": 0.5, "stage": "erecting", "open_loop_critical_speed_m_s": 40.0,
             "closed_loop_critical_speed_m_s": 50.0, "closed_loop_flutter_status": "converged",
             "closed_loop_divergence_status": "converged"}
    sens_row = {"parameter": "deck.gj_nm2", "value": 4.7e11, "d_flutter_speed": 1e-10,
                "relative_d_flutter_speed": 0.4, "relative_d_divergence_speed": 0.5}
    study = study_from_dict({"name": "s", "bridge": "humber", "analyses": ["flutter"]})
    return {
        "design": design.DesignResult("failed", design.DesignSettings(), None, CONTROLLER, (),
                                      None, np.array([0.0, 1.0]), np.array([np.nan, -1.0]),
                                      None, 1.0),
        "batch": BatchResult(2, 1, 1, Path("table.csv"), rows),
        "doe": bridgeflap.design.studies.experiments.DoeResult(config, Path("out"), 2, 1, 1, 0,
                                                    Path("table.csv"),
                                            rows),
        "sensitivity": SensitivityResult("humber", 60.0, 70.0, "converged", "converged", 6,
                                         (sens_row,)),
        "global_sensitivity": GlobalSensitivityResult(
            "morris", {"deck.gj_nm2": (4e11, 5e11)},
            {"flutter_speed_m_s": {"deck.gj_nm2": {"mu_star": 3.0, "sigma": 1.0}}},
            {"flutter_speed_m_s": {"p05": 55.0, "p50": 60.0, "p95": 65.0}}, 4, 4, 0, "out",
            outputs={"flutter_speed_m_s": np.array([55.0, 58.0, 62.0, 65.0])}),
        "harm": HarmResult("humber", 4, 8, 85.0, 127.5, 11, {}, harm_rows),
        "acceptance": AcceptanceResult(
            "harm", {"checks": ["robustness"], "status": "harm",
                     "robustness": HarmResult("humber", 4, 8, 85.0, 127.5, 11, {},
                                              harm_rows).summary()},
            {"robustness": HarmResult("humber", 4, 8, 85.0, 127.5, 11, {}, harm_rows)}),
        "failsafe": FailSafeResult("humber", 8, 85.0, 127.5, 20.0, "both",
                                   {**crit, "critical_speed_m_s": 90.0}, crit, crit, pairs, ()),
        "erection_control": ErectionControlResult(
            "humber", (stage, {**stage, "erected_fraction": 1.0, "stage": "completed bridge"}),
            "none"),
        "study": StudyResult(study, Path("out"), {"flutter": "ok"},
                             {"flutter": fl.summary()}, 3.0, {"flutter": fl}),
        "placement": _placement(),
    }


def _placement():
    """A two-row placement: every candidate meets the target, one pair fewer fails."""
    from bridgeflap.design.control.search.placement import PlacementResult, PlacementRow

    def row(step, groups, meets, angle):
        return PlacementRow(step, groups, None if step == 0 else 0, 56.4,
                            tuple(float(x) for x in range(len(groups))), "Solve_Succeeded",
                            meets, meets, () if meets else ("flap angle 3 sigma 21 deg > 20",),
                            (0.5, 1.0, -0.8, 0.1, 0.19), 10.8, 0.72, 78.0, angle, 18.7, meets,
                            True, 78.0, 0.0, 26, 22.0)

    return PlacementResult("found", 76.71, "given", {"open_loop_critical_speed_m_s": 69.5},
                           (row(0, (0, 1), True, 19.0), row(1, (1,), False, 21.0)), (0,), 0,
                           (-56.4, 0.0, 56.4), 2, 44.0,
                           {"flap_angle_limit_deg": 20.0, "gain_limit": 15.0})


@pytest.fixture(scope="module")
def results(analyses):
    return {**analyses, **records(analyses["flutter"])}


def _figure_has_data(out) -> bool:
    first = out[0] if isinstance(out, (tuple, list, np.ndarray)) else out
    first = first.flat[0] if isinstance(first, np.ndarray) else first
    fig = getattr(first, "figure", first)
    return any(ax.lines or ax.patches or ax.images or ax.collections for ax in fig.axes)


NAMES = ["flutter", "sweep", "modal", "erection", "frequency_ratio", "buffeting", "plant",
         "closed_loop", "convergence", "pk", "mode_shape", "design", "batch", "doe",
         "sensitivity", "global_sensitivity", "harm", "acceptance", "failsafe",
         "erection_control", "study", "placement"]


@pytest.mark.parametrize("name", NAMES)
def test_views(results, name):
    import matplotlib.pyplot as plt

    res = results[name]
    assert isinstance(res, ResultData)
    text = repr(res)
    assert len(text) < min(REPR_LIMIT, 2048), text[:200]
    assert text.startswith(type(res).__name__) and "summary_error" not in text, text
    html = res._repr_html_()
    assert isinstance(html, str) and "<table" in html and "summary_error" not in html
    try:
        assert _figure_has_data(res.plot()), f"{name}: plot drew nothing"
    finally:
        plt.close("all")


def test_html_is_escaped():
    @dataclasses.dataclass(frozen=True)
    class Odd(ResultData):
        label: str

        def summary(self):
            return {"label": self.label}

    assert "<b>" not in Odd("<b>x</b>")._repr_html_()
    assert repr(Odd("x")) == "Odd(label='x')"


def test_every_public_result_is_covered(results):
    """Every result class a public function returns (``model.__all__``, ``design.__all__``)
    is among the cases above."""
    import inspect

    returned = set()
    for mod in (model, design):
        for name in mod.__all__:
            obj = getattr(mod, name)
            if callable(obj) and not isinstance(obj, type):
                ann = inspect.signature(obj).return_annotation
                returned.add(getattr(ann, "__name__", str(ann)))
    covered = {type(r).__name__ for r in results.values()}
    results_named = {n for n in returned if n.endswith(("Result", "Sweep", "Model", "Shape"))
                     or n == "Plant"}
    # not results: the model's builders
    results_named -= {"ClosedLoopModel", "SymbolicModel"}
    assert results_named <= covered, results_named - covered
