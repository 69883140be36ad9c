"""Axis helpers shared by the figure modules of model/ (a foundation module).

:func:`new_axes` opens a figure, :func:`axes_or_new` draws on given axes or a new figure,
:func:`data_limits` gives axis limits that enclose every finite value (nothing is clipped),
:func:`number_or_nan` reads a table cell as a number to plot, :func:`ring_points` rings and names
points that need a second look (hybrid erection stages). The figures themselves live
with their concept: mode shapes in :mod:`bridgeflap.model.structure.plots`, root locus and V-g/V-f
in
:mod:`bridgeflap.model.stability.plots`, buffeting in :mod:`bridgeflap.model.response.plots`, the
design's in design/.

May import: numpy and matplotlib (lazily, inside :func:`new_axes`) only -- nothing of
model/'s subpackages, so every layer may use it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["axes_or_new", "data_limits", "new_axes", "number_or_nan", "ring_points"]


def new_axes(nrows=1, ncols=1, figsize=(6, 4.5), **kw):
    """A new figure (constrained layout) and its axes, as :func:`matplotlib.pyplot.subplots`."""
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(nrows, ncols, figsize=figsize, layout="constrained", **kw)
    return ax


def data_limits(values, pad: float = 0.05) -> tuple[float, float]:
    """``(low, high)`` enclosing every finite value with ``pad`` of the range either side."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return (-1.0, 1.0)
    lo, hi = float(v.min()), float(v.max())
    d = (hi - lo) or max(abs(hi), 1.0)
    return lo - pad * d, hi + pad * d


def axes_or_new(ax=None, figsize=(6.5, 4.0)):
    """``ax`` itself, or the axes of a new figure (constrained layout) of ``figsize`` [in]."""
    return new_axes(figsize=figsize) if ax is None else ax


def number_or_nan(v) -> float:
    """``v`` as a float; NaN for None, text or a flag (a table cell that is not a number)."""
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else float("nan")


def ring_points(ax, x, y, names, label: str):
    """Red rings around the points ``(x, y)``, each named (``names``) below and above in turn
    so that neighbours do not overlap; one legend entry ``label``. Nothing when no point."""
    if len(x) == 0:
        return
    ax.plot(x, y, "o", ms=13, mfc="none", mec="C3", mew=1.5, zorder=4, label=label)
    for k, (xi, yi, name) in enumerate(zip(x, y, names, strict=True)):
        ax.annotate(name, (xi, yi), xytext=(0, -15 if k % 2 == 0 else 9),
                    textcoords="offset points", ha="center", fontsize=6, color="C3")
