"""A small report document rendered twice from the same data: Markdown and self-contained HTML.

:class:`Document` collects headings, paragraphs, bullet lists, tables (a
:class:`pandas.DataFrame` of already formatted strings, so that both renderings show the same
digits) and figures. :meth:`Document.markdown` writes the tables with
:meth:`pandas.DataFrame.to_markdown` (tabulate); :meth:`Document.html` writes one HTML file
with the tables from :meth:`pandas.DataFrame.to_html` and the figures inline (PNG as base64,
SVG as markup), so that it can be mailed or archived alone. The only inline markup is
```code``` spans.
"""

from __future__ import annotations

import base64
import html
import re
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

__all__ = ["Document"]

_CSS = """body{font-family:system-ui,sans-serif;max-width:70rem;margin:2rem auto;padding:0 1rem;
line-height:1.45;color:#222}table{border-collapse:collapse;margin:0.6rem 0;font-size:0.9rem}
th,td{border:1px solid #bbb;padding:0.2rem 0.5rem;text-align:left}th{background:#eee}
code{background:#f3f3f3;padding:0 0.2rem}img,svg{max-width:100%;height:auto}
figure{margin:1rem 0}figcaption{font-size:0.9rem;color:#444}"""


def _inline(text: str) -> str:
    """HTML of one paragraph: escaped, with ```code``` spans."""
    return re.sub(r"`([^`]+)`", r"<code>\1</code>", html.escape(text, quote=False))


@dataclass
class Document:
    """Blocks of a report, in order (see the module docstring)."""

    blocks: list = field(default_factory=list)

    def heading(self, level: int, text: str) -> None:
        """A heading of ``level`` 1-4."""
        self.blocks.append(("h", level, text))

    def paragraph(self, text: str) -> None:
        """One paragraph (``code`` spans allowed)."""
        self.blocks.append(("p", text))

    def items(self, items) -> None:
        """A bullet list."""
        self.blocks.append(("ul", list(items)))

    def table(self, rows, columns) -> pd.DataFrame:
        """A table of formatted strings: ``rows`` (sequences) under ``columns``; returned."""
        df = pd.DataFrame([[str(c) for c in r] for r in rows], columns=list(columns))
        self.blocks.append(("table", df))
        return df

    def figure(self, path: str, caption: str = "", alt: str = "") -> None:
        """A figure file (relative to the report folder) and its caption."""
        self.blocks.append(("fig", path, caption, alt or Path(path).stem))

    def markdown(self) -> str:
        """The Markdown rendering."""
        out = []
        for b in self.blocks:
            kind = b[0]
            if kind == "h":
                out.append(f"{'#' * b[1]} {b[2]}")
            elif kind == "p":
                out.append(b[1])
            elif kind == "ul":
                out.append("\n".join(f"- {x}" for x in b[1]))
            elif kind == "table":
                out.append(b[1].to_markdown(index=False, disable_numparse=True))
            elif kind == "fig":
                out.append(f"![{b[3]}]({b[1]})" + (f"\n\n{b[2]}" if b[2] else ""))
        return "\n\n".join(out) + "\n"

    def html(self, folder: str | Path, title: str = "report") -> str:
        """The self-contained HTML rendering; figures are read from ``folder``."""
        folder = Path(folder)
        body = []
        for b in self.blocks:
            kind = b[0]
            if kind == "h":
                body.append(f"<h{b[1]}>{_inline(b[2])}</h{b[1]}>")
            elif kind == "p":
                body.append(f"<p>{_inline(b[1])}</p>")
            elif kind == "ul":
                body.append("<ul>" + "".join(f"<li>{_inline(x)}</li>" for x in b[1]) + "</ul>")
            elif kind == "table":
                body.append(b[1].to_html(index=False, border=0, escape=True))
            elif kind == "fig":
                body.append(f"<figure>{_embed(folder / b[1], b[3])}"
                            + (f"<figcaption>{_inline(b[2])}</figcaption>" if b[2] else "")
                            + "</figure>")
        return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
                f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>\n"
                + "\n".join(body) + "\n</body></html>\n")


def _embed(path: Path, alt: str) -> str:
    """A figure file as inline HTML (PNG base64, SVG markup), or a note when it is missing."""
    if not path.is_file():
        return f"<p>(figure {html.escape(path.name)} missing)</p>"
    if path.suffix.lower() == ".svg":
        text = path.read_text(encoding="utf-8")
        return text[text.find("<svg"):]
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    mime = "image/png" if path.suffix.lower() == ".png" else "application/octet-stream"
    return f"<img alt=\"{html.escape(alt)}\" src=\"data:{mime};base64,{data}\">"
