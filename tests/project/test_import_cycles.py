"""No import cycle in ``model`` and ``design``.

Every import counts: a module-level one and a lazy one inside a function (a lazy import still
ties the two modules together; it only hides the cycle from the interpreter). The graph is read
from the source with :mod:`ast`, so the test imports nothing and takes well under a second.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("model", "design")



def _modules() -> dict[str, Path]:
    out = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            out[name] = path
    return out


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _runtime_nodes(tree: ast.AST):
    """Every node of ``tree`` except the bodies of ``if TYPE_CHECKING:`` blocks: an import
    there is read by type checkers only and never runs, so it ties no module to another (its
    ``else`` branch does run and is walked)."""
    todo = [tree]
    while todo:
        node = todo.pop()
        yield node
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            todo.extend(node.orelse)
            continue
        todo.extend(ast.iter_child_nodes(node))


def import_graph() -> dict[str, set[str]]:
    """module -> the package modules it imports (top level or lazy). Modules are named by
    their source folders (``model.aero.rfa`` for ``bridgeflap.model.aero.rfa``). A package's own
    ``__init__`` (the lazy public face) is not a node: importing ``model`` names nothing."""
    mods = _modules()
    graph: dict[str, set[str]] = {m: set() for m in mods if m not in PACKAGES}
    for name in graph:
        for node in _runtime_nodes(ast.parse(mods[name].read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            else:
                continue
            targets = [t.removeprefix("bridgeflap.") for t in targets]
            graph[name].update(t for t in targets if t in graph and t != name)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[frozenset[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[frozenset[str]] = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = set()
                    while True:
                        x = stack.pop()
                        on.discard(x)
                        comp.add(x)
                        if x == v:
                            break
                    if len(comp) > 1:
                        out.append(frozenset(comp))
            elif w not in index:
                index[w] = low[w] = len(index)
                stack.append(w)
                on.add(w)
                work.append((w, iter(sorted(graph[w]))))
            elif w in on:
                low[v] = min(low[v], index[w])
    return out


def test_the_walker_finds_a_planted_cycle():
    # the test can fail: a three-module ring and a two-module one are found, a chain is not
    g = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"e"}, "e": {"d"}, "f": {"a"}, "g": set()}
    assert sorted(sorted(c) for c in cycles(g)) == [["a", "b", "c"], ["d", "e"]]


def test_the_walker_sees_lazy_imports():
    graph = import_graph()
    # design.cli.main imports its commands inside functions only; the walker must see those edges
    edges = graph["design.cli.main"]
    assert any(t.startswith("design.cli.") for t in edges), edges


def test_the_walker_skips_type_checking_imports():
    # design.studies.report names design.studies.study's result type under TYPE_CHECKING only: no
    # edge (the study imports the report at run time); an import in the else branch does count
    tree = ast.parse("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import a\n"
                     "else:\n    import b\nimport c\n")
    names = {a.name for n in _runtime_nodes(tree) if isinstance(n, ast.Import) for a in n.names}
    assert names == {"b", "c"}
    assert "design.studies.study" not in import_graph()["design.studies.report"]


def test_no_import_cycle():
    # none anywhere (model/ had one of 21 modules, design/ 8, one of 17);
    # each was cut by moving a shared concept into a module of its own, not by hiding an edge
    found = [sorted(c) for c in cycles(import_graph())]
    assert not found, f"import cycles: {found}"


def test_model_does_not_import_design():
    # the layering rule: model/ is the physics, design/ builds on it (optimisation, studies,
    # the CLI); an import from model/ into design/ would tie the physics to its users
    graph = import_graph()
    up = sorted((m, t) for m, ts in graph.items() if m.startswith("model.")
                for t in ts if t.startswith("design."))
    assert not up, up
