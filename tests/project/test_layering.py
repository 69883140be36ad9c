"""The layering of the subpackages: each may import only itself and the
layers below it, so the architecture reads bottom-up and no cycle can form between rooms.

model/ (physics), bottom to top:

* ``model`` foundation -- the top-level modules ``errors``, ``lazy``, ``results``,
  ``vocabulary``, ``grid``, ``workers``, ``progress``, ``spectrum``, ``spectral``, ``axes``:
  typed errors, the lazy public face, result records, the API vocabulary, speed grids, worker
  processes, the elapsed/time-left text of progress lines, eigenvalue tools, the LTI
  random-response engine, the axis helpers of the figures;
* ``model.aero`` -- Theodorsen, RFA, strip loads and their structural basis, flutter
  derivatives, quasi-steady loads, wind and turbulence (no bridge in sight);
* ``model.structure`` -- the bridge definition and its loader, Irvine cables, FE, modes,
  Ritz projection, imported modal models (these carry flutter-derivative tables: aero below);
* ``model.aeroelastic`` -- the one assembly, the state space A(U), flaps, compensator, plant,
  the named CasADi functions;
* ``model.stability`` -- sweeps, branch tracking, Hopf/Newton, p-k, static divergence, mode
  convergence, flutter mode shapes;
* ``model.response`` -- buffeting and the spectral engine, time-domain checks;
* ``model.analysis`` -- the facade of whole-bridge analyses;
* ``model.cases`` -- the built-in reference cases (2-D sections, IABSE, RFA flat plates,
  measured Humber frequencies), which may use everything.

design/ (optimisation, studies, CLI) may import any of model/, and, bottom to top:
``design.io`` < ``design.batch`` < ``design.control`` < ``design.sensitivity`` <
``design.assessment`` < ``design.studies`` < ``design.cli``.

``design.control`` is itself in rooms, layers of their own between ``design.batch`` and
``design.sensitivity``, bottom to top:

* ``design.control`` foundation -- the top-level modules ``settings`` and ``uncertainty``: the
  settings card and the stated uncertainty set;
* ``design.control.results`` -- the records, the design result, its figures and plots;
* ``design.control.formulation`` -- the design problem as an NLP: model, plant, constraints and
  terms, cutting planes, the dense check;
* ``design.control.review`` -- checks and reports around a solved design, the flap count;
* ``design.control.solve`` -- scenarios, pair failure, one start of the multistart design;
* ``design.control.search`` -- the layout search, the critical-speed design, the driver.

The graph is the one of :mod:`test_import_cycles` (lazy imports count).
"""

from __future__ import annotations

import pytest
from test_import_cycles import import_graph

MODEL_LAYERS = ("model", "model.aero", "model.structure", "model.aeroelastic", "model.stability",
                "model.response", "model.analysis", "model.cases")
CONTROL_LAYERS = ("design.control", "design.control.results", "design.control.formulation",
                  "design.control.review", "design.control.solve", "design.control.search")
DESIGN_LAYERS = ("design.io", "design.batch", *CONTROL_LAYERS, "design.sensitivity",
                 "design.assessment", "design.studies", "design.cli")
RANK = {name: i for i, name in enumerate(MODEL_LAYERS + DESIGN_LAYERS)}


def layer(module: str) -> str:
    """The room of ``module``: its subpackage (a room of ``design.control`` when it is in one),
    or the foundation/facade of ``model`` or of ``design.control``."""
    parts = module.split(".")
    if ".".join(parts[:3]) in RANK:  # a room of design.control (or its __init__)
        return ".".join(parts[:3])
    if parts[:2] == ["design", "control"] and len(parts) > 3:
        raise AssertionError(f"{module} is in no layer: add its room to CONTROL_LAYERS")
    if ".".join(parts[:2]) in RANK:
        return ".".join(parts[:2])
    if parts[0] == "model":
        return "model"
    if parts[:2] == ["model", "bridges"]:
        return "model"
    raise AssertionError(f"{module} is in no layer: add it to a subpackage")


def violations(graph=None) -> list[tuple[str, str]]:
    graph = import_graph() if graph is None else graph
    out = []
    for mod, targets in graph.items():
        if mod.startswith("model.bridges"):
            continue
        for t in targets:
            if RANK[layer(t)] > RANK[layer(mod)]:
                out.append((mod, t))
    return sorted(out)


def test_every_module_has_a_layer():
    for mod in import_graph():
        if not mod.startswith("model.bridges"):
            assert layer(mod) in RANK


def test_a_planted_upward_import_is_found():
    # the test can fail: an aero module importing the structure is an upward edge
    g = {"model.aero.strips": {"model.structure.fe"}, "model.structure.fe": {"model.errors"}}
    assert violations(g) == [("model.aero.strips", "model.structure.fe")]


def test_a_planted_upward_import_inside_control_is_found():
    # the rooms of design.control are layers of their own: the formulation importing the
    # driver of the search room is an upward edge, the search room importing the NLP is not
    g = {"design.control.formulation.nlp": {"design.control.search.driver"},
         "design.control.search.driver": {"design.control.formulation.nlp",
                                          "design.control.settings"},
         "design.control.settings": {"design.io.api_args"}}
    assert violations(g) == [("design.control.formulation.nlp", "design.control.search.driver")]
    # and the foundation (top-level modules) sits below every room of control
    assert violations({"design.control.settings": {"design.control.results.records"}}) == [
        ("design.control.settings", "design.control.results.records")]


def test_the_control_rooms_are_ordered_inside_design():
    # between design.batch and design.sensitivity, the foundation first
    order = [RANK[name] for name in ("design.batch", *CONTROL_LAYERS, "design.sensitivity")]
    assert order == sorted(order) and len(set(order)) == len(order)
    assert layer("design.control.settings") == "design.control"
    assert layer("design.control") == "design.control"
    assert layer("design.control.solve.start") == "design.control.solve"
    assert layer("design.control.solve") == "design.control.solve"
    with pytest.raises(AssertionError, match="in no layer"):
        layer("design.control.new_room.module")  # a room that is no layer yet


def test_no_room_imports_a_room_above_it():
    bad = violations()
    assert not bad, "upward imports (module -> module above its layer): " + ", ".join(
        f"{a} -> {b}" for a, b in bad)


if __name__ == "__main__":  # python tests/project/test_layering.py: the list to work through
    for a, b in violations():
        print(f"{layer(a):20} {a:40} -> {b}")
