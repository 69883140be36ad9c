"""The scripting API's bad-input contract: every public function of ``model.__all__`` and
``design.__all__`` refuses a bad argument at the door with a typed error (a
:class:`~bridgeflap.model.errors.BridgeflapInputError`;
:class:`~bridgeflap.model.errors.BridgeflapTypeError` for the wrong type or kind) whose message is
one line naming the argument, before any work and without writing anything.

The matrix is generated: each argument a function checks is given the wrong type (an
``object()``) with every other argument valid; the cases the survey found (a path where a
controller is expected, ``n_modes=2.5``, a negative ``modes_per_family``...) are listed by
hand. No physics runs (every call is refused at the door), so there are no tolerances.
"""

from __future__ import annotations

import inspect
import math
import types

import pytest

from bridgeflap import design, model
from bridgeflap.design.assessment.harm import do_no_harm
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.errors import BridgeflapError, BridgeflapInputError, BridgeflapTypeError

#: public functions that check their arguments themselves rather than by
#: ``model.arguments.checked``: the reason for each
CHECKED_INSIDE = {
    "bridgeflap.model.load_bridge": "its one argument is read by load_bridge's own checks",
    "bridgeflap.design.design": "bridgeflap.design.io.api_args.check_design_args on its first line",
    "bridgeflap.design.accept": "its controller, settings, checks and counts on its first lines",
    "bridgeflap.design.open_run": "bridgeflap.model.arguments.check_path on its folder, then the "
    "folder's marker",
    "bridgeflap.design.quick_settings": "bridgeflap.design.io.api_args.check_settings on its first "
    "line",
    "bridgeflap.design.load_settings": "bridgeflap.design.io.api_args.check_load_settings_args on "
    "its first line",
    "bridgeflap.design.do_no_harm": "bridgeflap.design.io.api_args.check_harm_args on its first "
    "line",
    "bridgeflap.design.placement_search": "check_settings, then its numbers and log, on its "
    "first lines",
}

_CONTROLLER = Controller(Compensator(0.0, 0.1, 0.5, 0.0, 0.1), flap_strip_positions_m=(0.0,),
                         flap_width_m=10.0)
_SYSTEM = types.SimpleNamespace(A=lambda U: None, basis=None)  # passes the kind check only
_S = "0:10:10"
#: valid values of the required arguments (the argument under test is replaced)
BASE = {
    "bridgeflap.model.bridge_system": {"bridge": "humber"},
    "bridgeflap.model.buffeting": {"bridge": "humber", "speeds": "10"},
    "bridgeflap.model.build_symbolic": {"bridge": "humber", "n_modes": 2},
    "bridgeflap.model.closed_loop": {"bridge": "humber", "speed": 10.0, "controller": _CONTROLLER},
    "bridgeflap.model.closed_loop_flutter": {"bridge": "humber", "controller": _CONTROLLER,
                                             "speeds": _S},
    "bridgeflap.model.closed_loop_model": {"bridge": "humber", "positions_m": [0.0],
                                           "width_m": 10.0},
    "bridgeflap.model.closed_loop_state_space": {"bridge": "humber", "controller": _CONTROLLER,
                                      "speed": 10.0},
    "bridgeflap.model.erection": {"bridge": "humber", "fractions": "1", "speeds": _S},
    "bridgeflap.model.flutter": {"bridge": "humber", "speeds": _S},
    "bridgeflap.model.flutter_mode_shape": {"bridge": "humber", "speeds": _S, "n_modes": 2},
    "bridgeflap.model.frequency_ratio": {"bridge": "humber", "fractions": "1"},
    "bridgeflap.model.load_controller": {"path": "c.toml"},
    "bridgeflap.model.modal_model": {"bridge": "humber"},
    "bridgeflap.model.mode_convergence": {"bridge": "humber", "speeds": _S},
    "bridgeflap.model.pk_flutter": {"bridge": "humber", "speeds": _S},
    "bridgeflap.model.pk_sweep": {"system": _SYSTEM, "speeds": _S},
    "bridgeflap.model.plant": {"bridge": "humber", "speed": 10.0},
    "bridgeflap.model.plant_data": {"bridge": "humber", "speed": 10.0},
    "bridgeflap.model.plant_family": {"bridge": "humber", "speeds": "10"},
    "bridgeflap.model.save_bridge": {"bridge": "humber", "path": "out.toml"},
    "bridgeflap.model.save_controller": {"controller": _CONTROLLER, "path": "c.toml"},
    "bridgeflap.model.section_basis": {"mass_kg_per_m": 1e4, "inertia_kgm2_per_m": 1e6,
                                       "f_heave_hz": 0.1,
                            "f_torsion_hz": 0.3, "half_chord_m": 10.0},
    "bridgeflap.model.spec_from_dict": {"data": {}},
    "bridgeflap.model.sweep": {"system": _SYSTEM, "speeds": _S},
    "bridgeflap.model.truncation_error": {"bridge": "humber", "n_modes": 2, "speeds": _S},
    "bridgeflap.model.typical_section": {"mu": 50.0, "r2": 0.25, "sigma": 0.4, "a": 0.0,
                                         "x_theta": 0.0},
    "bridgeflap.model.closed_loop_functions": {"model": None},
    "bridgeflap.design.local_sensitivity": {"bridge": "humber"},
    "bridgeflap.design.global_sensitivity": {},
    "bridgeflap.design.load_study": {},
    "bridgeflap.design.run_study": {},
    "bridgeflap.design.study_from_dict": {"data": {}},
    "bridgeflap.design.load_doe": {"path": "doe.toml"},
    "bridgeflap.design.run_doe": {"config": "doe.toml"},
    "bridgeflap.design.doe_from_dict": {"data": {}},
    "bridgeflap.design.run_batch": {"fn": len, "cases": [{}], "out_dir": "b"},
    "bridgeflap.design.make_design": {"kind": "full-factorial"},
    "bridgeflap.design.parse_range": {"text": "0:1:1", "field": "x"},
    "bridgeflap.design.main": {},
}


