"""High-level analyses on a bridge definition: modes, flutter, erection, frequency ratio.

Plain functions of a :class:`~model.spec.BridgeSpec` and numeric grids (arrays of wind speeds
[m/s] and erected fractions [-]); reading grid text and the default grids belong to
:mod:`design` (:mod:`design.options`, :mod:`design.analyses`). Each returns a frozen result
object with ``summary()`` (JSON-ready numbers with units in the key names and statuses) and
``plot()``. Conventions: see :mod:`model`.

>>> from model.spec import load_bridge                    # doctest: +SKIP
>>> res = flutter(load_bridge("humber"), np.arange(0.0, 85.5, 0.5))  # doctest: +SKIP
>>> res.summary()["flutter_speed_m_s"]                     # doctest: +SKIP
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from model import statespace
from model.control import Controller
from model.errors import BridgeflapError, BridgeflapInputError
from model.fe import assemble
from model.flaps import DEFAULT_FLAP_CHORD_M, closed_loop_model
from model.modes import ModalModel, solve
from model.spec import BridgeSpec, check_fraction
from model.stability import StabilitySweep, check_speeds, sweep

#: retained vertical + torsional modes of every analysis unless told otherwise
DEFAULT_MODES = 16  # truncation study (bench/stability.py): 66.12 m/s at 16-20, 66.14 at 24-60


def modal_model(spec: BridgeSpec, count: int | None = None,
                erection_gj_factor: float = 0.5) -> ModalModel:
    """Cable statics, FE assembly and modes of ``spec``."""
    return solve(assemble(spec, erection_gj_factor=erection_gj_factor), count)


def bridge_system(spec: BridgeSpec, n_modes: int = DEFAULT_MODES, order: str = "modal",
                  rfa: str = "rfa4", modal: ModalModel | None = None,
                  ) -> tuple[ModalModel, statespace.AeroelasticSystem]:
    """Modal model and aeroelastic state space of ``spec``."""
    if int(n_modes) < 1:
        raise BridgeflapInputError("modes", f"must be at least 1, got {n_modes}")
    modal = modal_model(spec) if modal is None else modal
    system = statespace.spec_system(spec, modal.structural_basis(int(n_modes)), order, rfa)
    return modal, system


@dataclass(frozen=True)
class FlutterResult:
    """Stability sweep of one bridge state."""

    spec: BridgeSpec
    sweep: StabilitySweep
    n_modes: int
    order: str
    rfa: str
    n_states: int
    modes: tuple = ()

    def summary(self) -> dict:
        """JSON-ready numbers (units in the key names) and statuses of the sweep."""
        s = self.sweep.summary()
        label = self.sweep.critical_branch
        crit = {"label": label, "family": "", "symmetry": "", "frequency_hz": float("nan")}
        if label:
            fam = {"V": "vertical", "T": "torsional", "L": "lateral"}[label[0]]
            sym = {"S": "symmetric", "A": "antisymmetric"}[label[1]]
            crit = {"label": label, "family": fam, "symmetry": sym,
                    "frequency_hz": self._mode_frequency(label)}
        s.update({"bridge": self.spec.name, "erected_fraction": self.spec.erected_fraction,
                  "critical_branch": crit, "modes_retained": self.n_modes,
                  "order": self.order, "rfa": self.rfa, "states": self.n_states,
                  "half_chord_m": self.spec.deck.half_chord_m,
                  "added_inertia": self.spec.aero.added_inertia})
        return s

    def _mode_frequency(self, label: str) -> float:
        """In-vacuo natural frequency [Hz] of the structural mode that labels the branch."""
        for m in self.modes:
            if m.label == label:
                return m.frequency_hz
        return float("nan")

    def plot(self, axes=None):
        """Root locus and damping/frequency against speed."""
        return self.sweep.plot(axes, title=f"{self.spec.name} (erected "
                                           f"{self.spec.erected_fraction:.2f}):")


def flutter(spec: BridgeSpec, speeds, n_modes: int = DEFAULT_MODES,
            order: str = "modal", rfa: str = "rfa4") -> FlutterResult:
    """Flutter and torsional divergence of ``spec`` over a grid of wind speeds [m/s]."""
    u = check_speeds(speeds)
    modal, system = bridge_system(spec, n_modes, order, rfa)
    return FlutterResult(spec, sweep(system, u), int(n_modes), order, rfa, system.n_states,
                         modal.modes)


@dataclass(frozen=True)
class _StagesResult:
    """Rows of numbers (units in the key names) per erected fraction of one bridge."""

    bridge: str
    stages: tuple

    def summary(self) -> dict:
        """JSON-ready ``{"bridge", "stages"}``, one dict per erected fraction."""
        return {"bridge": self.bridge, "stages": list(self.stages)}


def _axes(ax):
    """``ax``, or the axes of a new 6 x 4 in figure."""
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=(6, 4))
    return ax


@dataclass(frozen=True)
class ErectionResult(_StagesResult):
    """Flutter and divergence speeds [m/s] and statuses against the erected fraction."""

    def plot(self, ax=None):
        """Flutter and divergence speed against deck completion (seed Fig. 3 right)."""
        ax = _axes(ax)
        f = np.array([s["erected_fraction"] for s in self.stages]) * 100
        uf = np.array([np.nan if s["flutter_speed_m_s"] is None else s["flutter_speed_m_s"]
                       for s in self.stages], dtype=float)
        ud = np.array([np.nan if s["divergence_speed_m_s"] is None else s["divergence_speed_m_s"]
                       for s in self.stages], dtype=float)
        ax.plot(f, uf, "o-", label="flutter")
        ax.plot(f, ud, "s--", label="torsional divergence")
        ax.set_xlabel("deck erected [% of main span]")
        ax.set_ylabel("critical wind speed [m/s]")
        ax.set_title(f"{self.bridge}: stability during erection\n"
                     "(half GJ, zero EI while erecting; full bridge at 100 %)")
        ax.grid(alpha=0.3)
        ax.legend()
        return ax


def erection(spec: BridgeSpec, fractions, speeds, n_modes: int = DEFAULT_MODES,
             progress=None) -> ErectionResult:
    """Flutter/divergence at each erected fraction [-] (mid-span outwards, half GJ, zero EI)
    over a grid of wind speeds [m/s]."""
    fr = _fractions(fractions)
    speeds = check_speeds(speeds)
    stages = []
    for f in fr:
        s = spec.erected(float(f))
        try:
            r = flutter(s, speeds, n_modes).summary()
            stage = {k: r[k] for k in ("flutter_speed_m_s", "flutter_frequency_hz",
                                       "flutter_status", "divergence_speed_m_s",
                                       "divergence_status", "critical_branch_label")}
        except BridgeflapError as exc:
            stage = {"flutter_speed_m_s": float("nan"), "flutter_status": f"failed: {exc}",
                     "divergence_speed_m_s": float("nan"), "divergence_status": f"failed: {exc}"}
        stage["erected_fraction"] = float(f)
        stages.append(stage)
        if progress:
            progress(f)
    return ErectionResult(spec.name, tuple(stages))


@dataclass(frozen=True)
class FrequencyRatioResult(_StagesResult):
    """First torsional over first vertical symmetric frequency [-] against erected fraction."""

    def plot(self, ax=None):
        """Seed Fig. 2 style plot."""
        ax = _axes(ax)
        f = [100 * s["erected_fraction"] for s in self.stages]
        ax.plot(f, [s["ratio_full_gj"] for s in self.stages], "o-", label="full GJ")
        ax.plot(f, [s["ratio_half_gj"] for s in self.stages], "s--", label="half GJ")
        ax.set_xlabel("deck erected [% of main span]")
        ax.set_ylabel("f(TS1) / f(VS1) [-]")
        ax.set_title(f"{self.bridge}: torsion-to-bending frequency ratio (EI = 0 while erecting)")
        ax.grid(alpha=0.3)
        ax.legend()
        return ax


def _fractions(fractions) -> np.ndarray:
    try:
        fr = np.asarray(fractions, dtype=float).ravel()
    except (TypeError, ValueError):
        raise BridgeflapInputError("fractions", "not numeric") from None
    if fr.size == 0:
        raise BridgeflapInputError("fractions", "empty grid")
    for f in fr:
        check_fraction(f)
    return fr


def first_symmetric_frequency_hz(modal: ModalModel, family: str) -> float:
    """Frequency [Hz] of the first symmetric ``family`` mode living mainly in the main span.

    Main-span share above 0.5; NaN when there is none.
    """
    for m in modal.modes:
        if m.family == family and m.symmetry == "symmetric" and m.main_span_share > 0.5:
            return m.frequency_hz
    return float("nan")


def frequency_ratio(spec: BridgeSpec, fractions) -> FrequencyRatioResult:
    """``f(TS1)/f(VS1)`` with half and full deck GJ against erected fraction [-] (seed Fig. 2).

    Symmetric modes living mainly in the main span are used (main-span share > 0.5).
    """
    fr = _fractions(fractions)
    stages = []
    for f in fr:
        s = spec.erected(float(f))
        row = {"erected_fraction": float(f)}
        for key, factor in (("ratio_full_gj", 1.0), ("ratio_half_gj", 0.5)):
            m = modal_model(s, erection_gj_factor=factor)
            ts1 = first_symmetric_frequency_hz(m, "torsional")
            vs1 = first_symmetric_frequency_hz(m, "vertical")
            row[key] = ts1 / vs1
            if key == "ratio_half_gj":
                row["ts1_hz"] = ts1
                row["vs1_hz"] = vs1
        stages.append(row)
    return FrequencyRatioResult(spec.name, tuple(stages))


# ------------------------------------------------------------------ closed loop (flaps)


@dataclass(frozen=True)
class ClosedLoopFlutterResult:
    """Closed-loop stability sweep plus the open-loop reference."""

    base: object            # model.analysis.FlutterResult of the closed loop
    open_loop: object       # model.analysis.FlutterResult without flaps
    controller: Controller

    def summary(self) -> dict:
        """Same keys as :meth:`model.analysis.FlutterResult.summary`, plus closed-loop info.

        ``divergence_static_speed_m_s`` is the closed-loop static check (static flap loads of
        ``beta = K(0) alpha``); the open-loop values are under ``open_loop_*``.
        """
        s = self.base.summary()
        ol = self.open_loop.summary()
        k = self.controller.compensator
        s.update({
            "closed_loop": True,
            "flap_count": self.controller.n_flaps,
            "compensator": {"b2": k.b2, "b1": k.b1, "b0": k.b0, "a2": k.a2, "a1": k.a1},
            "max_gain": k.max_gain(),
            "gain_limit": self.controller.gain_limit,
            "open_loop_flutter_speed_m_s": ol["flutter_speed_m_s"],
            "open_loop_flutter_status": ol["flutter_status"],
            "open_loop_divergence_speed_m_s": ol["divergence_speed_m_s"],
            "open_loop_divergence_status": ol["divergence_status"],
        })
        return s

    def plot(self, axes=None):
        """Closed-loop root locus and damping/frequency against speed."""
        return self.base.sweep.plot(axes, title=f"{self.base.spec.name} with "
                                                f"{self.controller.n_flaps} flap pairs:")


def closed_loop_flutter(spec, controller: Controller, speeds, n_modes: int = DEFAULT_MODES,
                        flap_chord_m: float = DEFAULT_FLAP_CHORD_M) -> ClosedLoopFlutterResult:
    """Closed-loop flutter/divergence sweep (and the open-loop one for reference).

    ``speeds`` [m/s] is an array (strings are parsed by the CLI).
    """
    u = check_speeds(speeds)
    model = closed_loop_model(spec, controller.flap_strip_positions_m, controller.flap_width_m,
                              n_modes, flap_chord_m, controller.leading_edge,
                              controller.trailing_edge)
    system = model.open_loop
    cl = model.system(controller.compensator)
    base = FlutterResult(spec, sweep(cl, u), int(n_modes), "modal", "rfa4", cl.n_states)
    ol = FlutterResult(spec, sweep(system, u), int(n_modes), "modal", "rfa4", system.n_states)
    return ClosedLoopFlutterResult(base, ol, controller)
