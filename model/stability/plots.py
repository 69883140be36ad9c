"""Figures of a stability sweep: root locus, V-g / V-f, and both in one figure; the critical
speeds of the erection stages (the paper's Fig. 3 right).

:class:`bridgeflap.model.stability.sweeps.StabilitySweep` keeps thin ``plot`` methods that call
these functions (matplotlib imported lazily, nothing here calls ``plt.show()``). Units are fixed per
kind of axis so that figures can be read side by side:

* root locus: ``Re(lambda)`` and ``Im(lambda)``, both in 1/s (rad/s for the imaginary part),
  with rays of constant damping ratio and a secondary frequency axis in Hz;
* V-g / V-f: damping ratio [%] and frequency [Hz] against the wind speed [m/s]; the axes
  enclose every tracked branch (nothing is clipped: a branch that runs far negative past
  flutter stays on the axis).

May import: the foundation (:mod:`bridgeflap.model.axes`) and bridgeflap.model.stability's result
vocabulary (:mod:`bridgeflap.model.stability.tracking`), nothing above bridgeflap.model.stability.
"""

from __future__ import annotations

import numpy as np

from bridgeflap.model.axes import axes_or_new, data_limits, new_axes, number_or_nan, ring_points

__all__ = ["ZETA_RAYS", "branch_styles", "erection_speeds", "root_locus", "stability_panels",
           "vg_vf"]

#: constant damping ratios [-] drawn as rays on the root locus
ZETA_RAYS = (0.0, 0.05, 0.1, 0.2)


