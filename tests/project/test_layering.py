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

The graph is the one of :mod:`test_import_cycles` (lazy imports count).
"""

from __future__ import annotations

from test_import_cycles import import_graph

MODEL_LAYERS = ("model", "model.aero", "model.structure", "model.aeroelastic", "model.stability",
                "model.response", "model.analysis", "model.cases")
DESIGN_LAYERS = ("design.io", "design.batch", "design.control", "design.sensitivity",
                 "design.assessment", "design.studies", "design.cli")
RANK = {name: i for i, name in enumerate(MODEL_LAYERS + DESIGN_LAYERS)}


def layer(module: str) -> str:
    """The room of ``module``: its subpackage, or the foundation/facade of ``model``."""
    parts = module.split(".")
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


def test_no_room_imports_a_room_above_it():
    bad = violations()
    assert not bad, "upward imports (module -> module above its layer): " + ", ".join(
        f"{a} -> {b}" for a, b in bad)


if __name__ == "__main__":  # python tests/project/test_layering.py: the list to work through
    for a, b in violations():
        print(f"{layer(a):20} {a:40} -> {b}")
