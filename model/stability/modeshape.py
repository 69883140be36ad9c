"""The flutter mode along the span, and the deck modes picked by the frequency-ratio rule.

:func:`flutter_mode_shape` takes the critical eigenvector of the aeroelastic state at the
flutter speed (the same eigenpair :func:`bridgeflap.model.stability.sweeps.sweep` reports: the
oscillatory eigenvalue with the largest real part), keeps its structural coordinates ``q`` and maps
them to the physical deck fields with the FE shapes of the retained modes:

``h(x) = sum_j phi_h,j(x) q_j`` (vertical modes, heave [m], positive down) and
``alpha(x) = sum_j phi_alpha,j(x) q_j`` (torsional modes, pitch [rad], nose-up),

at every mesh node (the family's ``node_map``, for plots) and at every aerodynamic strip
(the family's ``strip_map``: the same fields the state space's output matrix ``C_out``
reads). The complex scale of an eigenvector is arbitrary: the shape is normalised so that the
largest pitch amplitude is ``peak_pitch_rad`` (0.01 rad unless told) with zero phase there;
heave is then in metres per that pitch. Modal participation is the kinetic-energy share of each
retained mode, ``|q_j|^2`` for mass-normalised modes, as
:attr:`bridgeflap.model.stability.sweeps.StabilitySweep.critical_participation` (taken from there).

:func:`ratio_modes` collects the modes a selection rule picks at several erected fractions for
:func:`plot_ratio_modes`; the rule is passed in (the frequency-ratio study's is
:func:`bridgeflap.model.analysis.first_symmetric_deck_mode`), because this module sits below the
facade
:mod:`bridgeflap.model.analysis` and does not import it. Conventions: see :mod:`bridgeflap.model`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from bridgeflap.model.aeroelastic import statespace
from bridgeflap.model.errors import BridgeflapError
from bridgeflap.model.results import ResultData
from bridgeflap.model.stability.sweeps import CONVERGED, check_speeds, oscillation_tolerance, sweep
from bridgeflap.model.structure.bridge_arg import BridgeArg, takes_bridge
from bridgeflap.model.structure.fe import assemble
from bridgeflap.model.structure.modes import ModalModel, solve
from bridgeflap.model.structure.spans import span_extents_m, tower_positions_m
from bridgeflap.model.structure.spec import BridgeSpec

__all__ = ["FlutterModeShape", "RatioModes", "critical_eigenvector", "deck_fields",
           "flutter_mode_shape", "plot_ratio_modes", "ratio_modes", "span_extents_m",
           "tower_positions_m"]

#: normalisation of the flutter shape: the largest pitch amplitude [rad]
PEAK_PITCH_RAD = 0.01


def _mark_spans(ax, spans, names: bool = True, y: float = 0.97) -> None:
    """Towers as dotted lines; span names at height ``y`` (axes fraction) of ``ax`` (x in km)."""
    for _, _, b in spans[:-1]:
        ax.axvline(b / 1000.0, color="k", lw=1.2, ls=":")
    if names:
        tr = ax.get_xaxis_transform()
        for name, a, b in spans:
            ax.text(0.5 * (a + b) / 1000.0, y, f"{name} span", transform=tr, ha="center",
                    va="top" if y > 0.5 else "bottom", fontsize=8, color="0.3")


def critical_eigenvector(system, wind_speed: float) -> tuple[complex, np.ndarray]:
    """``(lambda, v)``: the oscillatory eigenpair of ``A(U)`` with the largest real part.

    The selection of :func:`bridgeflap.model.stability.sweeps.sweep` (``|Im lambda|`` above
    :func:`~bridgeflap.model.stability.sweeps.oscillation_tolerance`), upper half plane (``Im lambda
    > 0``).
    """
    lam, V = sla.eig(system.A(wind_speed))
    tol = oscillation_tolerance(system)
    osc = np.where(lam.imag > tol)[0]
    if osc.size == 0:
        raise BridgeflapError(f"no oscillatory eigenvalue at {wind_speed} m/s")
    k = osc[np.argmax(lam[osc].real)]
    return complex(lam[k]), V[:, k]


def deck_fields(modal: ModalModel, labels, q) -> dict:
    """Physical deck fields of modal coordinates ``q`` on the modes named ``labels``.

    Returns ``{"node_heave_m", "node_pitch_rad", "strip_heave_m", "strip_pitch_rad"}``
    (complex arrays; nodes in :attr:`bridgeflap.model.structure.fe.StructuralModel.node_x` order,
    strips in ``strip_x`` order).
    """
    st = modal.structure
    q = np.asarray(q)
    out = {"node_heave_m": np.zeros(len(st.node_x), complex),
           "node_pitch_rad": np.zeros(len(st.node_x), complex),
           "strip_heave_m": np.zeros(len(st.strip_x), complex),
           "strip_pitch_rad": np.zeros(len(st.strip_x), complex)}
    for lab, qj in zip(labels, q, strict=True):
        m = modal.find(lab)
        v = modal.shape(modal.modes.index(m))
        fam = st.families[m.family]
        key = "heave_m" if m.family == "vertical" else "pitch_rad"
        out[f"node_{key}"] += (fam.node_map @ v) * qj
        out[f"strip_{key}"] += (fam.strip_map @ v) * qj
    return out


def _normaliser(pitch: np.ndarray, peak_pitch_rad: float) -> complex:
    """Complex factor that makes the largest ``|pitch|`` equal ``peak_pitch_rad``, phase 0."""
    i = int(np.argmax(np.abs(pitch)))
    if abs(pitch[i]) == 0:
        raise BridgeflapError("the flutter eigenvector has no pitch")
    return peak_pitch_rad / pitch[i]


@dataclass(frozen=True)
class FlutterModeShape(ResultData):
    """The flutter eigenvector as deck heave and pitch along the bridge.

    Attributes
    ----------
    x_m, node_span : ndarray (n_nodes,)
        Node position from the north anchorage [m] and span index of each node.
    heave_m, pitch_rad : ndarray (n_nodes,), complex
        Normalised fields (module docstring): amplitude ``abs``, phase ``angle``.
    strip_x_m, strip_heave_m, strip_pitch_rad : ndarray (n_strip,)
        The same at the aerodynamic strips.
    q : ndarray (n,), complex
        Normalised modal coordinates of ``labels``.
    participation : dict
        Kinetic-energy share of each retained mode [-] (sums to 1).
    """

    bridge: str
    status: str
    flutter_speed_m_s: float
    flutter_frequency_hz: float
    eigenvalue: complex
    x_m: np.ndarray
    node_span: np.ndarray
    heave_m: np.ndarray
    pitch_rad: np.ndarray
    strip_x_m: np.ndarray
    strip_heave_m: np.ndarray
    strip_pitch_rad: np.ndarray
    q: np.ndarray
    labels: tuple
    participation: dict
    tower_x_m: tuple
    half_chord_m: float
    n_modes: int
    order: str
    peak_pitch_rad: float = PEAK_PITCH_RAD
    mode_frequencies_hz: dict = field(default_factory=dict)
    spans: tuple = ()
    divergence_speed_m_s: float = float("nan")

    def family_shares(self) -> dict:
        """Kinetic-energy share of the vertical and of the torsional modes [-].

        Returns
        -------
        dict
            ``{"vertical": share, "torsional": share}``, summing to 1.
        """
        fam = {"V": "vertical", "T": "torsional"}
        out = {"vertical": 0.0, "torsional": 0.0}
        for lab, s in self.participation.items():
            out[fam[lab[0]]] += s
        return out

    def strain_energy_shares(self) -> dict:
        """Share of each retained mode in the strain energy, ``omega_j^2 |q_j|^2`` [-].

        Returns
        -------
        dict
            Mode label -> share [-], summing to 1.
        """
        w2 = np.array([(2 * np.pi * self.mode_frequencies_hz[lab]) ** 2 for lab in self.labels])
        e = w2 * np.abs(self.q) ** 2
        return {lab: float(v) for lab, v in zip(self.labels, e / e.sum(), strict=True)}

    _HEADLINE_KEYS = ("bridge", "flutter_speed_m_s", "flutter_frequency_hz",
                      "divergence_speed_m_s", "n_modes", "peak_heave_m", "peak_heave_x_m",
                      "peak_pitch_x_m", "status")

    def summary(self, top: int = 6) -> dict:
        """JSON-ready numbers: speed, frequency, participation (largest ``top``), peaks.

        Parameters
        ----------
        top : int, default 6
            Modes listed in the participation and strain-energy shares (the largest).

        Returns
        -------
        dict
            Plain Python numbers: flutter speed [m/s] and frequency [Hz], the shares [-], the
            peak heave [m] and pitch [rad] and where they are along the bridge [m].
        """
        part = dict(sorted(self.participation.items(), key=lambda kv: -kv[1])[:top])
        strain = dict(sorted(self.strain_energy_shares().items(), key=lambda kv: -kv[1])[:top])
        ih = int(np.argmax(np.abs(self.heave_m)))
        ia = int(np.argmax(np.abs(self.pitch_rad)))
        return {"bridge": self.bridge, "status": self.status,
                "flutter_speed_m_s": self.flutter_speed_m_s,
                "flutter_frequency_hz": self.flutter_frequency_hz,
                "divergence_speed_m_s": self.divergence_speed_m_s,
                "n_modes": self.n_modes, "order": self.order,
                "half_chord_m": self.half_chord_m,
                "participation_kinetic_energy": part,
                "participation_strain_energy": strain,
                "family_shares_kinetic_energy": self.family_shares(),
                "peak_pitch_rad": self.peak_pitch_rad,
                "peak_pitch_x_m": float(self.x_m[ia]),
                "peak_heave_m": float(np.abs(self.heave_m[ih])),
                "peak_heave_x_m": float(self.x_m[ih]),
                "peak_heave_over_half_chord_pitch": float(
                    np.abs(self.heave_m[ih]) / self.half_chord_m / self.peak_pitch_rad),
                "heave_phase_at_peak_pitch_deg": float(np.degrees(np.angle(self.heave_m[ia]))),
                "tower_x_m": list(self.tower_x_m)}

    def plot(self, axes=None):
        """Heave amplitude, pitch amplitude and phase along the bridge (three panels).

        Parameters
        ----------
        axes : sequence of three matplotlib.axes.Axes, optional
            Heave, pitch and phase axes (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        import matplotlib.pyplot as plt

        if axes is None:
            fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True, layout="constrained")
        ax_h, ax_a, ax_p = axes
        x = self.x_m / 1000.0
        h, a = np.abs(self.heave_m), np.abs(self.pitch_rad)
        # phases only where the amplitude is at least 2 % of its peak (noise elsewhere)
        ph = np.where(h >= 0.02 * h.max(), np.degrees(np.angle(self.heave_m)), np.nan)
        pa = np.where(a >= 0.02 * a.max(), np.degrees(np.angle(self.pitch_rad)), np.nan)
        for s in np.unique(self.node_span):
            sel = self.node_span == s
            first = s == self.node_span[0]
            ax_h.plot(x[sel], h[sel], color="C0", label="|h|" if first else None)
            ax_a.plot(x[sel], a[sel], color="C3", label="|alpha|" if first else None)
            ax_p.plot(x[sel], _unwrap_deg(ph[sel]), color="C0",
                      label="phase of h" if first else None)
            ax_p.plot(x[sel], _unwrap_deg(pa[sel]), color="C3", ls="--",
                      label="phase of alpha" if first else None)
        ax_h.set_ylabel(f"heave amplitude [m]\nper {self.peak_pitch_rad:g} rad peak pitch")
        ax_a.set_ylabel("pitch amplitude [rad]")
        ax_p.set_ylabel("phase [deg]\n(0 = pitch at its peak)")
        ax_p.set_ylim(-200, 290)
        ax_p.set_yticks(np.arange(-180, 271, 90))
        ax_p.set_xlabel("distance from north (Hessle) anchorage [km]")
        for k, ax in enumerate(axes):
            _mark_spans(ax, self.spans, names=k == 0)
            ax.grid(alpha=0.3)
        ax_h.set_ylim(0, 1.12 * h.max())
        ax_a.set_ylim(bottom=0)
        ax_p.legend(fontsize=8, loc="lower left", ncol=2)
        top = sorted(self.participation.items(), key=lambda kv: -kv[1])[:4]
        part = ", ".join(f"{k} {v:.2f}" for k, v in top)
        first = ""
        if self.divergence_speed_m_s < self.flutter_speed_m_s:
            first = f"; divergence first, at {self.divergence_speed_m_s:.2f} m/s"
        ax_h.set_title(f"{self.bridge}: flutter mode at {self.flutter_speed_m_s:.2f} m/s, "
                       f"{self.flutter_frequency_hz:.4f} Hz ({self.n_modes} modes{first})\n"
                       f"kinetic-energy shares: {part}; dotted lines: towers", fontsize=10)
        return axes


    def animate(self, path, frames: int = 24, fps: int = 8):
        """Write a GIF of one period of the flutter mode (heave and pitch, real part of
        ``field * exp(i 2 pi t / T)``) to ``path``; returns the path.

        Parameters
        ----------
        path : str or pathlib.Path
            The GIF file to write (its folder must exist).
        frames : int, default 24
            Frames in the period.
        fps : int, default 8
            Frames per second of the GIF.

        Returns
        -------
        str or pathlib.Path
            ``path``.
        """
        import matplotlib.pyplot as plt
        from matplotlib.animation import FuncAnimation, PillowWriter

        fig, (ax_h, ax_a) = plt.subplots(2, 1, figsize=(8, 5), sharex=True,
                                         layout="constrained")
        x = self.x_m / 1000.0
        hm, am = np.abs(self.heave_m).max(), np.degrees(np.abs(self.pitch_rad)).max()
        lh, = ax_h.plot(x, self.heave_m.real, "C0")
        la, = ax_a.plot(x, np.degrees(self.pitch_rad.real), "C3")
        ax_h.set_ylim(-1.1 * hm, 1.1 * hm)
        ax_a.set_ylim(-1.1 * am, 1.1 * am)
        ax_h.set_ylabel("heave [m]")
        ax_a.set_ylabel("pitch [deg]")
        ax_a.set_xlabel("distance from north anchorage [km]")
        for ax in (ax_h, ax_a):
            _mark_spans(ax, self.spans, names=ax is ax_h)
            ax.grid(alpha=0.3)
        ax_h.set_title(f"{self.bridge}: flutter mode at {self.flutter_speed_m_s:.2f} m/s, "
                       f"{self.flutter_frequency_hz:.4f} Hz", fontsize=10)

        def frame(k):
            rot = np.exp(2j * np.pi * k / frames)
            lh.set_ydata((self.heave_m * rot).real)
            la.set_ydata(np.degrees((self.pitch_rad * rot).real))
            return lh, la

        FuncAnimation(fig, frame, frames=frames, blit=True).save(
            path, writer=PillowWriter(fps=fps))
        plt.close(fig)
        return path


