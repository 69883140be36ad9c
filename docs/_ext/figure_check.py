"""A docs check: every executed code cell that calls ``plot`` shows a figure.

A tutorial or how-to cell such as ``res.plot();`` that renders as code with no image is an
error of the build (Sphinx warning, and ``-W`` makes warnings errors): the usual cause is a
kernel whose matplotlib backend draws nowhere (``MPLBACKEND=Agg`` inherited from the shell).

The check walks the resolved doctree of every page that MyST-NB executed: a code cell
(``nb_element="cell_code"``) whose source calls ``.plot(`` or ``.plot_<name>(`` (or
``plot_<name>(``/``plot(`` as a function) must hold at least one image in its output. At the
end of the build it also counts the ``<img`` tags of each such page in the written HTML, so a
page that lost its images on the way to HTML fails too.
"""

from __future__ import annotations

import re
from pathlib import Path

from docutils import nodes
from sphinx.util import logging

LOGGER = logging.getLogger(__name__)

#: A call of a plotting method or function: ``x.plot(``, ``x.plot_bode(``, ``plot(``.
PLOT_CALL = re.compile(r"(?<![\w])(?:\w+\.)*plot(?:_\w+)?\s*\(")

_ENV_KEY = "figure_check_pages"


def _element(node) -> str | None:
    return node.get("nb_element") if isinstance(node, nodes.container) else None


def plot_cells(doctree):
    """``(source, image_count)`` of every executed code cell of ``doctree`` that calls plot."""
    out = []
    for cell in doctree.findall(nodes.container):
        if _element(cell) != "cell_code":
            continue
        source = "".join(n.astext() for n in cell.findall(nodes.literal_block)
                         if _element(n.parent) == "cell_code_source")
        if not PLOT_CALL.search(source):
            continue
        images = sum(1 for out_node in cell.findall(nodes.container)
                     if _element(out_node) == "cell_code_output"
                     for _ in out_node.findall(nodes.image))
        out.append((source.strip(), images))
    return out


def _check_doctree(app, doctree, docname) -> None:
    cells = plot_cells(doctree)
    if not cells:
        return
    pages = getattr(app.env, _ENV_KEY, {})
    pages[docname] = len(cells)
    setattr(app.env, _ENV_KEY, pages)
    for source, images in cells:
        if images == 0:
            first = source.splitlines()[0] if source else ""
            LOGGER.warning("a code cell that calls plot() shows no figure: %r "
                           "(is the kernel's matplotlib backend inline?)", first,
                           location=docname, type="figure_check", subtype="no_image")


def _check_html(app, exception) -> None:
    if exception is not None or app.builder.format != "html":
        return
    for docname, count in sorted(getattr(app.env, _ENV_KEY, {}).items()):
        path = Path(app.outdir) / f"{docname}.html"
        if not path.is_file():
            continue
        found = path.read_text(encoding="utf-8").count("<img")
        if found < count:
            LOGGER.warning("%d code cell(s) call plot() but the page has %d <img> tags",
                           count, found, location=docname, type="figure_check",
                           subtype="no_image")


def setup(app):
    """Register the check with Sphinx."""
    app.connect("doctree-resolved", _check_doctree)
    app.connect("build-finished", _check_html)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
