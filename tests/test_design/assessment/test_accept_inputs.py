"""What the acceptance entry points accept and refuse besides the API matrix's one-liners: a
controller file's path is read, a controller judged on another bridge than it records warns as
the command line does, and the CLI and the API share one bound per quantity.

The checks themselves are replaced by a stub where only what happens before them is tested
(no physics runs, so there are no tolerances).
"""

from __future__ import annotations

import warnings

import pytest

from bridgeflap import design
from bridgeflap.design.io.api_args import MAX_DESIGN_SPEED_M_S, MAX_SEED, MAX_VARIANTS
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.aeroelastic.controller_file import plant_record, save_controller
from bridgeflap.model.errors import BridgeflapInputError, BridgeflapWarning

K = Compensator(0.0, 0.1, 0.5, 0.0, 0.1)


def _humber_controller():
    return Controller(K, (0.0,), 10.0, flap_chord_m=3.0, plant=plant_record("humber", 8))


@pytest.fixture
def stub_checks(monkeypatch):
    """The acceptance checks replaced by a recorder: ``calls`` holds each call's bridge."""
    calls = []

    def acceptance(controller, settings, opts, closed_loop=None, progress=None, bridge=None,
                   closed_loop_limits=None):
        calls.append((controller, bridge))
        return {"checks": list(opts.checks), "status": "passed"}, {}

    monkeypatch.setattr("bridgeflap.design.assessment.acceptance.acceptance", acceptance)
    return calls


def test_a_controller_judged_on_another_bridge_warns_as_the_cli_does(stub_checks):
    with pytest.warns(BridgeflapWarning, match="designed on bridge humber.*great-belt"):
        res = design.accept(_humber_controller(), bridge="great-belt", checks="robustness")
    assert res.status == "passed" and stub_checks[0][1] == "great-belt"


def test_the_bridge_a_controller_records_does_not_warn(stub_checks):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any warning fails the test
        design.accept(_humber_controller(), bridge="humber", checks="robustness")
    assert len(stub_checks) == 1


def test_a_controller_path_is_read_by_accept(tmp_path, stub_checks):
    path = save_controller(_humber_controller(), tmp_path / "c.toml")
    design.accept(path, checks="robustness")
    design.accept(str(path), checks="robustness")
    assert [c.compensator for c, _ in stub_checks] == [K, K]


def test_a_controller_path_is_read_by_do_no_harm(tmp_path):
    from bridgeflap.design.assessment.harm import HARM_METHODS, SAMPLINGS
    from bridgeflap.design.io.api_args import check_harm_args

    path = save_controller(_humber_controller(), tmp_path / "c.toml")
    controller, spec, grid = check_harm_args(
        str(path), "humber", 2, 11, 4, 85.0, None, None, (), 1, None, "fast", None, "random",
        None, HARM_METHODS, SAMPLINGS)
    assert controller.compensator == K and spec.name and grid is None


@pytest.mark.parametrize("argv, option, accepted", [
    (["--samples", str(MAX_VARIANTS)], "samples", True),
    (["--samples", str(MAX_VARIANTS + 1)], "samples", False),
    (["--seed", str(MAX_SEED)], "seed", True),
    (["--seed", "-1"], "seed", False),
    (["--speed-max", str(MAX_DESIGN_SPEED_M_S)], "speed-max", True),
    (["--speed-max", str(2 * MAX_DESIGN_SPEED_M_S)], "speed-max", False),
])
def test_robustness_options_have_the_apis_bounds(argv, option, accepted, tmp_path):
    """The CLI's checks after parsing, without the run: the bound is the API's."""
    from bridgeflap.design.cli.main import _check_args, build_parser

    path = save_controller(_humber_controller(), tmp_path / "c.toml")
    full = ["robustness", "--controller", str(path), *argv]
    args = build_parser(full).parse_args(full)
    if accepted:
        _check_args(args)
    else:
        with pytest.raises(BridgeflapInputError) as info:
            _check_args(args)
        assert info.value.field == option


def test_the_sensitivity_sample_bound_is_its_own():
    """``sensitivity --samples`` counts Morris trajectories / a Sobol' base sample: its bound
    (4096) is not the variants' one."""
    from bridgeflap.design.cli.main import _check_args, build_parser

    full = ["sensitivity", "--global", "morris", "--samples", "8192"]
    args = build_parser(full).parse_args(full)
    with pytest.raises(BridgeflapInputError, match="samples"):
        _check_args(args)


@pytest.mark.parametrize("extra, option", [
    (["--scheduler", "local"], "scheduler"),
    (["--sampling", "sobol"], "sampling"),
    (["--samples", "50"], "samples"),
])
def test_failures_refuses_the_variants_options(extra, option, tmp_path, capsys):
    from bridgeflap.design.cli.main import main

    path = save_controller(_humber_controller(), tmp_path / "c.toml")
    rc = main(["robustness", "--controller", str(path), "--failures", *extra])
    cap = capsys.readouterr()
    assert rc == 2 and cap.out == ""
    assert cap.err.splitlines() == [cap.err.strip()]  # one line
    assert cap.err.startswith(f"bridgeflap: error: {option}: not with --failures")
