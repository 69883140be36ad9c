"""Figures of the model results: root locus, V-g/V-f, mode shapes by family, buffeting.

The result classes keep thin ``plot`` methods that call these functions (compute, then plot:
matplotlib is imported lazily, nothing here calls ``plt.show()``). Units are fixed per kind of
axis so that figures can be read side by side:

* root locus: ``Re(lambda)`` and ``Im(lambda)``, both in 1/s (rad/s for the imaginary part),
  with rays of constant damping ratio and a secondary frequency axis in Hz;
* V-g / V-f: damping ratio [%] and frequency [Hz] against the wind speed [m/s]; the axes
  enclose every tracked branch (nothing is clipped: a branch that runs far negative past
  flutter stays on the axis);
* positions along the bridge in km from the north anchorage, towers as dotted lines.
"""

from __future__ import annotations

import numpy as np

__all__ = ["buffeting_panels", "data_limits", "imported_mode_shapes", "mark_spans",
           "mode_shapes_by_family",
           "root_locus", "stability_panels", "vg_vf"]

#: constant damping ratios [-] drawn as rays on the root locus
ZETA_RAYS = (0.0, 0.05, 0.1, 0.2)
_FAMILIES = ("vertical", "torsional", "lateral")
_FAMILY_UNIT = {"vertical": "heave", "torsional": "pitch", "lateral": "sway"}


def _new_axes(nrows=1, ncols=1, figsize=(6, 4.5), **kw):
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


def mark_spans(ax, spans, names: bool = True, y: float = 0.97, km: bool = True) -> None:
    """Towers (span boundaries) as dotted lines and the span names at height ``y`` (axes
    fraction); ``spans`` is :func:`model.stability.modeshape.span_extents_m`."""
    s = 1000.0 if km else 1.0
    for i, (_, _, b) in enumerate(spans[:-1]):
        ax.axvline(b / s, color="k", lw=1.2, ls=":", label="tower" if i == 0 else None)
    if names:
        tr = ax.get_xaxis_transform()
        for name, a, b in spans:
            ax.text(0.5 * (a + b) / s, y, f"{name} span", transform=tr, ha="center",
                    va="top" if y > 0.5 else "bottom", fontsize=8, color="0.3")


# ------------------------------------------------------------------ stability


def root_locus(sweep, ax=None, title: str = "root locus", reference=None,
               reference_label: str = "open loop", colorbar: bool = True):
    """Tracked branches of a :class:`~model.stability.sweeps.StabilitySweep` in the complex plane.

    Both axes in 1/s; points coloured by the wind speed [m/s], U = 0 as magenta dots.
    ``reference`` (another sweep, e.g. the open loop of a closed-loop ``sweep``) is drawn
    underneath in grey, so that what the controller moves is seen at a glance.
    """
    ax = ax if ax is not None else _new_axes()
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
        ax.figure.colorbar(sc, ax=ax, label="wind speed U [m/s]", pad=0.12)
    return ax


def vg_vf(sweep, axes=None, reference=None):
    """Damping ratio [%] (V-g) and frequency [Hz] (V-f) of every tracked branch against the
    wind speed, flutter and divergence marked; axes enclose all the data (no clipping)."""
    from model.stability.tracking import CONVERGED

    ax1, ax2 = axes if axes is not None else _new_axes(1, 2, figsize=(11, 4.5))
    z, f = 100 * sweep.damping_ratios(), sweep.frequencies_hz()
    for k, lab in enumerate(sweep.branch_labels):
        style = "-" if lab.startswith("T") else "--"
        ax1.plot(sweep.speeds, z[k], style, lw=1.2, color=f"C{k % 10}", label=lab)
        ax2.plot(sweep.speeds, f[k], style, lw=1.2, color=f"C{k % 10}", label=lab)
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
    ax2.legend(fontsize=7, ncol=1, loc="center left", bbox_to_anchor=(1.02, 0.5))
    return ax1, ax2


def stability_panels(sweep, axes=None, title: str = "", reference=None):
    """Root locus (left), V-g and V-f (right) in one figure; ``reference`` as
    :func:`root_locus`."""

    if axes is None:
        axes = _new_axes(1, 3, figsize=(17, 5))
    ax0, ax1, ax2 = axes
    root_locus(sweep, ax0, title="root locus" + (" (grey: open loop)" if reference else ""),
               reference=reference)
    vg_vf(sweep, (ax1, ax2), reference=reference)
    fl, dv = (_limit_text(sweep, c, name) for c, name in ((sweep.flutter, "flutter"),
                                                          (sweep.divergence, "divergence")))
    ax0.figure.suptitle(f"{title}  {fl}, {dv}".strip())
    return axes


