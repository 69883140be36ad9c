"""The registry of analyses is the single source of defaults for the CLI, studies and DOEs.

Before it, the same Humber case gave different flutter speeds from ``bridgeflap flutter`` and
from a DOE case (16 vs 10 retained modes, different speed grids). These tests pin that every
entry point resolves the same default objects and so the same number.
"""

import contextlib
import io
import json
import os
import subprocess
import sys

import pytest

import bridgeflap.model.analysis
from bridgeflap.design.cli.main import COMMANDS, build_parser, main
from bridgeflap.design.io.options import parse_range
from bridgeflap.design.studies.analyses import ANALYSES, DEFAULT_MODES, DEFAULT_SPEEDS, RunContext
from bridgeflap.design.studies.experiments import doe_from_dict
from bridgeflap.design.studies.study import study_from_dict
from bridgeflap.model.errors import BridgeflapInputError


def test_default_modes_are_defined_once():
    assert DEFAULT_MODES is bridgeflap.model.analysis.DEFAULT_MODES
    for name in ("flutter", "erection", "buffeting", "sensitivity"):
        assert ANALYSES[name].defaults["modes"] is DEFAULT_MODES


@pytest.mark.parametrize("command,analysis", [("flutter", "flutter"), ("erection", "erection"),
                                              ("buffeting", "buffeting"),
                                              ("sensitivity", "sensitivity")])
def test_cli_defaults_are_the_registry_objects(command, analysis):
    args = build_parser().parse_args([command])
    defaults = ANALYSES[analysis].defaults
    assert args.speeds is defaults["speeds"]
    assert args.modes is defaults["modes"]


def test_flutter_and_erection_share_the_default_grid():
    assert ANALYSES["flutter"].defaults["speeds"] is DEFAULT_SPEEDS
    assert ANALYSES["erection"].defaults["speeds"] is DEFAULT_SPEEDS
    assert build_parser().parse_args(["flutter"]).speeds is DEFAULT_SPEEDS


def test_study_and_doe_resolve_the_same_defaults(tmp_path):
    study = study_from_dict({"name": "s", "analyses": ["flutter"]}, base=tmp_path)
    (kind, opts), = study.analyses
    resolved = ANALYSES[kind].resolve(opts)
    assert resolved["speeds"] is DEFAULT_SPEEDS and resolved["modes"] is DEFAULT_MODES
    doe = doe_from_dict({"name": "d", "analysis": "flutter",
                         "parameters": {"deck.gj_nm2": [3.0e11, 4.0e11]}}, base=tmp_path)
    assert doe.options == {}
    fn = doe.case_function()
    assert fn.keywords == {"analysis": "flutter", "bridge": "humber"}


def test_doe_case_without_options_gives_the_cli_flutter_speed(tmp_path):
    """Same defaults, same code path: the same numbers to 1e-9 (deterministic LAPACK)."""
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
        assert main(["flutter", "--json"]) == 0
    cli = json.loads(buf.getvalue())
    doe = doe_from_dict({"name": "d", "analysis": "flutter",
                         "parameters": {"deck.gj_nm2": [3.0e11, 4.0e11]}}, base=tmp_path)
    case = doe.case_function()({})
    for key in ("flutter_speed_m_s", "flutter_frequency_hz", "divergence_speed_m_s"):
        assert case[key] == pytest.approx(cli[key], rel=1e-9)
    assert case["flutter_status"] == cli["flutter_status"] == "converged"


def test_study_runner_without_options_gives_the_cli_flutter_speed():
    from bridgeflap.model.structure.loader import load_bridge

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
        assert main(["flutter", "--json", "--order", "full"]) == 0
    cli = json.loads(buf.getvalue())
    outcome = ANALYSES["flutter"](load_bridge("humber"), {"order": "full"},
                                  RunContext(figures=False))
    assert outcome.summary["flutter_speed_m_s"] == pytest.approx(cli["flutter_speed_m_s"],
                                                                 rel=1e-9)
    assert outcome.figures == {}


def test_cli_is_an_explicit_table():
    names = [c.name for c in COMMANDS]
    assert len(names) == len(set(names))
    assert {"modes", "flutter", "erection", "frequency-ratio", "section", "state-space", "rfa",
            "derivatives", "buffeting", "optimise", "study", "robustness", "actuators", "doe",
            "placement",
            "sensitivity"} == set(names)
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert list(sub.choices) == names


def test_library_import_leaves_the_environment_alone():
    """Only ``bridgeflap.design.cli.main.main`` sets BLAS thread defaults; importing the library
    does not."""
    code = ("import os; before = dict(os.environ); "
            "import bridgeflap.design.cli.main, bridgeflap.design.studies.study, "
            "bridgeflap.design.studies.experiments, "
            "bridgeflap.design.studies.cases, bridgeflap.design.batch.runner; "
            "assert dict(os.environ) == before, set(os.environ) ^ set(before)")
    env = {k: v for k, v in os.environ.items()
           if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]


# ------------------------------------------------------------------ grid text (design.io.options)


@pytest.mark.parametrize("text", ["5:1:1", "0:10:0", "0:10:-1", "abc", "1:2", ""])
def test_bad_grid_text_raises(text):
    """``parse_range`` (the CLI's grid reader) names the field."""
    with pytest.raises(BridgeflapInputError) as info:
        parse_range(text, "speeds", 0.0)
    assert info.value.field == "speeds"


def test_empty_grid_reason():
    """'5:1:1' is an empty grid, not a non-numeric one: the message should say so."""
    with pytest.raises(BridgeflapInputError, match="empty"):
        parse_range("5:1:1", "speeds", 0.0)


def test_default_grid_is_the_seed_range():
    """0 to 85 m/s by 0.5 (seed Fig. 3), both ends included: 171 speeds."""
    u = parse_range(DEFAULT_SPEEDS, "speeds", 0.0)
    assert u.size == 171 and u[0] == 0.0 and u[-1] == 85.0
