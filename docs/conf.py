"""Sphinx configuration of the bridgeflap documentation.

Build (what ``.ci/run`` runs; warnings are errors, so a renamed function breaks the docs build
rather than a reader's script)::

    pip install ".[docs]"
    sphinx-build -W --keep-going -b html docs docs/_build/html

The tutorials are MyST-NB notebooks (``docs/tutorials/*.md``) executed at every build on cheap
settings; the API reference is generated from the packages' ``__all__`` by autosummary, the CLI
reference from the real argument parser by sphinx-argparse.
"""

from __future__ import annotations

import importlib
import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent

# The import names of the package, in one place: the API pages are generated from these.
PACKAGES = ("bridgeflap.model", "bridgeflap.design")

# The executed pages' kernels draw with the inline backend, so that every ``x.plot();`` cell
# shows its figure (an inherited ``MPLBACKEND=Agg``, as CI exports, would draw nowhere: no
# image on the page). The build itself draws nothing; _ext/figure_check.py fails the build
# when a cell that calls plot() shows no figure.
os.environ["MPLBACKEND"] = "module://matplotlib_inline.backend_inline"
for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

_dist = importlib.import_module("importlib.metadata")
try:
    release = _dist.version("bridgeflap")
except _dist.PackageNotFoundError:  # a checkout that is not installed
    sys.path.insert(0, str(ROOT))
    release = "unknown"
version = release

project = "bridgeflap"
author = "The bridgeflap developers"
copyright = "2026, The bridgeflap developers"

sys.path.insert(0, str(DOCS / "_ext"))

extensions = [
    "figure_check",  # _ext/figure_check.py: a cell that calls plot() must show a figure
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinxarg.ext",
    "myst_nb",  # also provides myst-parser for the Markdown pages
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"
exclude_patterns = ["_build", "_ext", "README.md", "**/.ipynb_checkpoints", "jupyter_execute"]
templates_path = ["_templates"]

# --- MyST and the executed tutorials -----------------------------------------------------------
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist", "attrs_inline"]
myst_heading_anchors = 4  # "page.md#a-heading" links, as the code's docstrings use them
nb_execution_mode = "force"  # every build runs every tutorial: the docs prove the code
nb_execution_timeout = 600
nb_execution_raise_on_error = True  # a failing cell fails the build
nb_execution_show_tb = True
nb_merge_streams = True
nb_execution_in_temp = True  # tutorials write their run folders into a temporary folder
# a cell's Markdown output (e.g. the table of dotted input paths on the bridge-file page) is
# parsed as MyST, which has tables; CommonMark, the default, would show the raw pipes
nb_render_markdown_format = "myst"

# --- API reference ------------------------------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = True
autodoc_typehints = "none"  # numpydoc's Parameters sections carry the types
# class pages list their methods, one page each: _templates/autosummary/class.rst
autodoc_default_options = {"members": False}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()  # style is reviewed in the code, not in the build
numpydoc_xref_param_type = False

# Markdown pages of the repository link to source files (``../model/...``) that are not pages
# of the site: those links stay plain text on the site and do not warn.
# sphinx-argparse's domain cannot resolve MyST's "any" references (it says so once per build).
suppress_warnings = ["myst.xref_missing", "myst.domains"]

# --- HTML ---------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"bridgeflap {release}"
html_static_path: list[str] = []  # no static files of our own
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "header_links_before_dropdown": 6,
    "secondary_sidebar_items": ["page-toc"],
}
html_show_sourcelink = False


def _api_pages() -> None:
    """``reference/api/<package>.rst``: one autosummary table of each package's ``__all__``."""
    out = DOCS / "reference" / "api"
    out.mkdir(parents=True, exist_ok=True)
    for name in PACKAGES:
        module = importlib.import_module(name)
        doc = (module.__doc__ or "").strip().splitlines()[0]
        names = sorted(module.__all__, key=str.lower)
        functions, classes, data = [], [], []
        for attr in names:
            obj = getattr(module, attr)
            if isinstance(obj, type):
                classes.append(attr)
            elif callable(obj):
                functions.append(attr)
            else:
                data.append(attr)
        lines = [f"``{name}``", "=" * (len(name) + 4), "", doc, "",
                 f".. currentmodule:: {name}", ""]
        for title, group in (("Functions", functions), ("Classes", classes),
                             ("Constants", data)):
            if not group:
                continue
            lines += [title, "-" * len(title), "", ".. autosummary::", "   :toctree: generated",
                      "   :nosignatures:", ""]
            lines += [f"   {attr}" for attr in group] + [""]
        text = "\n".join(lines)
        path = out / f"{name.rpartition('.')[2]}.rst"
        if not path.exists() or path.read_text() != text:
            path.write_text(text)



_api_pages()  # at configuration time: autosummary reads the pages when the build starts
