"""The paper's Fig. 5 of the report: closed-loop root locus over the open loop and buffeting with
and without the flaps.

:func:`bridgeflap.design.studies.analyses.fig5` (the report's figure) calls it (matplotlib imported
lazily); speeds in m/s. The figures of a compensator design (Bode plot, margins, flap layout)
are in :mod:`bridgeflap.design.control.results.figures`, the Morris plane of the global sensitivity
study in :mod:`bridgeflap.design.sensitivity.figures`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["fig5"]


def _new(nrows=1, ncols=1, figsize=(6, 4.5), **kw):
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(nrows, ncols, figsize=figsize, layout="constrained", **kw)
    return ax


def _buffeting_line(ax, u, y, style, label):
    y = np.asarray(y, dtype=float)
    ax.semilogy(u, y, style, ms=3, label=label)


def fig5(sweep_cl, sweep_ol, ol_buffeting, cl_buffeting, controller,
         open_loop_flutter_m_s: float | None = None, model_text: str = "",
         status: str | None = None):
    """The paper's Fig. 5: closed-loop root locus over the open loop (left), vertical (middle) and
    torsional (right) buffeting with and without the flaps; the open-loop flutter speed
    marked is ``open_loop_flutter_m_s`` (the design result's), else ``sweep_ol``'s."""
    from bridgeflap.model.stability.plots import root_locus
    from bridgeflap.model.stability.tracking import CONVERGED

    axes = _new(1, 3, figsize=(18, 5))
    ax0, ax1, ax2 = axes
    # the closed loop's first crossing (flutter or divergence); "stable" only when neither
    # crosses on the grid
    found = [(c.speed, name) for name, c in (("flutter", sweep_cl.flutter),
                                              ("divergence", getattr(sweep_cl, "divergence",
                                                                     None)))
             if c is not None and c.status == CONVERGED]
    fl = (f"closed-loop {min(found)[1]} {min(found)[0]:.1f} m/s" if found
          else f"closed loop stable {sweep_cl.speeds[0]:g}-{sweep_cl.speeds[-1]:g} m/s")
    if status is not None and status != "converged":
        fl += f" (design {status}: not usable)"
    root_locus(sweep_cl, ax0, title=f"{controller.n_flaps} flap pairs: {fl}",
               reference=sweep_ol)
    if open_loop_flutter_m_s is None and sweep_ol.flutter.status == CONVERGED:
        open_loop_flutter_m_s = sweep_ol.flutter.speed
    for ax, key, scale, ylabel in (
            (ax1, "rms_vertical", 1000.0, "max σ_z on the main span [mm]"),
            (ax2, "rms_torsion", np.degrees(1.0), "max σ_α on the main span [deg]")):
        _buffeting_line(ax, ol_buffeting.speeds, scale * getattr(ol_buffeting, key), "k--o",
                        "open loop")
        _buffeting_line(ax, cl_buffeting.speeds, scale * getattr(cl_buffeting, key), "b-o",
                        "closed loop")
        if open_loop_flutter_m_s is not None and np.isfinite(open_loop_flutter_m_s):
            ax.axvline(open_loop_flutter_m_s, color="r", ls=":", lw=1,
                       label=f"open-loop flutter {open_loop_flutter_m_s:.2f} m/s")
        ax.set_xlabel("mean wind speed U [m/s]")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8, loc="lower right")
        ax.set_xlim(0, max(cl_buffeting.speeds.max(), ol_buffeting.speeds.max()) + 2)
    ax1.set_title("buffeting, vertical (open loop NaN beyond its flutter)", fontsize=9)
    ax2.set_title("buffeting, torsion", fontsize=9)
    if model_text:
        ax0.figure.suptitle(model_text, fontsize=10)
    return ax0.figure
