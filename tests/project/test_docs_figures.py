"""The docs check that a page calling ``plot()`` shows a figure (docs/_ext/figure_check.py).

A tiny Sphinx project with one executed MyST-NB page is built twice: once with a cell whose
figure goes nowhere (the Agg backend, as an inherited ``MPLBACKEND=Agg`` gave every tutorial:
code and no image), which must fail the build under ``-W``; once with the inline backend, as
docs/conf.py sets it, which must pass with the image in the HTML. Each build starts one
kernel (a few seconds).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("myst_nb")
pytest.importorskip("sphinx")

ROOT = Path(__file__).resolve().parents[2]
EXT = ROOT / "docs" / "_ext"

CONF = f"""
import os, sys
sys.path.insert(0, {str(EXT)!r})
extensions = ["figure_check", "myst_nb"]
nb_execution_mode = "force"
nb_execution_raise_on_error = True
nb_execution_timeout = 120
os.environ["MPLBACKEND"] = {{backend!r}}
"""

PAGE = """---
file_format: mystnb
kernelspec:
  name: python3
  display_name: Python 3
---

# A page

```{code-cell} ipython3
import matplotlib.pyplot as plt

class Result:
    def plot(self):
        fig, ax = plt.subplots()
        ax.plot([0, 1], [1, 0])
        return fig

Result().plot();
```
"""


def _build(tmp_path: Path, backend: str) -> tuple[subprocess.CompletedProcess, Path]:
    src = tmp_path / backend.rpartition(".")[2] / "src"
    src.mkdir(parents=True)
    (src / "conf.py").write_text(CONF.format(backend=backend))
    (src / "index.md").write_text(PAGE)
    out = src.parent / "html"
    env = {**os.environ, "PYDEVD_DISABLE_FILE_VALIDATION": "1"}
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b",
                           "html", str(src), str(out)], capture_output=True, text=True,
                          env=env, timeout=300)
    return proc, out


def test_a_plot_cell_without_an_image_fails_the_build(tmp_path):
    proc, _ = _build(tmp_path, "agg")
    assert proc.returncode != 0
    assert "calls plot() shows no figure" in proc.stderr


def test_a_plot_cell_with_its_image_passes(tmp_path):
    proc, out = _build(tmp_path, "module://matplotlib_inline.backend_inline")
    assert proc.returncode == 0, proc.stderr
    assert (out / "index.html").read_text().count("<img") >= 1