def _unwrap_deg(phase_deg: np.ndarray) -> np.ndarray:
    """Phase [deg] unwrapped along the span where finite, shifted by whole turns so that its
    median lies in [-180, 180): no spurious +-180 jumps in the plot."""
    out = np.array(phase_deg, dtype=float)
    ok = np.isfinite(out)
    if ok.sum() > 1:
        u = np.degrees(np.unwrap(np.radians(out[ok])))
        u -= 360.0 * np.floor((np.median(u) + 180.0) / 360.0)
        out[ok] = u
    return out


@takes_bridge
def flutter_mode_shape(bridge: BridgeArg, speeds, n_modes: int,
                       order: str = "modal", rfa: str = "rfa4",
                       peak_pitch_rad: float = PEAK_PITCH_RAD) -> FlutterModeShape:
    """The flutter mode of ``spec`` along the span (module docstring).

    Parameters
    ----------
    bridge : str, os.PathLike or BridgeSpec
    speeds : array_like
        Wind-speed grid [m/s] of the sweep that finds the flutter speed.
    n_modes : int
        Retained vertical + torsional modes (the analyses' default is
        :data:`bridgeflap.model.analysis.DEFAULT_MODES`).
    order, rfa : str
        As :func:`bridgeflap.model.analysis.bridge_system`.
    peak_pitch_rad : float
        Normalisation [rad]: the largest pitch amplitude of the returned shape.

    Returns
    -------
    FlutterModeShape
        The complex heave [m] and pitch [rad] along the deck at the flutter speed, normalised to
        ``peak_pitch_rad``; ``plot()``, ``to_dataframe()``.

    Raises
    ------
    BridgeflapError
        When the sweep finds no converged flutter speed (its status is in the message).
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
    u = check_speeds(speeds)
    modal = solve(assemble(spec))
    system = statespace.spec_system(spec, modal.structural_basis(int(n_modes)), order, rfa)
    sw = sweep(system, u)
    if sw.flutter.status != CONVERGED:
        raise BridgeflapError(f"no flutter mode: flutter status {sw.flutter.status}")
    lam, v = critical_eigenvector(system, sw.flutter.speed)
    labels = system.basis.labels
    q = v[system.index.q]
    f = deck_fields(modal, labels, q)
    c = _normaliser(f["node_pitch_rad"], peak_pitch_rad)
    st = modal.structure
    freqs = {lab: modal.find(lab).frequency_hz for lab in labels}
    return FlutterModeShape(
        bridge=spec.name, status=CONVERGED, flutter_speed_m_s=sw.flutter.speed,
        flutter_frequency_hz=sw.flutter.frequency_hz, eigenvalue=lam,
        x_m=st.global_x(st.node_span, st.node_x), node_span=np.asarray(st.node_span),
        heave_m=c * f["node_heave_m"], pitch_rad=c * f["node_pitch_rad"],
        strip_x_m=st.global_x(st.strip_span, st.strip_x),
        strip_heave_m=c * f["strip_heave_m"], strip_pitch_rad=c * f["strip_pitch_rad"],
        q=c * q, labels=tuple(labels), participation=dict(sw.critical_participation),
        tower_x_m=tower_positions_m(spec), half_chord_m=spec.deck.half_chord_m,
        n_modes=int(n_modes), order=order, peak_pitch_rad=float(peak_pitch_rad),
        mode_frequencies_hz=freqs, spans=span_extents_m(spec),
        divergence_speed_m_s=sw.divergence.speed)


# ------------------------------------------------------------ frequency-ratio mode shapes


@dataclass(frozen=True)
class RatioModes:
    """The modes a selection rule (:func:`ratio_modes`) picks, per erected fraction.

    ``stages`` holds one dict per fraction: ``erected_fraction``, ``stage``, the stage's mesh
    nodes (``x_m`` from the north anchorage [m], ``node_span``), and per family (``vertical``,
    ``torsional``) the ``Mode`` picked (or None), its normalised node field and the
    uniform-motion deck share it is measured against.
    """

    bridge: str
    side_spans: str
    stages: tuple
    tower_x_m: tuple
    spans: tuple = ()

    def summary(self) -> list[dict]:
        """JSON-ready rows: label, frequency [Hz], deck share and its floor per family."""
        rows = []
        for s in self.stages:
            row = {"erected_fraction": s["erected_fraction"], "stage": s["stage"]}
            for fam in ("vertical", "torsional"):
                m = s[fam]
                row.update({f"{fam}_mode": m.label if m else "",
                            f"{fam}_frequency_hz": m.frequency_hz if m else float("nan"),
                            f"{fam}_deck_share": m.deck_share if m else float("nan"),
                            f"{fam}_uniform_deck_share": s[f"{fam}_uniform_deck_share"]})
            rows.append(row)
        return rows


def ratio_modes(spec: BridgeSpec, select, fractions=(0.2, 0.5, 0.8, 1.0),
                side_spans: str | None = None, erection_gj_factor: float = 0.5) -> RatioModes:
    """The modes ``select(modal, family)`` picks at each erected fraction [-].

    ``select`` is the frequency-ratio rule,
    :func:`bridgeflap.model.analysis.first_symmetric_deck_mode`, or any function of a
    :class:`~bridgeflap.model.structure.modes.ModalModel` and a family name returning a
    :class:`~bridgeflap.model.structure.modes.Mode` or None.
    """
    stages = []
    for f in fractions:
        s = spec.erected(float(f), side_spans=side_spans)
        modal = solve(assemble(s, erection_gj_factor=erection_gj_factor))
        st = modal.structure
        row = {"erected_fraction": float(f),
               "stage": "closed deck, temporary joints" if f >= 1.0 else "erecting",
               "deck_extent_m": _deck_extent(s),
               # the mesh follows the erected deck's ends: nodes differ between stages
               "x_m": st.global_x(st.node_span, st.node_x), "node_span": np.asarray(st.node_span)}
        for fam in ("vertical", "torsional"):
            m = select(modal, fam)
            row[fam] = m
            row[f"{fam}_uniform_deck_share"] = st.families[fam].uniform_deck_share
            y = None
            if m is not None:
                y = st.families[fam].node_map @ modal.shape(modal.modes.index(m))
                y = y / _main_span_scale(st, y)
            row[f"{fam}_field"] = y
        stages.append(row)
    side = spec.erected(1.0, side_spans=side_spans).side_span_decks
    return RatioModes(spec.name, side, tuple(stages), tower_positions_m(spec),
                      span_extents_m(spec))


def _main_span_scale(st, y: np.ndarray) -> float:
    """Largest ``|y|`` in the main span, signed so that the mid-span value is positive."""
    main = st.node_span == st.main_span
    xm = st.node_x[main]
    mid = y[main][int(np.argmin(np.abs(xm - 0.5 * st.spec.main_span.length_m)))]
    peak = float(np.max(np.abs(y[main])))
    return (peak if mid >= 0 else -peak) or 1.0


def _deck_extent(spec: BridgeSpec) -> tuple[float, float]:
    """Global x [m] of the erected main-span deck's ends (symmetric about mid-span)."""
    start = sum(s.length_m for s in spec.spans[:spec.main_span_index])
    L = spec.main_span.length_m
    half = 0.5 * spec.erected_fraction * L
    return (start + 0.5 * L - half, start + 0.5 * L + half)


