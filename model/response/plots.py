"""Figures of the buffeting response: RMS on the main span against the wind speed.

:meth:`bridgeflap.model.response.buffeting.BuffetingResult.plot` calls :func:`buffeting_panels`
(matplotlib imported lazily, nothing here calls ``plt.show()``).

May import: the foundation (:mod:`bridgeflap.model.axes`) only.
"""

from __future__ import annotations

import numpy as np

from bridgeflap.model.axes import new_axes

__all__ = ["buffeting_panels"]


def buffeting_panels(curves, axes=None, log: bool = False, title: str = ""):
    """Vertical (left, ``max sigma_z / 2b``) and torsional (right, ``max sigma_alpha``
    [deg]) RMS on the main span against the wind speed.

    ``curves`` maps a label to a :class:`~bridgeflap.model.response.buffeting.BuffetingResult` (or
    one result); unstable speeds are NaN and leave a gap, nothing is clipped.
    """
    if not isinstance(curves, dict):
        curves = {None: curves}
    ax0, ax1 = axes if axes is not None else new_axes(1, 2, figsize=(11, 4.2))
    styles = ("C0-o", "C3--s", "C2-.^", "C4:v")
    for k, (label, res) in enumerate(curves.items()):
        lab = label or (f"{res.inputs.get('spectrum', '')}, {res.inputs.get('admittance', '')}"
                        f", c = {res.inputs.get('coherence_decay', float('nan')):g}")
        plot = ax0.semilogy if log else ax0.plot
        plot(res.speeds, res.rms_vertical_over_width, styles[k % 4], ms=4, label=lab)
        plot = ax1.semilogy if log else ax1.plot
        plot(res.speeds, np.degrees(res.rms_torsion), styles[k % 4], ms=4, label=lab)
        bad = np.array([s == "unstable" for s in res.status])
        for ax in (ax0, ax1):
            for i, u in enumerate(res.speeds[bad]):
                ax.axvline(u, color="r", alpha=0.15,
                           label=f"unstable ({lab})" if i == 0 else None)
    ax0.set_ylabel("max σ_z / (2b) on the main span [-]")
    ax1.set_ylabel("max σ_α on the main span [deg]")
    ax0.set_title("vertical", fontsize=9)
    ax1.set_title("torsion", fontsize=9)
    for ax in (ax0, ax1):
        ax.set_xlabel("mean wind speed U [m/s]")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
        if not log:
            ax.set_ylim(bottom=0)
    if title:
        ax0.figure.suptitle(title, fontsize=10)
    return ax0, ax1
