"""Analyses over erection stages: flutter and divergence against the erected fraction, and
the torsion/bending frequency ratio (:mod:`bridgeflap.model.analysis`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bridgeflap.model.analysis.core import flutter, modal_model
from bridgeflap.model.errors import BridgeflapError, BridgeflapInputError
from bridgeflap.model.results import ResultData, finite_extreme
from bridgeflap.model.stability.sweeps import check_speeds
from bridgeflap.model.structure.bridge_arg import BridgeArg, takes_bridge
from bridgeflap.model.structure.modes import ModalModel
from bridgeflap.model.structure.spec import BridgeSpec, check_fraction
from bridgeflap.model.vocabulary import DEFAULT_MODES


@dataclass(frozen=True)
class _StagesResult(ResultData):
    """Rows of numbers (units in the key names) per erected fraction of one bridge, plus the
    completed bridge as its own row (joints closed: full GJ and EI)."""

    bridge: str
    stages: tuple
    completed: dict = field(default_factory=dict)
    side_spans: str = ""

    def summary(self) -> dict:
        """JSON-ready ``{"bridge", "side_spans", "stages", "completed_bridge"}``.

        Returns
        -------
        dict
            ``bridge``, ``side_spans`` (the side-span sequence), ``stages`` (one dict per erected
            fraction, units in the key names) and ``completed_bridge`` (the same keys).
        """
        return {"bridge": self.bridge, "side_spans": self.side_spans,
                "stages": list(self.stages), "completed_bridge": dict(self.completed)}

    def _headline(self) -> dict:
        """Bridge, stage count, and of each key in ``_HEADLINE_KEYS`` the lowest value over the
        stages and the completed bridge's (where the rows hold it)."""
        out = {"bridge": self.bridge, "side_spans": self.side_spans, "stages": len(self.stages)}
        for k in self._HEADLINE_KEYS:
            vals = [_nan(r.get(k)) for r in self.stages if k in r]
            if vals:
                out[f"lowest_{k}"] = finite_extreme(vals, lowest=True)
            if k in self.completed:
                out[f"completed_{k}"] = self.completed[k]
        return out

    def _rows(self) -> list[dict]:
        """The stages, then the completed bridge as its own row."""
        return [dict(r) for r in self.stages] + ([dict(self.completed)] if self.completed else [])


def _nan(v) -> float:
    return float("nan") if v is None else float(v)


