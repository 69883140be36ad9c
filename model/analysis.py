"""High-level analyses on a bridge definition: the operations of the CLI as plain functions.

Each returns a frozen result object with ``summary()`` (JSON-ready numbers with units in the key
names and statuses) and ``plot()``. Conventions: see :mod:`model`.

>>> from model.spec import load_bridge                    # doctest: +SKIP
>>> res = flutter(load_bridge("humber"))                   # doctest: +SKIP
>>> res.summary()["flutter_speed_m_s"]                     # doctest: +SKIP
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from model import statespace
from model.errors import BridgeflapError, BridgeflapInputError
from model.fe import assemble
from model.modes import ModalModel, solve
from model.spec import BridgeSpec, check_fraction
from model.stability import StabilitySweep, check_speeds, sweep

DEFAULT_MODES = 16  # truncation study (bench/stability.py): 66.12 m/s at 16-20, 66.14 at 24-60
DEFAULT_SPEEDS = "0:85:0.5"
DEFAULT_FRACTIONS = "0.1:1.0:0.1"


def parse_range(text: str, field: str, minimum: float | None = None) -> np.ndarray:
    """Parse ``start:stop:step`` (inclusive of ``stop``) or a comma list into an array."""
    try:
        if ":" in str(text):
            parts = [float(p) for p in str(text).split(":")]
            if len(parts) != 3:
                raise ValueError
            start, stop, step = parts
            if not (np.isfinite(step) and step > 0) or stop < start:
                raise BridgeflapInputError(
                    field, f"empty grid {text!r} (need start <= stop, step > 0)")
            n = int(np.floor((stop - start) / step + 1e-9)) + 1
            if n > 100000:
                raise BridgeflapInputError(field, f"grid {text!r} has too many points")
            values = start + step * np.arange(n)
        else:
            values = np.array([float(p) for p in str(text).split(",") if p.strip()])
    except BridgeflapInputError:
        raise
    except ValueError:
        raise BridgeflapInputError(field, f"not a number grid: {text!r}") from None
    if values.size == 0:
        raise BridgeflapInputError(field, "empty grid")
    if not np.all(np.isfinite(values)):
        raise BridgeflapInputError(field, "values must be finite")
    if minimum is not None and np.any(values < minimum):
        raise BridgeflapInputError(field, f"values must be >= {minimum} (got {values.min()})")
    return values


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
        """The ``bridgeflap flutter`` JSON contract."""
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


def flutter(spec: BridgeSpec, speeds=DEFAULT_SPEEDS, n_modes: int = DEFAULT_MODES,
            order: str = "modal", rfa: str = "rfa4") -> FlutterResult:
    """Flutter and torsional divergence of ``spec`` over a speed grid [m/s]."""
    u = parse_range(speeds, "speeds", 0.0) if isinstance(speeds, str) else check_speeds(speeds)
    modal, system = bridge_system(spec, n_modes, order, rfa)
    return FlutterResult(spec, sweep(system, u), int(n_modes), order, rfa, system.n_states,
                         modal.modes)


@dataclass(frozen=True)
class ErectionResult:
    """Flutter and divergence against the erected fraction of the main span."""

    bridge: str
    stages: tuple

    def summary(self) -> dict:
        """The ``bridgeflap erection`` JSON contract."""
        return {"bridge": self.bridge, "stages": list(self.stages)}

    def plot(self, ax=None):
        """Flutter and divergence speed against deck completion (seed Fig. 3 right)."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 4))
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


def erection(spec: BridgeSpec, fractions=DEFAULT_FRACTIONS, speeds=DEFAULT_SPEEDS,
             n_modes: int = DEFAULT_MODES, progress=None) -> ErectionResult:
    """Flutter/divergence at each erected fraction (mid-span outwards, half GJ, zero EI)."""
    fr = (parse_range(fractions, "fractions") if isinstance(fractions, str)
          else np.asarray(fractions))
    for f in fr:
        check_fraction(f)
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
class FrequencyRatioResult:
    """First torsional over first vertical symmetric frequency against erected fraction."""

    bridge: str
    stages: tuple

    def summary(self) -> dict:
        """The ``bridgeflap frequency-ratio`` JSON contract."""
        return {"bridge": self.bridge, "stages": list(self.stages)}

    def plot(self, ax=None):
        """Seed Fig. 2 style plot."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 4))
        f = [100 * s["erected_fraction"] for s in self.stages]
        ax.plot(f, [s["ratio_full_gj"] for s in self.stages], "o-", label="full GJ")
        ax.plot(f, [s["ratio_half_gj"] for s in self.stages], "s--", label="half GJ")
        ax.set_xlabel("deck erected [% of main span]")
        ax.set_ylabel("f(TS1) / f(VS1) [-]")
        ax.set_title(f"{self.bridge}: torsion-to-bending frequency ratio (EI = 0 while erecting)")
        ax.grid(alpha=0.3)
        ax.legend()
        return ax


def _first(modal: ModalModel, family: str) -> float:
    for m in modal.modes:
        if m.family == family and m.symmetry == "symmetric" and m.main_span_share > 0.5:
            return m.frequency_hz
    return float("nan")


def frequency_ratio(spec: BridgeSpec, fractions="0.1:1.0:0.05") -> FrequencyRatioResult:
    """``f(TS1)/f(VS1)`` with half and full deck GJ during erection (seed Fig. 2).

    Symmetric modes living mainly in the main span are used (main-span share > 0.5).
    """
    fr = (parse_range(fractions, "fractions") if isinstance(fractions, str)
          else np.asarray(fractions))
    for f in fr:
        check_fraction(f)
    stages = []
    for f in fr:
        s = spec.erected(float(f))
        row = {"erected_fraction": float(f)}
        for key, factor in (("ratio_full_gj", 1.0), ("ratio_half_gj", 0.5)):
            m = modal_model(s, erection_gj_factor=factor)
            row[key] = _first(m, "torsional") / _first(m, "vertical")
            if key == "ratio_half_gj":
                row["ts1_hz"] = _first(m, "torsional")
                row["vs1_hz"] = _first(m, "vertical")
        stages.append(row)
    return FrequencyRatioResult(spec.name, tuple(stages))