def _public():
    for pkg in (model, design):
        for name in pkg.__all__:
            obj = getattr(pkg, name)
            if inspect.isfunction(obj):
                yield f"{pkg.__name__}.{name}", obj


def _matrix():
    for qual, fn in _public():
        for arg in getattr(fn, "checked_arguments", ()):
            yield pytest.param(qual, fn, arg, id=f"{qual}-{arg}")


def _refused(call, field: str, kind=BridgeflapInputError) -> str:
    with pytest.raises(BridgeflapError) as info:
        call()
    err = info.value
    assert isinstance(err, kind), f"{type(err).__name__}: {err}"
    text = str(err)
    assert "\n" not in text and text.startswith(f"{field}: "), text
    return text


@pytest.fixture(autouse=True)
def _nothing_written(tmp_path, monkeypatch):
    """Every call runs in an empty folder that must stay empty."""
    monkeypatch.chdir(tmp_path)
    yield
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_every_public_function_checks_its_arguments():
    unchecked = [q for q, fn in _public()
                 if not getattr(fn, "checked_arguments", ()) and q not in CHECKED_INSIDE]
    assert not unchecked, unchecked
    assert set(BASE) >= {q for q, fn in _public() if getattr(fn, "checked_arguments", ())}
    assert len(list(_matrix())) >= 190  # the matrix is not silently empty (197 when written)


@pytest.mark.parametrize("qual, fn, arg", list(_matrix()))
def test_wrong_type_is_refused_naming_the_argument(qual, fn, arg):
    kwargs = {**BASE[qual], arg: object()}
    _refused(lambda: fn(**kwargs), arg, BridgeflapTypeError)


