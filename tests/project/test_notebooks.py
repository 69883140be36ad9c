"""The example notebooks (runs/notebooks/*.py, jupytext percent format) execute and their own
checks hold: each ends in assertions against the CLI or an independent API path, so a notebook
that runs but computes something else fails here. They use the public API only
(``from bridgeflap import model, design``) and show their figures inline; the kernel runs
with the ``[notebook]`` extra, which the ``[test]`` one includes."""

import ast
import os
from pathlib import Path

import pytest

jupytext = pytest.importorskip("jupytext", reason="the notebooks need the [notebook] extra")
nbclient = pytest.importorskip("nbclient", reason="the notebooks need the [notebook] extra")

NOTEBOOKS = Path(__file__).resolve().parents[2] / "runs" / "notebooks"
ROOT = NOTEBOOKS.parent.parent


def _execute(name: str, tmp_path: Path):
    nb = jupytext.read(NOTEBOOKS / name)
    env = {"OPENBLAS_NUM_THREADS": "1"}  # the notebooks choose the inline backend
    old = {k: os.environ.get(k) for k in (*env, "PYTHONPATH")}
    os.environ.update(env)
    # the kernel imports this checkout (as the tests do), whatever is installed
    os.environ["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(ROOT), old["PYTHONPATH"]) if p)
    try:
        client = nbclient.NotebookClient(nb, kernel_name="python3", timeout=600,
                                         resources={"metadata": {"path": str(tmp_path)}})
        client.execute()
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    return nb


def _outputs(nb) -> str:
    """The printed text; asserts on the way that the notebook showed a figure inline and an
    HTML table of a result (the results' ``_repr_html_``)."""
    outs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    data = [o.get("data", {}) for o in outs]
    assert any("image/png" in d for d in data), "no inline figure"
    assert any("<table" in d.get("text/html", "") for d in data), "no result table"
    return "\n".join(o.get("text", "") for o in outs)


@pytest.mark.parametrize("name", ["doe_batch.py", "optimisation.py", "sensitivity_study.py"])
def test_notebooks_use_the_public_api(name):
    """Only ``from bridgeflap import model, design`` of the package, and no backend forced."""
    nb = jupytext.read(NOTEBOOKS / name)
    code = "\n".join(c.source for c in nb.cells if c.cell_type == "code")
    assert "%matplotlib inline" in code and "matplotlib.use" not in code
    tree = ast.parse("\n".join(line for line in code.splitlines()
                               if not line.startswith("%")))
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            assert node.module.split(".")[0] not in ("model", "design", "bridgeflap") or (
                node.module == "bridgeflap"
                and all(a.name in ("model", "design") for a in node.names)), node.module
        elif isinstance(node, ast.Import):
            for alias in node.names:
                assert alias.name.split(".")[0] not in ("model", "design", "bridgeflap") or \
                    alias.name == "bridgeflap", alias.name


def test_every_notebook_is_tested():
    assert sorted(p.name for p in NOTEBOOKS.glob("*.py")) == sorted(
        ["doe_batch.py", "optimisation.py", "sensitivity_study.py"])


def test_sensitivity_notebook(tmp_path):
    nb = _execute("sensitivity_study.py", tmp_path)
    assert "IFT = FD and = CLI" in _outputs(nb)


def test_doe_notebook(tmp_path):
    nb = _execute("doe_batch.py", tmp_path)
    assert "batch = API" in _outputs(nb)


@pytest.mark.slow
def test_optimisation_notebook(tmp_path):
    nb = _execute("optimisation.py", tmp_path)
    assert "closed loop stable 0-85 m/s" in _outputs(nb)
