"""Numbers as the text output shows them: a speed [m/s] or a number with its unit, a missing
value (``None``/NaN) as a word, never "nan".

Used by the command line (:mod:`bridgeflap.design.cli.common` serves them to the commands) and by
the text of the design checks (:mod:`bridgeflap.design.control.review.checks`).
"""

from __future__ import annotations

__all__ = ["number_text", "speed_text"]


def number_text(x, fmt, unit="", none="-") -> str:
    """``x`` formatted with ``fmt`` (e.g. ``".4f"``) and ``unit`` for the text output;
    ``None``/NaN as ``none``."""
    return none if x is None or x != x else f"{float(x):{fmt}}{unit}"


def speed_text(u, digits=2, none="none on the grid") -> str:
    """A speed [m/s] for the text output with ``digits`` decimals; ``None``/NaN (not found)
    as ``none``, never "nan m/s"."""
    return none if u is None or u != u else f"{float(u):.{int(digits)}f} m/s"