# the cases the survey found, and out-of-range values: (call, argument named, error class)
SURVEY = [
    (lambda: model.flutter(42, _S), "bridge", BridgeflapTypeError),
    (lambda: model.closed_loop("humber", 10.0, "ctrl.toml"), "controller", BridgeflapInputError),
    (lambda: model.closed_loop("humber", 10.0, 3), "controller", BridgeflapTypeError),
    (lambda: model.load_controller(123), "path", BridgeflapTypeError),
    (lambda: model.save_controller("c.toml", "x.toml"), "controller", BridgeflapTypeError),
    (lambda: design.design({"n_modes": 8}), "settings", BridgeflapTypeError),
    (lambda: design.accept(42), "controller", BridgeflapTypeError),
    (lambda: design.open_run(42), "folder", BridgeflapTypeError),
    (lambda: design.accept(_CONTROLLER, checks="everything"), "checks", BridgeflapInputError),
    (lambda: design.accept(_CONTROLLER, checks=3), "checks", BridgeflapTypeError),
    (lambda: design.accept(_CONTROLLER, samples=0), "samples", BridgeflapInputError),
    (lambda: design.accept(_CONTROLLER, samples=2.5), "samples", BridgeflapTypeError),
    (lambda: design.accept(_CONTROLLER, settings=7), "settings", BridgeflapTypeError),
    (lambda: design.design(design.load_settings(), checks="x"), "checks", BridgeflapInputError),
    (lambda: design.quick_settings("card.toml"), "settings", BridgeflapTypeError),
    (lambda: design.load_settings(42), "path", BridgeflapTypeError),
    (lambda: design.design(design.load_settings(), warm_start="ctrl.toml"), "warm_start",
     BridgeflapTypeError),
    (lambda: design.design(design.load_settings(), bridge=3.0), "bridge", BridgeflapTypeError),
    (lambda: design.placement_search("card.toml"), "settings", BridgeflapTypeError),
    (lambda: design.placement_search(design.load_settings(), target_m_s="fast"), "target_m_s",
     BridgeflapTypeError),
    (lambda: design.placement_search(design.load_settings(), target_m_s=-1.0), "target_m_s",
     BridgeflapInputError),
    (lambda: design.placement_search(design.load_settings(), workers=0), "workers",
     BridgeflapInputError),
    (lambda: design.placement_search(design.load_settings(), max_steps=1.5), "max_steps",
     BridgeflapTypeError),
    (lambda: design.placement_search(design.load_settings(), log="stderr"), "log",
     BridgeflapTypeError),
    (lambda: design.local_sensitivity("humber", parameters=5), "parameters",
     BridgeflapTypeError),
    (lambda: design.local_sensitivity("humber", parameters=[]), "parameters",
     BridgeflapInputError),
    (lambda: model.plant("humber", "fast"), "speed", BridgeflapTypeError),
    (lambda: model.plant("humber", 10.0, flaps=0), "flaps", BridgeflapInputError),
    (lambda: model.plant("humber", 10.0, controller="nope.toml"), "controller",
     BridgeflapInputError),
    (lambda: model.modal_model("humber", modes_per_family=-3), "modes_per_family",
     BridgeflapInputError),
    (lambda: model.modal_model("humber", modes_per_family=0), "modes_per_family",
     BridgeflapInputError),
    (lambda: model.flutter("humber", _S, n_modes=2.5), "n_modes", BridgeflapTypeError),
    (lambda: model.flutter("humber", _S, n_modes=True), "n_modes", BridgeflapTypeError),
    (lambda: model.flutter("humber", _S, n_modes=0), "n_modes", BridgeflapInputError),
    (lambda: model.flutter("humber", _S, n_modes=101), "n_modes", BridgeflapInputError),
    (lambda: model.flutter("humber", _S, rfa="rfa9"), "rfa", BridgeflapInputError),
    (lambda: model.flutter("humber", _S, order="diagonal"), "order", BridgeflapInputError),
    (lambda: model.flutter("humber", _S, speed_tol=-1.0), "speed_tol", BridgeflapInputError),
    (lambda: model.flutter("", _S), "bridge", BridgeflapInputError),
    (lambda: model.closed_loop_state_space("humber", _CONTROLLER, math.nan), "speed",
     BridgeflapInputError),
    (lambda: model.closed_loop_state_space("humber", _CONTROLLER, 1.0e6), "speed",
     BridgeflapInputError),
    (lambda: model.erection("humber", "1", _S, workers=0), "workers", BridgeflapInputError),
    (lambda: model.erection("humber", "1", _S, workers=10**6), "workers", BridgeflapInputError),
    (lambda: model.modal_model("humber", erection_gj_factor=-1.0), "erection_gj_factor",
     BridgeflapInputError),
    (lambda: model.mode_convergence("humber", _S, counts=(8, -2)), "counts",
     BridgeflapInputError),
    (lambda: model.buffeting("humber", "10", n_base=-3), "n_base", BridgeflapInputError),
    (lambda: design.run_batch(len, "cases", "b"), "cases", BridgeflapTypeError),
    (lambda: design.run_study(42), "config", BridgeflapTypeError),
    (lambda: design.run_doe({"bridge": "humber"}), "config", BridgeflapTypeError),
    (lambda: design.main("flutter humber"), "argv", BridgeflapTypeError),
    (lambda: model.flutter("humber", _S, nmodes=8), "flutter", BridgeflapTypeError),
    (lambda: model.modal_model(), "modal_model", BridgeflapTypeError),
    (lambda: model.pk_sweep(_SYSTEM, _S, True), "speed_tol", BridgeflapTypeError),
    (lambda: model.closed_loop_functions("model.toml"), "model", BridgeflapTypeError),
    # the do-no-harm check: every argument at the door, with the CLI's bounds
    (lambda: do_no_harm(_CONTROLLER, speed_max_m_s="abc"), "speed_max_m_s",
     BridgeflapTypeError),
    (lambda: do_no_harm(_CONTROLLER, speed_max_m_s=1e6), "speed_max_m_s",
     BridgeflapInputError),
    (lambda: do_no_harm(_CONTROLLER, n_modes=0), "n_modes", BridgeflapInputError),
    (lambda: do_no_harm(_CONTROLLER, seed=-1), "seed", BridgeflapInputError),
    (lambda: do_no_harm(_CONTROLLER, workers=True), "workers", BridgeflapTypeError),
    (lambda: do_no_harm(_CONTROLLER, screen_modes=0), "screen_modes", BridgeflapInputError),
    (lambda: do_no_harm(_CONTROLLER, sampling="lhs"), "sampling", BridgeflapInputError),
    (lambda: do_no_harm(_CONTROLLER, speeds="0:10:-1"), "speeds", BridgeflapInputError),
    (lambda: do_no_harm(_CONTROLLER, bridge=42), "bridge", BridgeflapTypeError),
    (lambda: do_no_harm("ctrl.toml"), "controller", BridgeflapInputError),  # no such file
    (lambda: do_no_harm(3.5), "controller", BridgeflapTypeError),
    # the acceptance checks: the CLI's seed bound, booleans that are bools
    (lambda: design.accept(_CONTROLLER, seed=-1), "seed", BridgeflapInputError),
    (lambda: design.accept(_CONTROLLER, seed=2 ** 32), "seed", BridgeflapInputError),
    (lambda: design.accept(_CONTROLLER, quick="no"), "quick", BridgeflapTypeError),
    (lambda: design.accept("ctrl.toml"), "controller", BridgeflapInputError),  # no such file
    (lambda: design.design(design.load_settings(), checks="robustness", quick_checks="no"),
     "quick_checks", BridgeflapTypeError),
    (lambda: design.design(design.load_settings(), check_samples=100_001), "check_samples",
     BridgeflapInputError),
]


@pytest.mark.parametrize("call, field, kind", SURVEY, ids=[f"{i}-{c[1]}"
                                                           for i, c in enumerate(SURVEY)])
def test_the_surveyed_bad_calls_are_refused(call, field, kind):
    _refused(call, field, kind)


def test_a_planted_unchecked_argument_is_found():
    # the matrix can fail: a function whose argument passes unchecked raises nothing typed
    def loose(bridge, n_modes=30):
        return int(n_modes)

    with pytest.raises(TypeError):  # a bare TypeError, not a BridgeflapError: the check fails
        _refused(lambda: loose("humber", n_modes=object()), "n_modes")


def test_a_controller_path_is_loaded(tmp_path, monkeypatch):
    # the right kind of file where a controller is expected is read, not refused
    from bridgeflap.model.aeroelastic.controller_file import as_controller

    path = model.save_controller(_CONTROLLER, tmp_path / "c.toml")
    assert as_controller(path).compensator == _CONTROLLER.compensator
    path.unlink()
