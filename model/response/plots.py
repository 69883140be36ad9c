"""Figures of the buffeting response: RMS on the main span against the wind speed.

:meth:`bridgeflap.model.response.buffeting.BuffetingResult.plot` calls :func:`buffeting_panels`
(matplotlib imported lazily, nothing here calls ``plt.show()``).

May import: the foundation (:mod:`bridgeflap.model.axes`) only.
"""

from __future__ import annotations

import numpy as np

from bridgeflap.model.axes import new_axes

__all__ = ["buffeting_panels"]


#: [mm] per [m] and [deg] per [rad]: the figures' units (the results stay in m and rad)
MM_PER_M = 1000.0
DEG_PER_RAD = float(np.degrees(1.0))


def buffeting_panels(curves, axes=None, log: bool = False, title: str = ""):
    """Vertical (left, ``max sigma_z`` [mm], with ``sigma_z / 2b`` [-] of the paper's Fig. 4 on
    a right-hand axis when every curve has the same deck width) and torsional (right,
    ``max sigma_alpha`` [deg]) RMS on the main span against the wind speed.

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
        plot(res.speeds, MM_PER_M * np.asarray(res.rms_vertical, dtype=float), styles[k % 4],
             ms=4, label=lab)
        plot = ax1.semilogy if log else ax1.plot
        plot(res.speeds, DEG_PER_RAD * np.asarray(res.rms_torsion, dtype=float), styles[k % 4],
             ms=4, label=lab)
        bad = np.array([s == "unstable" for s in res.status])
        for ax in (ax0, ax1):
            for i, u in enumerate(res.speeds[bad]):
                ax.axvline(u, color="r", alpha=0.15,
                           label=f"unstable ({lab})" if i == 0 else None)
    ax0.set_ylabel("max σ_z on the main span [mm]")
    ax1.set_ylabel("max σ_α on the main span [deg]")
    widths = {float(res.deck_width_m) for res in curves.values()}
    if len(widths) == 1 and next(iter(widths)) > 0:  # the paper's ordinate, for comparison
        scale = MM_PER_M * next(iter(widths))
        sec = ax0.secondary_yaxis("right", functions=(lambda z: z / scale,
                                                      lambda r: r * scale))
        sec.set_ylabel("σ_z / (2b) [-]", fontsize=8)
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
