"""Figures of the compensator design: Bode plot, margins per speed, flap layout on the deck.

:class:`bridgeflap.design.control.results.result.DesignResult` (``plot_bode``, ``plot_margins``)
calls these (matplotlib imported lazily). Frequencies are in Hz as in every other figure (the
compensator's response is :func:`scipy.signal.freqs` of its numerator and denominator), speeds in
m/s, positions along the bridge in m from the main-span mid-point (the controller's coordinate,
:class:`bridgeflap.model.aeroelastic.control.Controller`). The seed Fig. 5 is in
:mod:`bridgeflap.design.studies.figures`, the Morris plane in
:mod:`bridgeflap.design.sensitivity.figures`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["bode", "compensator_response", "flap_layout", "margins"]


def _new(nrows=1, ncols=1, figsize=(6, 4.5), **kw):
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(nrows, ncols, figsize=figsize, layout="constrained", **kw)
    return ax


def compensator_response(compensator, frequency_hz) -> np.ndarray:
    """``K(j 2 pi f)`` [rad/rad] of ``K(s) = (b2 s^2 + b1 s + b0) / (a2 s^2 + a1 s + 1)`` by
    :func:`scipy.signal.freqs` at the frequencies ``frequency_hz`` [Hz]."""
    from scipy.signal import freqs

    k = compensator
    _, h = freqs([k.b2, k.b1, k.b0], [k.a2, k.a1, 1.0],
                 worN=2 * np.pi * np.asarray(frequency_hz, dtype=float))
    return h


def bode(compensator, gain_limit: float, axes=None, omega_range_rad_s=(1e-3, 1e2),
         title: str = "compensator K(s)", marks_hz=None):
    """Gain and phase of ``K`` against frequency [Hz] with the gain limit [rad/rad];
    ``marks_hz`` (label -> frequency [Hz]) draws vertical markers (e.g. modal frequencies)."""
    ax0, ax1 = axes if axes is not None else _new(2, 1, figsize=(6.5, 5.2), sharex=True)
    lo, hi = (w / (2 * np.pi) for w in omega_range_rad_s)
    f = np.logspace(np.log10(lo), np.log10(hi), 800)
    # the analytic peaks join the grid: a lightly damped compensator's resonance is narrower
    # than the grid spacing (default design: sampled 9.70 against the true 9.90)
    fs = np.asarray(compensator.stationary_frequencies(), float) / (2 * np.pi)
    f = np.unique(np.concatenate([f, fs[(fs > lo) & (fs < hi)]]))
    K = compensator_response(compensator, f)
    g = np.abs(K)
    ax0.loglog(f, g, "b-", label="|K(j2πf)|")
    ax0.axhline(gain_limit, color="r", ls="--", label=f"gain limit {gain_limit:g}")
    i = int(np.argmax(g))
    if i == g.size - 1:  # still rising at the plotted range's end: say where the sup is
        ax0.plot(f[i], g[i], "bo", ms=5, label=f"{g[i]:.2f} at {f[i]:.3g} Hz; sup |K| = "
                 f"|K(j inf)| = {compensator.high_frequency_gain():.2f}")
    else:
        ax0.plot(f[i], g[i], "bo", ms=5, label=f"peak {g[i]:.2f} at {f[i]:.3g} Hz")
    ax0.set_ylim(min(g.min(), gain_limit) / 1.5, max(g.max(), gain_limit) * 1.5)
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    ax0.yaxis.set_major_formatter(ScalarFormatter())
    ax0.yaxis.set_minor_formatter(NullFormatter())
    ax0.set_ylabel("gain [rad/rad]")
    ax1.semilogx(f, np.degrees(np.angle(K)), "b-")
    ax1.set_ylabel("phase [deg]")
    ax1.set_xlabel("frequency [Hz]")
    for label, fm in (marks_hz or {}).items():
        for a in (ax0, ax1):
            a.axvline(fm, color="0.5", lw=0.8, ls=":")
        ax0.text(fm, ax0.get_ylim()[1], label, fontsize=7, rotation=90, va="top", ha="right")
    for a in (ax0, ax1):
        a.grid(alpha=0.3, which="both")
    ax0.legend(fontsize=8, loc="upper left")
    ax0.set_title(title, fontsize=10)
    return ax0, ax1


def flap_layout(ax, controller, spec=None, flap_chord_m: float = 3.0):
    """Plan view of the deck (grey, ``2b`` wide) with the towers (black squares) and the
    flaps as patches along the leading (wind-side) and trailing edges."""
    from matplotlib.patches import Rectangle

    b = spec.deck.half_chord_m if spec is not None else 14.25
    if spec is not None:
        lengths = [s.length_m for s in spec.spans]
        start = -sum(lengths[:spec.main_span_index]) - 0.5 * spec.main_span.length_m
        ends = start + np.concatenate([[0.0], np.cumsum(lengths)])
        towers = ends[1:-1]
    else:
        ends, towers = np.array([-705.0, 705.0]), np.array([-705.0, 705.0])
    ax.add_patch(Rectangle((ends[0], -b), ends[-1] - ends[0], 2 * b, color="0.85",
                           label=f"deck, 2b = {2 * b:g} m"))
    ax.plot(towers, np.zeros_like(towers), "ks", ms=9, label="towers")
    w, c = controller.flap_width_m, flap_chord_m
    edges = [(e, y0, col) for e, y0, col in (("leading", b, "C1"), ("trailing", -b - c, "C2"))
             if getattr(controller, f"{e}_edge")]
    for e, y0, col in edges:
        for i, x in enumerate(controller.flap_strip_positions_m):
            ax.add_patch(Rectangle((x - w / 2, y0), w, c, facecolor=col, edgecolor="k", lw=0.4,
                                   label=f"{e}-edge flaps ({c:g} m chord)" if i == 0 else None))
    ax.set_xlim(ends[0] - 20, ends[-1] + 20)
    ax.set_ylim(-b - 3 * c, b + 3 * c)
    ax.annotate("wind", xy=(ends[0] + 60, b + 0.3 * c), xytext=(ends[0] + 60, b + 2.6 * c),
                arrowprops={"arrowstyle": "->"}, fontsize=8, ha="center")
    ax.set_xlabel("x from the main-span mid-point [m]")
    ax.set_ylabel("across the deck [m]")
    ax.set_title(f"flap layout: {controller.n_flaps} flap pairs of {w:g} m "
                 "(plan view, not to scale across)", fontsize=9)
    ax.legend(fontsize=7, loc="upper right", ncol=4)
    return ax


def margins(result, axes=None, spec=None):
    """Spectral abscissa (open and closed loop), smallest damping ratio of the movable
    branches with ``zeta_min``, the robust margin ``1 / sup_w sigma_max(T)`` per speed (top
    row) and the flap layout on the deck (bottom) of a
    :class:`bridgeflap.design.control.results.result.DesignResult`."""
    if axes is None:
        import matplotlib.pyplot as plt

        fig = plt.figure(figsize=(15, 7.5), layout="constrained")
        gs = fig.add_gridspec(2, 3, height_ratios=(1.6, 1.0))
        axes = [fig.add_subplot(gs[0, k]) for k in range(3)] + [fig.add_subplot(gs[1, :])]
    a0, a1, a2, a3 = axes
    st = result.settings
    U = result.abscissa_speeds_m_s
    a0.plot(U, result.abscissa_1_s, "b-", label="closed loop")
    ol = result.extras.get("open_loop_abscissa")
    if ol is not None:
        a0.plot(U, ol, "k--", label="open loop")
    a0.axhline(0, color="k", lw=0.7)
    a0.set_ylabel("spectral abscissa max Re λ [1/s]")
    a0.set_title("stability", fontsize=9)
    z = result.extras.get("damping_ratio")
    if z is not None:
        a1.plot(U, 100 * np.asarray(z), "g-", label="closed loop, min over movable branches")
    a1.axhline(100 * st.zeta_min, color="r", ls=":", label=f"ζ_min = {100 * st.zeta_min:g} %")
    a1.set_ylabel("smallest damping ratio [%]")
    a1.set_title("damping of the branches the flaps move", fontsize=9)
    t = result.best.t_inf_by_speed() if result.best is not None else {}
    if t:
        u = np.array([float(k) for k in t])
        m = 1.0 / np.array(list(t.values()))
        a2.plot(u, m, "mo-", label="1 / sup_ω σ_max(T(jω))")
        a2.axhline(m.min(), color="m", ls=":", lw=0.8,
                   label=f"robust margin {m.min():.3f} (worst speed {u[np.argmin(m)]:g} m/s)")
        a2.set_ylim(0, 1.1 * m.max())
    a2.set_ylabel("robust margin [-]")
    a2.set_title("small-gain margin per speed", fontsize=9)
    for a in (a0, a1, a2):
        a.set_xlabel("wind speed U [m/s]")
        a.grid(alpha=0.3)
        if a.get_legend_handles_labels()[0]:  # a design without a best start has no margin
            a.legend(fontsize=7)
    if result.candidate is not None:
        flap_layout(a3, result.candidate, spec, st.flap_chord_m)
    return axes
