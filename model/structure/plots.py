"""Figures of the structure: deck mode shapes by family, towers and span names marked; the
torsion-to-bending frequency ratio against deck completion (the paper's Fig. 2).

The modal models keep thin ``plot`` methods that call these functions
(:meth:`bridgeflap.model.structure.modes.ModalModel.plot`,
:meth:`bridgeflap.model.structure.modal_model.ImportedModalModel.plot`); matplotlib is imported
lazily, nothing here calls ``plt.show()``. Positions along the bridge are in km from the north
anchorage, towers as dotted lines; each shape is normalised to a peak of 1.

May import: the foundation (:mod:`bridgeflap.model.axes`) and bridgeflap.model.structure only.
"""

from __future__ import annotations

import numpy as np

from bridgeflap.model.axes import axes_or_new, new_axes, ring_points
from bridgeflap.model.structure.spans import span_extents_m

__all__ = ["frequency_ratio", "imported_mode_shapes", "mark_spans", "mode_shapes_by_family"]

_FAMILIES = ("vertical", "torsional", "lateral")
_FAMILY_UNIT = {"vertical": "heave", "torsional": "pitch", "lateral": "sway"}


def mark_spans(ax, spans, names: bool = True, y: float = 0.97, km: bool = True) -> None:
    """Towers (span boundaries) as dotted lines and the span names at height ``y`` (axes
    fraction); ``spans`` is :func:`bridgeflap.model.structure.spans.span_extents_m`."""
    s = 1000.0 if km else 1.0
    for i, (_, _, b) in enumerate(spans[:-1]):
        ax.axvline(b / s, color="k", lw=1.2, ls=":", label="tower" if i == 0 else None)
    if names:
        tr = ax.get_xaxis_transform()
        for name, a, b in spans:
            ax.text(0.5 * (a + b) / s, y, f"{name} span", transform=tr, ha="center",
                    va="top" if y > 0.5 else "bottom", fontsize=8, color="0.3")


def mode_shapes_by_family(modal, per_family: int = 3, axes=None, labels=None):
    """Deck mode shapes in one panel per family (vertical, torsional, lateral), each
    normalised to a peak of 1, the lowest ``per_family`` modes of each family (or the modes
    named in ``labels``), towers dotted."""
    st = modal.structure
    fams = [f for f in _FAMILIES if f in st.families]
    if axes is None:
        axes = new_axes(len(fams), 1, figsize=(9, 2.6 * len(fams) + 0.6), sharex=True)
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
    (:class:`bridgeflap.model.structure.modal_model.ImportedModalModel`): file coordinates, the
    main-span ends (``structure.main_span_m``) dotted."""
    d = modal.spec.structure.data
    fams = [f for f in _FAMILIES if any(m.family == f for m in modal.modes)]
    if axes is None:
        axes = new_axes(len(fams), 1, figsize=(9, 2.6 * len(fams) + 0.6), sharex=True)
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


def frequency_ratio(result, ax=None):
    """``f(TS1)/f(VS1)`` with full and half GJ against deck completion (the paper's Fig. 2) of a
    :class:`bridgeflap.model.analysis.FrequencyRatioResult`; the completed bridge is its own
    marker at 100 %; hybrid stages (``torsional_hybrid`` / ``vertical_hybrid``: the picked deck
    mode is split between modes, so the ratio rests on one of the hybrids; the modes are the
    half-GJ ones) ringed in red with the picked mode's label."""
    ax = axes_or_new(ax, figsize=(6, 4))
    stages = result.stages
    f = [100 * s["erected_fraction"] for s in stages]
    ax.plot(f, [s["ratio_full_gj"] for s in stages], "o-", label="full GJ")
    ax.plot(f, [s["ratio_half_gj"] for s in stages], "s--", label="half GJ")
    hyb = [(fx, s) for fx, s in zip(f, stages, strict=True)
           if s.get("torsional_hybrid") or s.get("vertical_hybrid")]
    ring_points(ax, [fx for fx, _ in hyb], [s["ratio_half_gj"] for _, s in hyb],
                ["/".join(s[f"{fam}_mode"] for fam in ("torsional", "vertical")
                          if s.get(f"{fam}_hybrid")) for _, s in hyb],
                "hybrid stage (half GJ): deck mode split between modes")
    if result.completed:
        ax.plot([100], [result.completed["ratio"]], "k*", ms=14, label="completed bridge")
    ax.set_xlabel("main-span deck erected [%]")
    ax.set_ylabel("f(TS1) / f(VS1) [-]")
    ax.set_title(f"{result.bridge}: torsion-to-bending frequency ratio\n"
                 f"(EI = 0 while erecting; side spans {result.side_spans})")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return ax
