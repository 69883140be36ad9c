"""Closed-loop flutter with a flap controller, and the exact p-k flutter
(:mod:`bridgeflap.model.analysis`)."""

from __future__ import annotations

from dataclasses import dataclass, field

from bridgeflap.model.aeroelastic.control import Controller
from bridgeflap.model.aeroelastic.controller_file import as_controller
from bridgeflap.model.aeroelastic.flaps import closed_loop_model
from bridgeflap.model.analysis.core import FlutterResult, bridge_system
from bridgeflap.model.arguments import optional
from bridgeflap.model.results import ResultData
from bridgeflap.model.stability.sweeps import check_speeds, sweep
from bridgeflap.model.structure.bridge_arg import BridgeArg, takes_bridge
from bridgeflap.model.structure.modes import ModalModel
from bridgeflap.model.vocabulary import DEFAULT_MODES


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

        Returns
        -------
        dict
            Plain Python numbers and strings, units in the key names (NaN where not found on
            the grid).
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
        """The closed-loop sweep, one row per speed x branch.

        Returns
        -------
        pandas.DataFrame
            Columns ``speed_m_s``, ``branch``, ``frequency_hz``, ``damping_ratio``,
            ``real_part_1_s``, ``imag_part_1_s``.
        """
        return self.base.to_dataframe()

    def to_xarray(self):
        """The closed-loop sweep as an ``xarray.Dataset``.

        Returns
        -------
        xarray.Dataset
            The branches on ``(branch, speed_m_s)``; the flutter and divergence numbers, the
            bridge and the model in its attributes.
        """
        return self.base.to_xarray()

    def plot(self, axes=None):
        """Closed-loop root locus and damping/frequency against speed, the open loop in
        grey underneath.

        Parameters
        ----------
        axes : sequence of three matplotlib.axes.Axes, optional
            Root-locus, V-g and V-f axes (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
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
