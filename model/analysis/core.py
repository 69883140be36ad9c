"""The facade's first analyses: the modal model, the aeroelastic system and flutter
(:mod:`bridgeflap.model.analysis`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bridgeflap.model.aeroelastic import statespace
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.results import ResultData
from bridgeflap.model.stability.sweeps import StabilitySweep, check_speeds, sweep
from bridgeflap.model.structure.bridge_arg import BridgeArg, takes_bridge
from bridgeflap.model.structure.fe import assemble
from bridgeflap.model.structure.modes import ModalModel, solve
from bridgeflap.model.structure.spec import BridgeSpec
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

        Returns
        -------
        dict
            Plain Python numbers and strings, units in the key names (NaN where not found on
            the grid).
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
        """The sweep, one row per speed x branch (:func:`bridgeflap.model.results.sweep_frame`).

        Returns
        -------
        pandas.DataFrame
            Columns ``speed_m_s``, ``branch``, ``frequency_hz``, ``damping_ratio``,
            ``real_part_1_s``, ``imag_part_1_s``.
        """
        return self.sweep.to_dataframe()

    def to_xarray(self):
        """The sweep as an ``xarray.Dataset`` (:func:`bridgeflap.model.results.sweep_dataset`).

        Returns
        -------
        xarray.Dataset
            The branches on ``(branch, speed_m_s)``; the flutter and divergence numbers, the
            bridge and the model in its attributes.
        """
        return self.sweep.to_xarray({"bridge": self.spec.name, "modes_retained": self.n_modes,
                                     "erected_fraction": self.spec.erected_fraction,
                                     "order": self.order, "rfa": self.rfa})

    def plot(self, axes=None):
        """Root locus and damping/frequency against speed.

        Parameters
        ----------
        axes : sequence of three matplotlib.axes.Axes, optional
            Root-locus, V-g and V-f axes (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
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