def root_locus(sweep, ax=None, title: str = "root locus", reference=None,
               reference_label: str = "open loop", colorbar: bool = True):
    """Tracked branches of a :class:`~bridgeflap.model.stability.sweeps.StabilitySweep` in the
    complex plane.

    Both axes in 1/s; points coloured by the wind speed [m/s], U = 0 as magenta dots.
    ``reference`` (another sweep, e.g. the open loop of a closed-loop ``sweep``) is drawn
    underneath in grey, so that what the controller moves is seen at a glance.
    """
    ax = ax if ax is not None else new_axes()
    re_all, im_all = [], []
    if reference is not None:
        for k in range(reference.branches.shape[0]):
            lam = reference.branches[k]
            ax.plot(lam.real, lam.imag, "-", color="0.6", lw=1.6, alpha=0.8,
                    label=reference_label if k == 0 else None, zorder=1)
            re_all.append(lam.real)
            im_all.append(lam.imag)
    sc = None
    for k in range(sweep.branches.shape[0]):
        lam = sweep.branches[k]
        sc = ax.scatter(lam.real, lam.imag, c=sweep.speeds, s=4, cmap="viridis", zorder=2,
                        label=("closed loop" if reference is not None else "branches")
                        if k == 0 else None)
        re_all.append(lam.real)
        im_all.append(lam.imag)
    lam0 = sweep.branches[:, 0]
    ax.plot(lam0.real, lam0.imag, "m.", ms=8, label=f"U = {sweep.speeds[0]:g} m/s", zorder=3)
    xlo, xhi = data_limits(np.concatenate(re_all + [[0.0]]))
    ylo, yhi = data_limits(np.concatenate(im_all))
    for z in ZETA_RAYS:  # Re = -zeta |lambda|: the ray Re/Im = -zeta / sqrt(1 - zeta^2)
        y = np.array([0.0, 2 * yhi])
        ax.plot(-z / np.sqrt(1 - z * z) * y, y, color="k" if z == 0 else "0.75",
                lw=0.8, ls="-" if z == 0 else "--", zorder=0)
        if z > 0 and -z / np.sqrt(1 - z * z) * yhi > xlo + 0.1 * (xhi - xlo):
            y_txt = yhi - 0.03 * (yhi - ylo)
            ax.text(-z / np.sqrt(1 - z * z) * y_txt, y_txt, f"ζ = {100 * z:g} %", fontsize=7,
                    color="0.35", ha="right", va="top", clip_on=True)
    ax.set_xlim(xlo, xhi)
    ax.set_ylim(ylo, yhi)
    ax.set_xlabel("Re(λ) [1/s]")
    ax.set_ylabel("Im(λ) [rad/s]")
    sec = ax.secondary_yaxis("right", functions=(lambda w: w / (2 * np.pi),
                                                 lambda f: f * 2 * np.pi))
    sec.set_ylabel("frequency Im(λ)/2π [Hz]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    if sc is not None and colorbar:
        _speed_colorbar(ax, sc, sec)
    return ax


def _speed_colorbar(ax, mappable, sec):
    """The wind-speed colour bar of a root locus, right of the frequency axis ``sec`` and clear
    of its label.

    A constrained layout places the bar after the axis' decorations by itself (a small pad). In
    any other layout the pad is a fraction of the axes width, so it is measured: the width of the
    frequency axis with its ticks and label, plus a margin, and a third more in case a tight
    layout shrinks the axes afterwards (the label keeps its size, the fraction does not).
    """
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    fig = ax.figure
    if isinstance(fig.get_layout_engine(), ConstrainedLayoutEngine):
        pad = 0.03
    else:
        renderer = fig.canvas.get_renderer()
        box, extent = sec.get_tightbbox(renderer), ax.get_window_extent(renderer)
        margin = 0.1 * fig.dpi  # [px] 0.1 in
        pad = max(0.05, 1.3 * (box.x1 - extent.x1 + margin) / max(extent.width, 1.0))
    return fig.colorbar(mappable, ax=ax, label="wind speed U [m/s]", pad=pad)


def vg_vf(sweep, axes=None, reference=None):
    """Damping ratio [%] (V-g) and frequency [Hz] (V-f) of every tracked branch against the
    wind speed, flutter and divergence marked; axes enclose all the data (no clipping)."""
    from bridgeflap.model.stability.tracking import CONVERGED

    ax1, ax2 = axes if axes is not None else new_axes(1, 2, figsize=(11, 4.5))
    z, f = 100 * sweep.damping_ratios(), sweep.frequencies_hz()
    for k, (lab, kw) in enumerate(zip(sweep.branch_labels, branch_styles(sweep.branch_labels),
                                      strict=True)):
        every = max(1, len(sweep.speeds) // 8)  # markers on the line, staggered per branch
        kw = {**kw, "markevery": ((k * every) // 5 % every, every), "ms": 4}
        ax1.plot(sweep.speeds, z[k], lw=1.2, label=lab, **kw)
        ax2.plot(sweep.speeds, f[k], lw=1.2, label=lab, **kw)
    if reference is not None:
        zr, fr = 100 * reference.damping_ratios(), reference.frequencies_hz()
        for k in range(zr.shape[0]):
            lab = "open loop" if k == 0 else None
            ax1.plot(reference.speeds, zr[k], ":", color="0.6", lw=0.9, label=lab)
            ax2.plot(reference.speeds, fr[k], ":", color="0.6", lw=0.9, label=lab)
        z, f = np.concatenate([z, zr]), np.concatenate([f, fr])
    for ax in (ax1, ax2):
        for c, col, name in ((sweep.flutter, "r", "flutter"),
                             (sweep.divergence, "b", "divergence")):
            if c.status == CONVERGED:
                ax.axvline(c.speed, color=col, lw=1.0, ls=":",
                           label=f"{name} {c.speed:.2f} m/s")
        ax.set_xlabel("wind speed U [m/s]")
        ax.grid(alpha=0.3)
        ax.set_xlim(sweep.speeds[0], sweep.speeds[-1])
    ax1.axhline(0, color="k", lw=0.8)
    ax1.set_ylim(*data_limits(np.concatenate([z.ravel(), [0.0]])))
    ax2.set_ylim(*data_limits(f.ravel()))
    ax1.set_ylabel("damping ratio ζ [%]")
    ax2.set_ylabel("frequency [Hz]")
    ax1.set_title("V-g: damping ratio (solid: torsional, dashed: vertical)", fontsize=9)
    ax2.set_title("V-f: frequency", fontsize=9)
    n_entries = len(ax2.get_legend_handles_labels()[1])  # columns of at most ~16 entries
    ax2.legend(fontsize=7, ncol=1 + (n_entries - 1) // 16, loc="center left",
               bbox_to_anchor=(1.02, 0.5))
    return ax1, ax2


#: markers of the second, third, ... round of the ten colours (the first round has none)
_ROUND_MARKERS = ("o", "s", "^", "v", "D", "x", "+", "*")


def branch_styles(labels) -> list[dict]:
    """Line keywords (``color``, ``ls``, ``marker``) of each branch of a V-g / V-f plot, unique
    per branch: the line style says the family (solid: torsional ``T...``, dashed: vertical and
    the rest), the colour runs through the ten default colours within the family, and each
    further round of ten in a family takes a marker. Two branches never share colour, style and
    marker (for up to 90 branches of a family; beyond, the markers repeat)."""
    count = {"T": 0, "V": 0}
    out = []
    for lab in labels:
        fam = "T" if str(lab).startswith("T") else "V"
        i = count[fam]
        count[fam] += 1
        rnd = i // 10
        marker = None if rnd == 0 else _ROUND_MARKERS[(rnd - 1) % len(_ROUND_MARKERS)]
        out.append({"color": f"C{i % 10}", "ls": "-" if fam == "T" else "--", "marker": marker})
    return out


def stability_panels(sweep, axes=None, title: str = "", reference=None):
    """Root locus (left), V-g and V-f (right) in one figure; ``reference`` as
    :func:`root_locus`."""

    if axes is None:
        axes = new_axes(1, 3, figsize=(17, 5))
    ax0, ax1, ax2 = axes
    root_locus(sweep, ax0, title="root locus" + (" (grey: open loop)" if reference else ""),
               reference=reference)
    vg_vf(sweep, (ax1, ax2), reference=reference)
    fl, dv = (_limit_text(sweep, c, name) for c, name in ((sweep.flutter, "flutter"),
                                                          (sweep.divergence, "divergence")))
    ax0.figure.suptitle(f"{title}  {fl}, {dv}".strip())
    return axes


def _limit_text(sweep, crossing, name: str) -> str:
    from bridgeflap.model.stability.tracking import CONVERGED, NO_CROSSING

    if crossing.status == CONVERGED:
        return f"{name} {crossing.speed:.2f} m/s"
    if crossing.status == NO_CROSSING:
        return f"no {name} in {sweep.speeds[0]:g}-{sweep.speeds[-1]:g} m/s"
    return f"{name}: {crossing.status}"


def erection_speeds(result, ax=None):
    """Flutter and divergence speed against deck completion (the paper's Fig. 3 right) of a
    :class:`bridgeflap.model.analysis.ErectionResult`; the completed bridge is its own marker at
    100 %, not joined to the erection curve; hybrid stages (the critical branch is a deck mode
    hybridised with a bare side-span cable: a side-span label, ``T-barton1``, not ``TS1``)
    ringed in red on the governing curve with the branch label."""
    ax = axes_or_new(ax, figsize=(6, 4))
    stages = result.stages
    f = np.array([s["erected_fraction"] for s in stages]) * 100
    uf = np.array([number_or_nan(s["flutter_speed_m_s"]) for s in stages])
    ud = np.array([number_or_nan(s["divergence_speed_m_s"]) for s in stages])
    ax.plot(f, uf, "o-", color="C0", label="flutter (erecting)")
    ax.plot(f, ud, "s--", color="C1", label="torsional divergence (erecting)")
    hyb = [(fx, s) for fx, s in zip(f, stages, strict=True)
           if str(s.get("critical_branch_label") or "")[1:2] == "-"]
    ring_points(ax, [fx for fx, _ in hyb],
                [number_or_nan(s["divergence_speed_m_s"]
                               if str(s.get("critical_mechanism", "")).startswith("divergence")
                               else s["flutter_speed_m_s"]) for _, s in hyb],
                [s["critical_branch_label"] for _, s in hyb],
                "hybrid stage: critical branch on a side-span cable mode")
    done = result.completed
    if done:
        ax.plot([100], [number_or_nan(done["flutter_speed_m_s"])], "*", color="C0", ms=14,
                label="flutter, completed bridge")
        ax.plot([100], [number_or_nan(done["divergence_speed_m_s"])], "P", color="C1",
                ms=11, label="divergence, completed bridge")
    ax.set_xlabel("main-span deck erected [%]")
    ax.set_ylabel("critical wind speed [m/s]")
    ax.set_title(f"{result.bridge}: stability during erection (side spans {result.side_spans})\n"
                 "half GJ, zero EI until the joints close; 100 % = closed deck")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return ax