def plot_ratio_modes(res: RatioModes, axes=None):
    """Vertical (top) and torsional (bottom) picked modes, one line per fraction; the erected
    main-span deck of each stage is drawn as a bar under the curves."""
    import matplotlib.pyplot as plt

    if axes is None:
        _, axes = plt.subplots(2, 1, figsize=(9, 7), sharex=True, layout="constrained")
    styles = ("-", "--", "-.", ":", (0, (5, 1, 1, 1, 1, 1)))
    for ax, fam in zip(axes, ("vertical", "torsional"), strict=True):
        top, low = 1.0, -1.0
        bars = []
        for k, s in enumerate(res.stages):
            y, m = s[f"{fam}_field"], s[fam]
            col = f"C{k}"
            if y is None:
                continue
            top, low = max(top, float(np.max(y))), min(low, float(np.min(y)))
            share = m.deck_share / s[f"{fam}_uniform_deck_share"]
            lab = (f"{100 * s['erected_fraction']:.0f} %: {m.label} {m.frequency_hz:.3f} Hz, "
                   f"deck share {share:.2f} x uniform")
            x, spans = s["x_m"] / 1000.0, s["node_span"]
            for sp in np.unique(spans):
                sel = spans == sp
                ax.plot(x[sel], y[sel], color=col, lw=1.6, ls=styles[k % len(styles)],
                        label=lab if sp == spans[0] else None)
            bars.append((s["deck_extent_m"], col))
        for k, ((a, b), col) in enumerate(bars):
            ax.plot([a / 1000, b / 1000], [low - 0.12 - 0.08 * k] * 2, color=col, lw=4,
                    solid_capstyle="butt")
        _mark_spans(ax, res.spans, y=0.01)
        ax.axhline(0, color="k", lw=0.6)
        ax.set_ylim(low - 0.3 - 0.08 * len(bars), top + 0.1 + 0.12 * len(res.stages))
        ax.set_ylabel(f"{fam} deck field [-]\n(main-span peak 1, + at mid-span)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left", ncol=2)
    axes[0].set_title(f"{res.bridge}: first symmetric deck modes picked by the frequency-ratio "
                      f"rule\n(half GJ, EI = 0; side spans {res.side_spans}; bars: erected "
                      "main-span deck; dotted: towers)", fontsize=10)
    axes[-1].set_xlabel("distance from north (Hessle) anchorage [km]")
    return axes
