"""High-level analyses on a bridge definition: modes, flutter, erection, frequency ratio.

Plain functions of a ``bridge`` (a name, a file or a
:class:`~bridgeflap.model.structure.spec.BridgeSpec`) and grids of wind speeds [m/s] and erected
fractions [-] (``"0:85:0.5"`` text or numbers,
:func:`bridgeflap.model.grid.speed_grid`); the default grids belong to
:mod:`bridgeflap.design.studies.analyses`; the argument names are those of docs/api_vocabulary.md.
Each returns a frozen result object with ``summary()`` (JSON-ready numbers with units in the key
names and statuses) and ``plot()``. Conventions: see :mod:`bridgeflap.model`.

>>> from bridgeflap.model.structure.loader import load_bridge                  # doctest: +SKIP
>>> res = flutter(load_bridge("humber"), np.arange(0.0, 85.5, 0.5))  # doctest: +SKIP
>>> res.summary()["flutter_speed_m_s"]                     # doctest: +SKIP
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bridgeflap.model.aeroelastic import statespace
from bridgeflap.model.aeroelastic.control import Controller
from bridgeflap.model.aeroelastic.controller_file import as_controller
from bridgeflap.model.aeroelastic.flaps import closed_loop_model
from bridgeflap.model.arguments import optional
from bridgeflap.model.errors import BridgeflapError, BridgeflapInputError
from bridgeflap.model.results import ResultData, finite_extreme
from bridgeflap.model.stability.sweeps import StabilitySweep, check_speeds, sweep
from bridgeflap.model.structure.bridge_arg import BridgeArg, takes_bridge
from bridgeflap.model.structure.fe import assemble
from bridgeflap.model.structure.modes import ModalModel, solve
from bridgeflap.model.structure.spec import BridgeSpec, check_fraction
from bridgeflap.model.vocabulary import DEFAULT_MODES


@takes_bridge
def modal_model(bridge: BridgeArg, modes_per_family: int | None = None,
                erection_gj_factor: float = 0.5) -> ModalModel:
    """Cable statics, finite-element assembly and structural modes of a bridge.

    Parameters
    ----------
    bridge : str, path-like or BridgeSpec
        A built-in name (``"humber"``, ``"humber:box"``), a bridge TOML file or a
        :class:`~bridgeflap.model.BridgeSpec` (an erection stage included).
    modes_per_family : int, optional
        The lowest modes kept of each family (vertical, torsional, lateral); default: all. This
        is not the vertical + torsional ``n_modes`` of an aeroelastic model
        (docs/api_vocabulary.md).
    erection_gj_factor : float, default 0.5
        Factor [-] on the deck's GJ while the joints are temporary (erection stages only).

    Returns
    -------
    ModalModel
        The modes: ``table()``, ``to_dataframe()``, ``find(label)``, ``shape(label)``,
        ``plot()``; frequencies in Hz, labels such as ``"VS1"`` and ``"TS1"``
        (docs/conventions.md#along-the-bridge).

    Raises
    ------
    BridgeflapInputError
        A bad bridge (unknown name, missing file, non-physical value), named by its field.

    Examples
    --------
    >>> from bridgeflap import model
    >>> modes = model.modal_model("humber", modes_per_family=2)
    >>> "TS1" in modes.table()
    True
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
    return solve(assemble(spec, erection_gj_factor=erection_gj_factor), modes_per_family)


@takes_bridge
def bridge_system(bridge: BridgeArg, n_modes: int = DEFAULT_MODES, order: str = "modal",
                  rfa: str = "rfa4", modal: ModalModel | None = None,
                  ) -> tuple[ModalModel, statespace.AeroelasticSystem]:
    """Modal model and aeroelastic state space of a bridge.

    Parameters
    ----------
    bridge : str, path-like or BridgeSpec
        A built-in name, a bridge TOML file or a :class:`~bridgeflap.model.BridgeSpec`.
    n_modes : int, default 30
        Retained vertical + torsional modes (:data:`DEFAULT_MODES`).
    order : {"modal", "full"}, default "modal"
        State ordering of the aerodynamic lag states (docs/methods.md#state-space).
    rfa : {"rfa4", "jones"}, default "rfa4"
        Rational approximation of Theodorsen's C(k) (docs/methods.md#rational-approximation).
    modal : ModalModel, optional
        Modes already solved for ``bridge`` (default: solved here).

    Returns
    -------
    modal : ModalModel
        The structural modes.
    system : AeroelasticSystem
        ``A(U) = A0 + U A1 + U^2 A2`` with its :class:`StateIndex`; ``system.A(U)`` at a speed
        [m/s].

    Raises
    ------
    BridgeflapInputError
        Bad bridge, ``n_modes``, ``order`` or ``rfa``.

    Examples
    --------
    >>> from bridgeflap import model
    >>> modal, system = model.bridge_system("humber", n_modes=4)
    >>> system.A(40.0).shape[0] == system.A(0.0).shape[1]
    True
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
    if int(n_modes) < 1:
        raise BridgeflapInputError("modes", f"must be at least 1, got {n_modes}")
    modal = modal_model(spec) if modal is None else modal
    if getattr(spec, "derivatives", None) is not None:  # flutter-derivative tables (modal bridge)
        from bridgeflap.model.aeroelastic.derivative_system import derivative_bridge_system

        return modal, derivative_bridge_system(spec, modal, int(n_modes))
    system = statespace.spec_system(spec, modal.structural_basis(int(n_modes)), order, rfa)
    return modal, system


@dataclass(frozen=True)
class FlutterResult(ResultData):
    """The stability sweep of one bridge state: flutter, divergence and the tracked branches.

    Returned by :func:`bridgeflap.model.flutter`. Its headline numbers are attributes
    (``res.flutter_speed_m_s``); a misspelt one raises :class:`AttributeError`.

    Parameters
    ----------
    spec : BridgeSpec
        The bridge (or erection stage) swept.
    sweep : StabilitySweep
        The eigenvalue sweep with its tracked branches and refined crossings.
    n_modes : int
        Retained vertical + torsional modes.
    order : str
        State ordering (``"modal"`` or ``"full"``).
    rfa : str
        Rational approximation of C(k) (``"rfa4"`` or ``"jones"``).
    n_states : int
        Size of the state vector.
    modes : tuple, optional
        The retained modes' labels.

    Attributes
    ----------
    flutter_speed_m_s, divergence_speed_m_s, critical_speed_m_s : float
        The crossing speeds [m/s]; NaN when not found or not verified (the statuses say which).
    flutter_frequency_hz : float
        Frequency of the flutter branch at flutter [Hz].
    flutter_status, divergence_status : str
        ``"converged"``, ``"no_crossing_in_range"``, ``"unstable_at_start"``, ...
        (docs/conventions.md#statuses).
    critical_mechanism : str
        ``"flutter"`` or ``"divergence"``, whichever comes first.
    """

    _HEADLINE_KEYS = ("bridge", "erected_fraction", "critical_speed_m_s", "critical_mechanism",
                      "flutter_speed_m_s", "flutter_frequency_hz", "flutter_status",
                      "divergence_speed_m_s", "divergence_status", "critical_branch_label",
                      "modes_retained", "states", "speed_min_m_s", "speed_max_m_s")

    spec: BridgeSpec
    sweep: StabilitySweep
    n_modes: int
    order: str
    rfa: str
    n_states: int
    modes: tuple = ()

    def summary(self) -> dict:
        """JSON-ready numbers (units in the key names) and statuses of the sweep.

        ``critical_speed_m_s`` is the lower of the converged flutter and divergence speeds and
        ``critical_mechanism`` says which (``"flutter"``, ``"divergence"``, or ``"none"`` when
        neither converged on the grid).
        """
        s = self.sweep.summary()
        label = self.sweep.critical_branch
        crit = {"label": label, "family": "", "symmetry": "", "span": "",
                "frequency_hz": float("nan")}
        mode = next((m for m in self.modes if m.label == label), None) if label else None
        if mode is not None:
            crit = {"label": label, "family": mode.family, "symmetry": mode.symmetry,
                    "span": mode.span, "frequency_hz": mode.frequency_hz}
        elif label:  # no modal model at hand: read the label (TS1, or V-barton1 for a side span)
            fam = {"V": "vertical", "T": "torsional", "L": "lateral"}.get(label[0], "")
            side = label[1:2] == "-"
            sym = "" if side else {"S": "symmetric", "A": "antisymmetric"}.get(label[1:2], "")
            crit.update(family=fam, symmetry=sym,
                        span=label[2:].rstrip("0123456789") if side else "main")
        s.update(critical_speed(s))
        if s["critical_mechanism"] == "divergence" and self.sweep.divergence_participation:
            # the participation of the root that crosses at the governing crossing, never the
            # flutter branch's above it (that one kept as flutter_participation)
            s["flutter_participation"] = s["critical_participation"]
            s["critical_participation"] = _top(self.sweep.divergence_participation)
        s.update({"bridge": self.spec.name, "erected_fraction": self.spec.erected_fraction,
                  "joints_closed": self.spec.joints_closed,
                  "critical_branch": crit, "modes_retained": self.n_modes,
                  "order": self.order, "rfa": self.rfa, "states": self.n_states,
                  "half_chord_m": self.spec.deck.half_chord_m,
                  "added_inertia": self.spec.aero.added_inertia})
        return s

    def to_dataframe(self):
        """The sweep, one row per speed x branch (:func:`bridgeflap.model.results.sweep_frame`)."""
        return self.sweep.to_dataframe()

    def to_xarray(self):
        """The sweep as an ``xarray.Dataset`` (:func:`bridgeflap.model.results.sweep_dataset`)."""
        return self.sweep.to_xarray({"bridge": self.spec.name, "modes_retained": self.n_modes,
                                     "erected_fraction": self.spec.erected_fraction,
                                     "order": self.order, "rfa": self.rfa})

    def plot(self, axes=None):
        """Root locus and damping/frequency against speed."""
        return self.sweep.plot(axes, title=f"{self.spec.name} (erected "
                                           f"{self.spec.erected_fraction:.2f}):")


def _top(participation: dict, n: int = 4) -> dict:
    """The ``n`` largest shares, largest first (as the sweep summary's)."""
    return dict(sorted(participation.items(), key=lambda kv: -kv[1])[:n])


def critical_speed(summary) -> dict:
    """``{"critical_speed_m_s", "critical_mechanism"}``: the lower converged stability limit.

    ``summary`` holds ``flutter_speed_m_s``/``flutter_status`` and the divergence pair (and
    ``<kind>_bracket_m_s`` for a crossing that did not converge). The speed is NaN, with the
    mechanism saying why, when the system is unstable at the first speed, when a crossing that
    did not converge lies below the lowest converged one (``"flutter unverified_crossing"``),
    or when nothing converged (``"none"``).
    """
    limits = [(summary[f"{k}_speed_m_s"], k) for k in ("flutter", "divergence")
              if summary.get(f"{k}_status") == "converged"]
    if any(summary.get(f"{k}_status") == "unstable_at_first_speed"
           for k in ("flutter", "divergence")):
        # unstable below the grid: no limit on it is the governing one
        return {"critical_speed_m_s": float("nan"), "critical_mechanism": "unstable_at_first_speed"}
    # a crossing seen on the grid but not located (bracket_failed, unverified_crossing) below
    # the lowest converged limit may be the governing one: the governing speed is then unknown
    lowest = min(limits)[0] if limits else np.inf
    for k in ("flutter", "divergence"):
        bracket = summary.get(f"{k}_bracket_m_s")
        if (summary.get(f"{k}_status") in ("bracket_failed", "unverified_crossing")
                and (bracket is None or bracket[0] < lowest)):
            return {"critical_speed_m_s": float("nan"),
                    "critical_mechanism": f"{k} {summary[f'{k}_status']}"}
    if not limits:
        return {"critical_speed_m_s": float("nan"), "critical_mechanism": "none"}
    u, k = min(limits)
    return {"critical_speed_m_s": float(u), "critical_mechanism": k}


@takes_bridge
def flutter(bridge: BridgeArg, speeds, n_modes: int = DEFAULT_MODES,
            order: str = "modal", rfa: str = "rfa4", speed_tol: float = 1e-3,
            sweep_method: str = "dense") -> FlutterResult:
    """Flutter and torsional divergence of a bridge over a grid of wind speeds.

    The eigenvalues of the aeroelastic state space ``A(U)`` are tracked over ``speeds``; the
    first speed where a branch's real part crosses zero is refined and verified
    (docs/methods.md#stability). Flutter is an oscillatory crossing, divergence a real one.

    Parameters
    ----------
    bridge : str, path-like or BridgeSpec
        A built-in name (``"humber"``), a bridge TOML file or a
        :class:`~bridgeflap.model.BridgeSpec` (an erection stage included).
    speeds : array_like or str
        Wind speeds [m/s], increasing and non-negative, or a range string ``"0:85:0.5"``
        (start:stop:step, stop included).
    n_modes : int, default 30
        Retained vertical + torsional modes.
    order : {"modal", "full"}, default "modal"
        State ordering, as :func:`bridge_system`.
    rfa : {"rfa4", "jones"}, default "rfa4"
        Rational approximation of C(k).
    speed_tol : float, default 1e-3
        Width [m/s] to which each crossing is refined.
    sweep_method : {"dense", "fast"}, default "dense"
        ``"dense"``, the reference, solves every eigenvalue at every grid speed; ``"fast"``, the
        CLI's default, tracks a coarse sweep and refines by Newton (the same fields and
        statuses; :func:`bridgeflap.model.sweep`).

    Returns
    -------
    FlutterResult
        ``flutter_speed_m_s``, ``divergence_speed_m_s``, ``critical_speed_m_s`` and
        ``critical_mechanism`` (NaN with a status saying why when a crossing is not found or
        not verified), ``summary()``, ``table()``, ``to_xarray()``, ``plot()`` (root locus,
        V-g, V-f).

    Raises
    ------
    BridgeflapInputError
        A bad bridge, speed grid, ``n_modes``, ``order`` or ``rfa``, named by its field.

    See Also
    --------
    closed_loop_flutter : the same with a flap controller.
    erection : the same at each erection stage.

    Examples
    --------
    >>> import numpy as np
    >>> from bridgeflap import model
    >>> res = model.flutter("humber", np.arange(0.0, 90.0, 2.0), n_modes=6)
    >>> res.critical_mechanism, f"{res.flutter_speed_m_s:.0f} m/s"
    ('flutter', '69 m/s')
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
    u = check_speeds(speeds)
    tol = float(speed_tol)
    if not (np.isfinite(tol) and tol > 0):
        raise BridgeflapInputError("speed_tol",
                                   f"must be a positive number of m/s, got {speed_tol!r}")
    modal, system = bridge_system(spec, n_modes, order, rfa)
    return FlutterResult(spec, sweep(system, u, speed_tol=tol, method=sweep_method),
                         system.basis.n, order,
                         system.extras.get("rfa", rfa), system.n_states, modal.modes)


@dataclass(frozen=True)
class _StagesResult(ResultData):
    """Rows of numbers (units in the key names) per erected fraction of one bridge, plus the
    completed bridge as its own row (joints closed: full GJ and EI)."""

    bridge: str
    stages: tuple
    completed: dict = field(default_factory=dict)
    side_spans: str = ""

    def summary(self) -> dict:
        """JSON-ready ``{"bridge", "side_spans", "stages", "completed_bridge"}``."""
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
        :func:`bridgeflap.model.stability.plots.erection_speeds`."""
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
        (:func:`bridgeflap.model.structure.plots.frequency_ratio`)."""
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


@dataclass(frozen=True)
class ClosedLoopFlutterResult(ResultData):
    """Closed-loop stability sweep plus the open-loop reference."""

    _HEADLINE_KEYS = ("bridge", "flap_count", "max_gain", "critical_speed_m_s",
                      "critical_mechanism", "flutter_speed_m_s", "flutter_status",
                      "divergence_speed_m_s", "divergence_status", "open_loop_flutter_speed_m_s",
                      "open_loop_flutter_status", "modes_retained")

    base: object            # model.analysis.FlutterResult of the closed loop
    open_loop: object       # model.analysis.FlutterResult without flaps
    controller: Controller
    #: model.stability.static_divergence.StaticDivergence of the closed loop (None: not checked)
    static: object = field(default=None, repr=False)

    def summary(self) -> dict:
        """Same keys as :meth:`bridgeflap.model.analysis.FlutterResult.summary`, plus closed-loop
        info.

        ``divergence_static_speed_m_s`` is the closed-loop static check (static flap loads of
        ``beta = K(0) alpha``), ``divergence_static_verified_*`` its verification
        (:mod:`bridgeflap.model.stability.static_divergence`: status, reason, direction of the real
        eigenvalue, whether it is the stability limit); the open-loop values are under
        ``open_loop_*``.
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
        if self.static is not None:
            s.update(self.static.summary())
        return s

    def to_dataframe(self):
        """The closed-loop sweep, one row per speed x branch."""
        return self.base.to_dataframe()

    def to_xarray(self):
        """The closed-loop sweep as an ``xarray.Dataset``."""
        return self.base.to_xarray()

    def plot(self, axes=None):
        """Closed-loop root locus and damping/frequency against speed, the open loop in
        grey underneath."""
        return self.base.sweep.plot(axes, title=f"{self.base.spec.name} with "
                                                f"{self.controller.n_flaps} flap pairs:",
                                    reference=self.open_loop.sweep)


@takes_bridge(controller=as_controller)
def closed_loop_flutter(bridge: BridgeArg, controller: Controller, speeds,
                        n_modes: int = DEFAULT_MODES,
                        flap_chord_m: float | None = None,
                        sweep_method: str = "dense",
                        verify_static: bool = True,
                        critical_only: bool = False,
                        modal: ModalModel | None = None) -> ClosedLoopFlutterResult:
    """Closed-loop flutter and divergence sweep with a flap controller, and the open loop beside it.

    Parameters
    ----------
    bridge : str, path-like or BridgeSpec
        A built-in name, a bridge TOML file or a :class:`~bridgeflap.model.BridgeSpec`.
    controller : Controller
        The compensator and its flap layout (:func:`load_controller` reads one from a file).
    speeds : array_like or str
        Wind speeds [m/s] (any form of :func:`bridgeflap.model.grid.speed_grid`).
    n_modes : int, default 30
        Retained vertical + torsional modes.
    flap_chord_m : float, optional
        Chordwise flap size [m] (default: the controller's own, :attr:`Controller.chord_m`).
    sweep_method : {"dense", "fast"}, default "dense"
        As :func:`flutter`, for both sweeps.
    verify_static : bool, default True
        Also verify the closed loop's static divergence on the grid's range (about 0.3 s on 30
        modes; :func:`bridgeflap.model.stability.static_divergence.static_divergence`).
    critical_only : bool, default False
        The critical crossings alone (no second branch), as :func:`bridgeflap.model.sweep`.
    modal : ModalModel, optional
        Modes already solved for ``bridge`` (default: all modes of its FE model).

    Returns
    -------
    ClosedLoopFlutterResult
        ``base`` (the closed loop) and ``open_loop`` (the bridge without flaps), each a
        :class:`FlutterResult`; ``summary()`` with ``flutter_status``, ``divergence_status`` and
        ``critical_speed_m_s``; ``plot()`` (closed over open root locus).

    Raises
    ------
    BridgeflapInputError
        A bad bridge, controller, speed grid or option.

    Examples
    --------
    >>> from bridgeflap import model
    >>> k = model.Controller(model.Compensator(b2=0.0, b1=0.0, b0=-1.0, a2=0.01, a1=0.1),
    ...                      flap_strip_positions_m=(0.0,), flap_width_m=100.0)
    >>> res = model.closed_loop_flutter("humber", k, "0:90:5", n_modes=4)
    >>> res.summary()["flap_count"]
    1
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
    u = check_speeds(speeds)
    chord = controller.chord_m if flap_chord_m is None else flap_chord_m
    model = closed_loop_model(spec, controller.flap_strip_positions_m, controller.flap_width_m,
                              n_modes, chord, controller.leading_edge,
                              controller.trailing_edge, modal=modal)
    system = model.open_loop
    cl = model.system(controller.compensator)
    base = FlutterResult(spec, sweep(cl, u, method=sweep_method, critical_only=critical_only),
                         int(n_modes), "modal", "rfa4", cl.n_states)
    ol = FlutterResult(spec, sweep(system, u, method=sweep_method, critical_only=critical_only),
                       int(n_modes), "modal", "rfa4", system.n_states)
    static = None
    if verify_static:
        from bridgeflap.model.stability.static_divergence import static_divergence

        static = static_divergence(cl, float(u[-1]))
    return ClosedLoopFlutterResult(base, ol, controller, static)


@takes_bridge(controller=optional(as_controller))
def pk_flutter(bridge: BridgeArg, speeds, n_modes: int = DEFAULT_MODES,
               controller: Controller | None = None) -> dict:
    """The exact-Theodorsen p-k check of the flutter speed, on the coordinates of :func:`flutter`.

    Parameters
    ----------
    bridge : str, path-like or BridgeSpec
        A built-in name, a bridge TOML file or a :class:`~bridgeflap.model.BridgeSpec`.
    speeds : array_like or str
        Wind speeds [m/s].
    n_modes : int, default 30
        Retained vertical + torsional modes.
    controller : Controller, optional
        Close the loop with the controller's exact ``K(p)`` (default: open loop).

    Returns
    -------
    dict
        The summary of :func:`bridgeflap.model.pk_sweep`: ``flutter_speed_m_s``,
        ``flutter_status`` and the reduced frequency at flutter (plain Python numbers).

    Raises
    ------
    BridgeflapInputError
        A bad bridge, speed grid or controller.
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
    from bridgeflap.model.stability.sweeps import pk_sweep

    u = check_speeds(speeds)
    if controller is None:
        _, system = bridge_system(spec, n_modes)
    else:
        c = controller
        system = closed_loop_model(spec, c.flap_strip_positions_m, c.flap_width_m, n_modes,
                                   c.chord_m, c.leading_edge,
                                   c.trailing_edge).system(c.compensator)
    return pk_sweep(system, u).summary()