def _limit_text(sweep, crossing, name: str) -> str:
    from model.stability.tracking import CONVERGED, NO_CROSSING

    if crossing.status == CONVERGED:
        return f"{name} {crossing.speed:.2f} m/s"
    if crossing.status == NO_CROSSING:
        return f"no {name} in {sweep.speeds[0]:g}-{sweep.speeds[-1]:g} m/s"
    return f"{name}: {crossing.status}"


# ------------------------------------------------------------------ mode shapes


def mode_shapes_by_family(modal, per_family: int = 3, axes=None, labels=None):
    """Deck mode shapes in one panel per family (vertical, torsional, lateral), each
    normalised to a peak of 1, the lowest ``per_family`` modes of each family (or the modes
    named in ``labels``), towers dotted."""
    from model.stability.modeshape import span_extents_m

    st = modal.structure
    fams = [f for f in _FAMILIES if f in st.families]
    if axes is None:
        axes = _new_axes(len(fams), 1, figsize=(9, 2.6 * len(fams) + 0.6), sharex=True)
    axes = np.atleast_1d(axes)
    xg = st.global_x(st.node_span, st.node_x) / 1000.0
    styles = ("-", "--", "-.", ":")
    for ax, fam in zip(axes, fams, strict=False):
        modes = [m for m in modal.modes if m.family == fam]
        if labels is not None:
            modes = [m for m in modes if m.label in labels]
        else:
            modes = sorted(modes, key=lambda m: m.frequency_hz)[:per_family]
        for k, m in enumerate(modes):
            y = st.families[fam].node_map @ modal.shape(modal.modes.index(m))
            y = y / (np.max(np.abs(y)) or 1.0)
            for s in np.unique(st.node_span):
                sel = st.node_span == s
                ax.plot(xg[sel], y[sel], color=f"C{k}", ls=styles[k % 4], lw=1.6,
                        label=f"{m.label} {m.frequency_hz:.3f} Hz" if s == st.node_span[0]
                        else None)
        mark_spans(ax, span_extents_m(modal.spec), names=ax is axes[0])
        _finish_family_axis(ax, fam)
    axes[-1].set_xlabel("distance from north anchorage [km]")
    axes[0].set_title(f"{modal.spec.name}: mode shapes by family "
                      f"(erected {modal.spec.erected_fraction:.2f}; dotted: towers)", fontsize=10)
    return axes


def _finish_family_axis(ax, fam: str) -> None:
    """Zero line, limits, label with the family's unit, grid and legend of one shape panel."""
    ax.axhline(0, color="k", lw=0.5)
    ax.set_ylim(-1.15, 1.3)
    ax.set_ylabel(f"{fam}\n({_FAMILY_UNIT[fam]}, peak 1) [-]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5))


def imported_mode_shapes(modal, per_family: int = 3, axes=None, labels=None):
    """:func:`mode_shapes_by_family` for an imported modal model
    (:class:`model.structure.modal_model.ImportedModalModel`): file coordinates, the main-span ends
    (``structure.main_span_m``) dotted."""
    d = modal.spec.structure.data
    fams = [f for f in _FAMILIES if any(m.family == f for m in modal.modes)]
    if axes is None:
        axes = _new_axes(len(fams), 1, figsize=(9, 2.6 * len(fams) + 0.6), sharex=True)
    axes = np.atleast_1d(axes)
    a, b = modal.spec.structure.main_span_m
    for ax, fam in zip(axes, fams, strict=False):
        idx = [i for i, m in enumerate(modal.modes) if m.family == fam
               and (labels is None or m.label in labels)]
        idx = idx if labels is not None else idx[:per_family]
        for k, i in enumerate(idx):
            y = d.shapes[fam][:, modal.order[i]]
            ax.plot(np.asarray(d.station_x_m) / 1000.0, y / (np.max(np.abs(y)) or 1.0),
                    color=f"C{k}", lw=1.6,
                    label=f"{modal.modes[i].label} {modal.modes[i].frequency_hz:.3f} Hz")
        for k, x in enumerate((a, b)):
            ax.axvline(x / 1000.0, color="k", ls=":", lw=1.2,
                       label="main-span ends" if k == 0 else None)
        _finish_family_axis(ax, fam)
    axes[-1].set_xlabel("x along the deck (file coordinates) [km]")
    axes[0].set_title(f"{modal.spec.name}: imported mode shapes by family", fontsize=10)
    return axes


# ------------------------------------------------------------------ buffeting


def buffeting_panels(curves, axes=None, log: bool = False, title: str = ""):
    """Vertical (left, ``max sigma_z / 2b``) and torsional (right, ``max sigma_alpha``
    [deg]) RMS on the main span against the wind speed.

    ``curves`` maps a label to a :class:`~model.response.buffeting.BuffetingResult` (or one result);
    unstable speeds are NaN and leave a gap, nothing is clipped.
    """
    if not isinstance(curves, dict):
        curves = {None: curves}
    ax0, ax1 = axes if axes is not None else _new_axes(1, 2, figsize=(11, 4.2))
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