@dataclass(frozen=True)
class ErectionResult(_StagesResult):
    """Flutter and divergence speeds [m/s] and statuses against the erected fraction."""

    _HEADLINE_KEYS = ("critical_speed_m_s", "flutter_speed_m_s", "divergence_speed_m_s")

    def plot(self, ax=None):
        """Flutter and divergence speed against deck completion (the paper's Fig. 3 right):
        :func:`bridgeflap.model.stability.plots.erection_speeds`.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        from bridgeflap.model.stability.plots import erection_speeds

        return erection_speeds(self, ax)


_STAGE_KEYS = ("flutter_speed_m_s", "flutter_frequency_hz", "flutter_status",
               "divergence_speed_m_s", "divergence_status", "critical_speed_m_s",
               "critical_mechanism", "critical_branch_label", "flutter_onset",
               "second_critical_branch_label", "second_flutter_speed_m_s",
               "second_flutter_status")


def _stage(spec: BridgeSpec, speeds, n_modes: int) -> dict:
    try:
        r = flutter(spec, speeds, n_modes).summary()
        return {k: r[k] for k in _STAGE_KEYS}
    except BridgeflapError as exc:
        return {"flutter_speed_m_s": float("nan"), "flutter_frequency_hz": float("nan"),
                "flutter_status": f"failed: {exc}",
                "divergence_speed_m_s": float("nan"), "divergence_status": f"failed: {exc}",
                "critical_speed_m_s": float("nan"), "critical_mechanism": "none",
                "critical_branch_label": "", "flutter_onset": "",
                "second_critical_branch_label": "", "second_flutter_speed_m_s": float("nan"),
                "second_flutter_status": "not_evaluated"}


@takes_bridge
def erection(bridge: BridgeArg, fractions, speeds, n_modes: int = DEFAULT_MODES,
             progress=None, side_spans: str | None = None, workers: int = 1) -> ErectionResult:
    """Flutter and divergence at each erection stage over a grid of wind speeds.

    Each stage is :meth:`~bridgeflap.model.BridgeSpec.erected`: the main-span deck from mid-span
    outwards, half GJ and zero EI (temporary joints), the side spans as ``side_spans``; a
    fraction of 1 is the closed deck before its joints are made. The completed bridge
    (:meth:`~bridgeflap.model.BridgeSpec.completed`) is reported separately.

    Parameters
    ----------
    bridge : str, path-like or BridgeSpec
        A built-in name, a bridge TOML file or a :class:`~bridgeflap.model.BridgeSpec`.
    fractions : sequence of float
        Erected fractions [-] of the main-span deck, each in (0, 1].
    speeds : array_like or str
        Wind speeds [m/s] of every stage's sweep (as :func:`flutter`).
    n_modes : int, default 30
        Retained vertical + torsional modes.
    progress : callable, optional
        ``str -> None``, one line per stage.
    side_spans : {"bare", "in_place", "with_main"}, optional
        The side-span decks while erecting (default: the bridge file's ``[erection]``).
    workers : int, default 1
        Worker processes for the stages (the same numbers for any count; inside a daemonic
        process, such as a Dask worker, the stages run one after another).

    Returns
    -------
    ErectionResult
        One row per stage (``to_dataframe()``, ``table()``), the completed bridge, the lowest
        critical speed, ``plot()`` (speeds against erected fraction).

    Raises
    ------
    BridgeflapInputError
        A bad bridge, fraction, speed grid, ``side_spans`` or ``workers``.

    Examples
    --------
    >>> from bridgeflap import model
    >>> res = model.erection("humber", [0.5, 1.0], "0:90:2", n_modes=6)
    >>> len(res.to_dataframe())  # two stages and the completed bridge
    3
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
    fr = _fractions(fractions)
    speeds = check_speeds(speeds)
    specs = [spec.erected(float(f), side_spans=side_spans) for f in fr] + [spec.completed()]
    results = _stages(specs, speeds, n_modes, workers,
                      lambda i: progress(float(fr[i])) if progress and i < len(fr) else None)
    stages = []
    for f, stage in zip(fr, results[:-1], strict=True):
        stage["erected_fraction"] = float(f)
        stage["stage"] = "closed deck, temporary joints" if f >= 1.0 else "erecting"
        stages.append(stage)
    done = results[-1]
    done.update({"erected_fraction": 1.0, "stage": "completed bridge"})
    side = spec.erected(1.0, side_spans=side_spans).side_span_decks
    return ErectionResult(spec.name, tuple(stages), done, side)


def _stages(specs, speeds, n_modes: int, workers: int, done) -> list[dict]:
    """:func:`_stage` of every spec, in order; ``done(i)`` as each (in order) is ready."""
    import multiprocessing

    workers = min(int(workers), len(specs))
    if workers <= 1 or multiprocessing.current_process().daemon:
        out = []
        for i, s in enumerate(specs):
            out.append(_stage(s, speeds, n_modes))
            done(i)
        return out
    from bridgeflap.model.workers import process_pool

    with process_pool(workers) as ex:
        futures = [ex.submit(_stage, s, speeds, n_modes) for s in specs]
        out = []
        for i, fut in enumerate(futures):
            out.append(fut.result())
            done(i)
        return out


@dataclass(frozen=True)
class FrequencyRatioResult(_StagesResult):
    """First torsional over first vertical symmetric deck frequency [-] against erected
    fraction, with half and with full GJ during erection, and the completed bridge."""

    _HEADLINE_KEYS = ("ratio_full_gj", "ratio_half_gj", "ratio")

    def plot(self, ax=None):
        """The paper's Fig. 2 style plot
        (:func:`bridgeflap.model.structure.plots.frequency_ratio`).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        from bridgeflap.model.structure.plots import frequency_ratio

        return frequency_ratio(self, ax)


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


#: a deck mode carries at least this fraction of the uniform-motion deck share of its energy
DECK_SHARE_FACTOR = 0.5


def fundamental_content(modal: ModalModel, family: str) -> dict:
    """Share of each ``family`` mode that is the main-span deck's fundamental shape.

    A deck-mass weighted modal assurance criterion against the reference shape
    ``psi = sin(pi x / L)`` on the main span (zero elsewhere):
    ``MAC_j = (v_j' M_deck psi)^2 / ((v_j' M v_j)(psi' M_deck psi))`` with ``M`` the family's whole
    mass (deck and cables). A pure deck fundamental reaches about the uniform-motion deck share;
    a bare-cable mode, an antisymmetric mode or one with three half-waves stays near zero.
    Returns ``{index into modal.modes: MAC}`` for the family's modes.
    """
    st = modal.structure
    fam = st.families[family]
    sel = st.node_span == st.main_span
    psi_node = np.zeros(len(st.node_x))
    psi_node[sel] = np.sin(np.pi * st.node_x[sel] / st.spec.main_span.length_m)
    psi = np.linalg.lstsq(fam.node_map, psi_node, rcond=None)[0]
    Md = fam.M_deck if fam.M_deck is not None else fam.M
    ref = float(psi @ Md @ psi)
    out = {}
    for col, i in enumerate(modal.family_index[family]):
        v = modal.shapes[family][:, col]
        out[i] = float((v @ Md @ psi) ** 2 / ((v @ fam.M @ v) * ref)) if ref > 0 else 0.0
    return out


def first_symmetric_deck_mode(modal: ModalModel, family: str):
    """The mode that is the main-span deck's first symmetric ``family`` mode, or None.

    Selection rule: among the symmetric modes whose deck kinetic-energy share is at least
    :data:`DECK_SHARE_FACTOR` (one half) of the main span's uniform-motion share (its deck mass
    over its deck-plus-cable mass,
    :attr:`bridgeflap.model.structure.fe.FamilyMatrices.uniform_deck_share`; this passes over the
    bare-cable modes of early erection stages), the one with the largest
    :func:`fundamental_content` (the most main-span deck fundamental in it). A selection by
    frequency order alone fails where the deck's TS1 hybridises with the torsion of a bare
    side-span cable of nearly the same frequency (Humber with bare side spans: at 35 % the
    main-span share rule picked TS4 at 0.889 Hz, and at 100 % a 0.517 Hz mode shaped like TS2):
    then the hybrid with the larger content is picked, and :func:`_ratio_row` flags the stage
    as hybrid.
    """
    mac = fundamental_content(modal, family)
    floor = DECK_SHARE_FACTOR * modal.structure.families[family].uniform_deck_share
    cand = [i for i in modal.family_index[family]
            if modal.modes[i].symmetry == "symmetric" and modal.modes[i].deck_share >= floor]
    if not cand:
        return None
    return modal.modes[max(cand, key=lambda i: mac[i])]


def _hybrid(modal: ModalModel, family: str, picked) -> tuple[float, bool]:
    """Fundamental content of the pick and whether another candidate holds at least half of it
    (the deck mode is split between hybrids)."""
    mac = fundamental_content(modal, family)
    k = modal.modes.index(picked)
    others = [v for i, v in mac.items() if i != k and modal.modes[i].symmetry == "symmetric"]
    return mac[k], bool(others) and max(others) >= 0.5 * mac[k]


def first_symmetric_frequency_hz(modal: ModalModel, family: str) -> float:
    """Frequency [Hz] of :func:`first_symmetric_deck_mode`; NaN when there is none."""
    m = first_symmetric_deck_mode(modal, family)
    return float("nan") if m is None else m.frequency_hz


def _ratio_row(modal: ModalModel) -> dict:
    ts, vs = (first_symmetric_deck_mode(modal, fam) for fam in ("torsional", "vertical"))
    f_t = float("nan") if ts is None else ts.frequency_hz
    f_v = float("nan") if vs is None else vs.frequency_hz
    return {"ratio": f_t / f_v, "ts1_hz": f_t, "vs1_hz": f_v,
            "torsional_mode": ts.label if ts else "", "vertical_mode": vs.label if vs else "",
            "torsional_deck_share": ts.deck_share if ts else float("nan"),
            "vertical_deck_share": vs.deck_share if vs else float("nan"),
            **{f"{fam}_{key}": val
               for fam, m in (("torsional", ts), ("vertical", vs))
               for key, val in zip(("fundamental_mac", "hybrid"),
                                   _hybrid(modal, fam, m) if m else (float("nan"), False),
                                   strict=True)}}


@takes_bridge
def frequency_ratio(bridge: BridgeArg, fractions, side_spans: str | None = None
                    ) -> FrequencyRatioResult:
    """Torsion-to-bending frequency ratio ``f(TS1)/f(VS1)`` against the erected fraction.

    The paper's Fig. 2: the ratio with half (temporary joints) and with full deck GJ; modes by
    :func:`~bridgeflap.model.structure.modes.first_symmetric_deck_mode`; the completed bridge is
    reported separately.

    Parameters
    ----------
    bridge : str, path-like or BridgeSpec
        A built-in name, a bridge TOML file or a :class:`~bridgeflap.model.BridgeSpec`.
    fractions : sequence of float
        Erected fractions [-], each in (0, 1].
    side_spans : {"bare", "in_place", "with_main"}, optional
        The side-span decks while erecting (default: the bridge file's).

    Returns
    -------
    FrequencyRatioResult
        The ratios per fraction (``to_dataframe()``, ``table()``, ``plot()``).

    Raises
    ------
    BridgeflapInputError
        A bad bridge, fraction or ``side_spans``.

    Examples
    --------
    >>> from bridgeflap import model
    >>> res = model.frequency_ratio("humber", [0.5, 1.0])
    >>> len(res.to_dataframe())  # two fractions and the completed bridge
    3
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
    fr = _fractions(fractions)
    stages = []
    for f in fr:
        s = spec.erected(float(f), side_spans=side_spans)
        row = {"erected_fraction": float(f)}
        full = _ratio_row(modal_model(s, erection_gj_factor=1.0))
        half = _ratio_row(modal_model(s, erection_gj_factor=0.5))
        row["ratio_full_gj"] = full["ratio"]
        row["ratio_half_gj"] = half["ratio"]
        row.update({k: v for k, v in half.items() if k != "ratio"})
        stages.append(row)
    side = spec.erected(1.0, side_spans=side_spans).side_span_decks
    done = {"erected_fraction": 1.0, "stage": "completed bridge",
            **_ratio_row(modal_model(spec.completed()))}
    return FrequencyRatioResult(spec.name, tuple(stages), done, side)


# ------------------------------------------------------------------ closed loop (flaps)


