"""Axis helpers shared by the figure modules of model/ (a foundation module).

:func:`new_axes` opens a figure, :func:`data_limits` gives axis limits that enclose every
finite value (nothing is clipped). The figures themselves live with their concept:
mode shapes in :mod:`model.structure.plots`, root locus and V-g/V-f in
:mod:`model.stability.plots`, buffeting in :mod:`model.response.plots`.

May import: numpy and matplotlib (lazily, inside :func:`new_axes`) only -- nothing of
model/'s subpackages, so every layer may use it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["data_limits", "new_axes"]


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
