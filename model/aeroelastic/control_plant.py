"""The plant for control engineers (``bridgeflap.model.plant``): gust and flap inputs,
python-control.

:func:`plant_data` returns a :class:`Plant` (numpy matrices, short indexable signal names, strip
and flap coordinates); :func:`plant` the same as a ``control.StateSpace`` (python-control, the
optional extra ``control``, imported lazily). Conventions: :mod:`bridgeflap.model`; flap drive
signs:
:mod:`bridgeflap.model.aeroelastic.flaps`.

Signals (0-based strip and flap numbers, ordered along the bridge)
-----------------------------------------------------------------
* inputs ``gust[i]`` -- vertical gust velocity at strip ``i`` [m/s] (up, before admittance);
  ``flap_te[f]`` -- trailing-edge flap angle at flap ``f`` [rad] (TE down positive);
  ``flap_le[f]`` -- leading-edge flap angle [rad] (LE down positive);
* outputs ``heave[i]`` [m] (down) and ``pitch[i]`` [rad] (nose-up) at strip ``i``, and with
  flaps ``pitch_flap[f]`` [rad], the deck pitch at flap ``f`` (what the built-in compensator
  feeds back: the package's closed loop is ``flap_te = K(s) pitch_flap``,
  ``flap_le = -K(s) pitch_flap``).

Flap inputs: one physics path
-----------------------------
The flap loads depend on ``beta``, ``beta'`` and ``beta''`` (non-circulatory and circulatory
terms, :func:`bridgeflap.model.aeroelastic.assembly.flap_inputs`). Their input columns are taken
from the one assembly (:func:`bridgeflap.model.aeroelastic.assembly.rfa_parts`) by closing it with a
chain of three integrators in place of the compensator (``beta = xc1``, ``beta' = xc2``, ``beta'' =
xc3``): the compensator-state columns of that matrix are exactly ``B0, B1, B2`` of ``x' = A x + B0 u
+ B1 u' + B2 u''``. The derivatives are then removed by the state change ``z = x - E u - B2 u'``,
  ``E = A B2 +
B1``::

    z' = A z + (A E + B0) u,      y = C z + C E u        (C B2 = 0: B2 acts on q' only)

so the plant is proper with a feed-through ``C E`` and its states ``z`` are the aeroelastic
states ``(q, q', lag states)`` less the flap terms (equal to them with the flaps at rest).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bridgeflap.model.aeroelastic.assembly import rfa_parts
from bridgeflap.model.aeroelastic.controller_file import as_controller
from bridgeflap.model.arguments import count, one_of, optional
from bridgeflap.model.errors import BridgeflapError, BridgeflapInputError
from bridgeflap.model.results import ResultData
from bridgeflap.model.structure.bridge_arg import takes_bridge
from bridgeflap.model.vocabulary import DEFAULT_MODES

__all__ = ["INPUTS", "Plant", "closed_loop_plant", "even_flap_layout", "plant", "plant_data",
           "to_control"]

#: Most flaps of an even layout (a flap per 7 m of the Humber main span).
MAX_FLAPS = 200

#: Input sets of :func:`plant_data`.
INPUTS = ("gust", "flaps", "both")

#: A chain of three integrators in the compensator's place: beta, beta', beta'' as its states.
_SHIFT = (np.diag([1.0, 1.0], 1), np.zeros((3, 1)), np.array([[1.0, 0.0, 0.0]]), 0.0)


@dataclass(frozen=True)
class Plant(ResultData):
    """Linear plant ``x' = A x + B u``, ``y = C x + D u`` at one wind speed.

    Attributes
    ----------
    A, B, C, D : ndarray
        [SI units of the signals below; time in s].
    state_names, input_names, output_names : tuple of str
        Short indexable names (module docstring).
    wind_speed_m_s : float
    strip_x_m : ndarray (n_strip,)
        Strip centres from the north anchorage [m] (the ``i`` of ``gust[i]``, ``heave[i]``).
    flap_x_m : ndarray (n_flap,)
        Flap centres from the north anchorage [m] (empty without flaps).
    flap_position_m : ndarray (n_flap,)
        Flap centres from the main-span mid-point [m].
    flap_width_m : ndarray (n_flap,)
        Spanwise length of each flap [m].
    inputs : str
        ``"gust"``, ``"flaps"`` or ``"both"``.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    state_names: tuple
    input_names: tuple
    output_names: tuple
    wind_speed_m_s: float
    strip_x_m: np.ndarray
    flap_x_m: np.ndarray
    flap_position_m: np.ndarray
    flap_width_m: np.ndarray
    inputs: str

    def summary(self) -> dict:
        """Sizes, speed, spectral abscissa [1/s] and the signal names (strict JSON).

        Returns
        -------
        dict
            ``inputs`` (the input set), ``states``, ``input_count``, ``output_count``,
            ``wind_speed_m_s`` [m/s], ``spectral_abscissa_1_s`` [1/s], the signal names and the
            strip and flap positions [m].
        """
        return {"inputs": self.inputs, "states": int(self.A.shape[0]),
                "input_count": int(self.B.shape[1]), "output_count": int(self.C.shape[0]),
                "wind_speed_m_s": self.wind_speed_m_s,
                "spectral_abscissa_1_s": float(np.linalg.eigvals(self.A).real.max()),
                "input_names": list(self.input_names), "output_names": list(self.output_names),
                "strip_x_m": self.strip_x_m.tolist(), "flap_x_m": self.flap_x_m.tolist()}

    _HEADLINE_KEYS = ("inputs", "states", "input_count", "output_count", "wind_speed_m_s",
                      "spectral_abscissa_1_s")

    def plot(self, ax=None):
        """Eigenvalues of ``A`` in the complex plane [1/s].

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 4.5), layout="constrained")
        lam = np.linalg.eigvals(self.A)
        ax.plot(lam.real, lam.imag, "x", color="C0")
        ax.axvline(0.0, color="k", lw=0.8)
        ax.set_xlabel("Re lambda [1/s]")
        ax.set_ylabel("Im lambda [1/s]")
        ax.set_title(f"plant eigenvalues at U = {self.wind_speed_m_s:g} m/s ({self.inputs})")
        ax.grid(alpha=0.3)
        return ax

    def arrays(self, mat: bool = False) -> dict:
        """The ``.npz``/``.mat`` payload: matrices, names, coordinates [m] and the speed [m/s].

        Names are unicode arrays for ``.npz`` (loadable without pickle) and object arrays for
        ``.mat`` (``scipy.io.savemat`` writes them as MATLAB cell arrays: no space padding).

        Parameters
        ----------
        mat : bool, default False
            Names as MATLAB cell arrays (for ``scipy.io.savemat``) rather than unicode arrays.

        Returns
        -------
        dict
            ``A``, ``B``, ``C``, ``D``, the state, input and output names, ``wind_speed_m_s``
            [m/s], ``strip_x_m``, ``flap_x_m``, ``flap_position_m`` and ``flap_width_m`` [m].
        """
        def cells(names):
            if not mat:
                return np.array(list(names), dtype=str)
            out = np.empty((len(names), 1), dtype=object)
            out[:, 0] = list(names)
            return out

        return {"A": self.A, "B": self.B, "C": self.C, "D": self.D,
                "state_names": cells(self.state_names), "input_names": cells(self.input_names),
                "output_names": cells(self.output_names),
                "wind_speed_m_s": np.array(self.wind_speed_m_s),
                "strip_x_m": self.strip_x_m, "flap_x_m": self.flap_x_m,
                "flap_position_m": self.flap_position_m, "flap_width_m": self.flap_width_m}

    def to_control(self):
        """This plant as a named ``control.StateSpace`` (:func:`to_control`).

        Returns
        -------
        control.StateSpace
            ``A, B, C, D`` with the plant's state, input and output names.

        Raises
        ------
        BridgeflapError
            python-control is not installed (the ``control`` extra).
        """
        return to_control(self)


def to_control(p: Plant):
    """``control.StateSpace`` with the plant's signal names (python-control, extra ``control``).

    Raises
    ------
    BridgeflapError
        One line when python-control is not installed.
    """
    try:
        import control
    except ImportError as exc:  # the optional extra
        raise BridgeflapError("python-control is not installed: pip install "
                              "'bridgeflap[control]' (or pip install control)") from exc
    return control.ss(p.A, p.B, p.C, p.D, inputs=list(p.input_names),
                      outputs=list(p.output_names), states=list(p.state_names),
                      name="bridgeflap_plant_U" + f"{p.wind_speed_m_s:g}".replace(".", "p"))


def even_flap_layout(spec, count: int) -> tuple[np.ndarray, float]:
    """``count`` flaps of equal width side by side over the main span: (positions from the
    main-span mid-point [m], width [m])."""
    if not 1 <= int(count) <= MAX_FLAPS:
        raise BridgeflapInputError("flaps", f"must lie in 1..{MAX_FLAPS}, got {count}")
    length = float(spec.spans[spec.main_span_index].length_m)
    width = length / int(count)
    return (np.arange(int(count)) - 0.5 * (int(count) - 1)) * width, width


def _flap_columns(system, flaps_le_te, U: float):
    """``(B0, B1, B2)`` (n_x, n_flap) per unit flap drive of one flap set (module docstring)."""
    from bridgeflap.model.aeroelastic.flaps import ClosedLoopModel

    model = ClosedLoopModel(system, flaps_le_te)
    A0, A1, A2, _, _ = rfa_parts(model.pieces(), system.rfa, _SHIFT)
    A = A0 + U * A1 + (U * U) * A2
    nol = system.n_states
    cols = A[:nol, nol:]                      # (n_x, 3 n_flap): flap f -> columns 3f, 3f+1, 3f+2
    return cols[:, 0::3], cols[:, 1::3], cols[:, 2::3]


@takes_bridge(controller=optional(as_controller), inputs=one_of(*INPUTS),
              flaps=count(1, MAX_FLAPS))
def plant_data(bridge, speed: float, inputs: str = "gust", n_modes: int = DEFAULT_MODES,
               controller=None, flaps: int = 5, flap_chord_m: float | None = None,
               system=None) -> Plant:
    """The open-loop plant of a bridge at ``speed`` [m/s] (module docstring).

    Parameters
    ----------
    bridge : str, os.PathLike or BridgeSpec
    speed : float
        ``U`` [m/s], ``>= 0``.
    inputs : {"gust", "flaps", "both"}
    n_modes : int
        Vertical and torsional modes retained (default :data:`bridgeflap.model.DEFAULT_MODES`).
    controller : bridgeflap.model.aeroelastic.control.Controller, optional
        Its flap layout (positions, width, fitted edges) is used; its K(s) is **not** closed.
    flaps : int
        Without a controller: this many flaps side by side over the main span
        (:func:`even_flap_layout`).
    flap_chord_m : float, optional
        Chordwise flap size [m] (default: the controller's own,
        :attr:`bridgeflap.model.aeroelastic.control.Controller.chord_m`, else
        :data:`bridgeflap.model.aeroelastic.flaps.DEFAULT_FLAP_CHORD_M`).
    system : AeroelasticSystem, optional
        A prebuilt open-loop system of ``bridge`` (else built from ``n_modes`` modes).

    Returns
    -------
    Plant
        ``A``, ``B``, ``C``, ``D`` (numpy) with the names of the states, inputs and outputs;
        ``to_control()`` gives the python-control object, ``spectral_abscissa_1_s`` the largest
    real part of its poles [1/s].

    Raises
    ------
    BridgeflapInputError
        A bad bridge, speed, ``inputs``, ``flaps`` or controller.
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
    from bridgeflap.model.aeroelastic import statespace
    from bridgeflap.model.aeroelastic.flaps import DEFAULT_FLAP_CHORD_M, flap_set
    from bridgeflap.model.structure.fe import assemble
    from bridgeflap.model.structure.modes import solve

    if inputs not in INPUTS:
        raise BridgeflapInputError("inputs", f"must be one of {INPUTS}, got {inputs!r}")
    U = float(speed)
    if not (np.isfinite(U) and U >= 0):
        raise BridgeflapInputError("speed", f"must be a non-negative number, got {speed}")
    if system is None:
        if int(n_modes) < 1:
            raise BridgeflapInputError("modes", f"must be at least 1, got {n_modes}")
        # the system of model.analysis.bridge_system (spec_system refuses derivative tables)
        system = statespace.spec_system(spec, solve(assemble(spec)).structural_basis(int(n_modes)))
    basis = system.basis
    ns = basis.n_strip
    A = system.A(U)
    C = system.C_out
    names_in, B, D = [], np.zeros((A.shape[0], 0)), np.zeros((C.shape[0], 0))
    if inputs in ("gust", "both"):
        B = system.B_gust(U)
        D = np.zeros((C.shape[0], ns))
        names_in = [f"gust[{i}]" for i in range(ns)]
    names_out = [f"heave[{i}]" for i in range(ns)] + [f"pitch[{i}]" for i in range(ns)]
    empty = np.zeros(0)
    fx = fpos = fwidth = empty
    if inputs in ("flaps", "both"):
        chord = (float(flap_chord_m) if flap_chord_m is not None else
                 controller.chord_m if controller is not None else DEFAULT_FLAP_CHORD_M)
        if controller is not None:
            pos, width = controller.flap_strip_positions_m, controller.flap_width_m
            edges = [e for e, on in (("te", controller.trailing_edge),
                                     ("le", controller.leading_edge)) if on]
        else:
            pos, width = even_flap_layout(spec, flaps)
            edges = ["te", "le"]
        Bf, Df, rows_c = [], [], None
        for edge in edges:
            fs = flap_set(spec, basis, pos, width, chord, leading_edge=edge == "le",
                          trailing_edge=edge == "te")
            B0, B1, B2 = _flap_columns(system, fs, U)
            sign = 1.0 if edge == "te" else -1.0    # flap_le = -beta (model.aeroelastic.flaps)
            if rows_c is None:
                rows_c = np.zeros((fs.n_flaps, A.shape[0]))
                rows_c[:, system.index.q] = fs.phi_a
                C = np.vstack([C, rows_c])
                D = np.vstack([D, np.zeros((fs.n_flaps, D.shape[1]))])
                names_out += [f"pitch_flap[{f}]" for f in range(fs.n_flaps)]
                fx = basis_mid(spec) + np.asarray(fs.position_m, float)
                fpos, fwidth = np.asarray(fs.position_m, float), np.asarray(fs.width_m, float)
            if np.abs(C @ B2).max(initial=0.0) > 0:
                raise BridgeflapError("flap plant: the beta'' input reaches an output")
            E = A @ B2 + B1
            Bf.append(sign * (A @ E + B0))
            Df.append(sign * (C @ E))
            names_in += [f"flap_{edge}[{f}]" for f in range(fs.n_flaps)]
        B = np.hstack([B, *Bf])
        D = np.hstack([D, *Df])
    return Plant(A=A, B=B, C=C, D=D, state_names=tuple(system.index.names),
                 input_names=tuple(names_in), output_names=tuple(names_out),
                 wind_speed_m_s=U, strip_x_m=np.asarray(basis.strip_x, float),
                 flap_x_m=fx, flap_position_m=fpos, flap_width_m=fwidth, inputs=inputs)


@takes_bridge(controller=as_controller)
def closed_loop_plant(spec, controller, speed: float, n_modes: int = DEFAULT_MODES,
                      flap_chord_m: float | None = None) -> Plant:
    """The package's closed loop (``controller``'s K(s) fed back,
    :mod:`bridgeflap.model.aeroelastic.flaps`) with gust inputs ``gust[i]``; outputs ``heave[i]``,
    ``pitch[i]`` and each flap's drive angle ``beta[f]`` [rad] (TE flap TE-down; the LE flap is at
    ``-beta``, LE-down)."""
    from bridgeflap.model.aeroelastic.flaps import closed_loop_system

    U = float(speed)
    chord = controller.chord_m if flap_chord_m is None else float(flap_chord_m)
    cl = closed_loop_system(spec, controller, int(n_modes), chord)
    ns = cl.basis.n_strip
    C = np.vstack([cl.C_out, cl.extras["flap_angle_map"]])
    B = cl.B_gust(U)
    pos = np.asarray(controller.flap_strip_positions_m, float)
    return Plant(A=cl.A(U), B=B, C=C, D=np.zeros((C.shape[0], B.shape[1])),
                 state_names=tuple(cl.index.names),
                 input_names=tuple(f"gust[{i}]" for i in range(ns)),
                 output_names=tuple([f"heave[{i}]" for i in range(ns)]
                                    + [f"pitch[{i}]" for i in range(ns)]
                                    + [f"beta[{f}]" for f in range(controller.n_flaps)]),
                 wind_speed_m_s=U, strip_x_m=np.asarray(cl.basis.strip_x, float),
                 flap_x_m=basis_mid(spec) + pos, flap_position_m=pos,
                 flap_width_m=np.full(pos.size, float(controller.flap_width_m)),
                 inputs="gust (closed loop)")


def basis_mid(spec) -> float:
    """Global x of the main-span mid-point [m] (from the north anchorage)."""
    lengths = [s.length_m for s in spec.spans]
    return float(sum(lengths[: spec.main_span_index])) + 0.5 * float(
        lengths[spec.main_span_index])


@takes_bridge(controller=optional(as_controller), inputs=one_of(*INPUTS),
              flaps=count(1, MAX_FLAPS))
def plant(bridge, speed: float, inputs: str = "gust", n_modes: int = DEFAULT_MODES,
          **options):
    """:func:`plant_data` as a ``control.StateSpace`` (``bridge``: a name, a file or a spec).

    ``options``: ``controller`` (its layout), ``flaps``, ``flap_chord_m``, ``system``.

    Parameters
    ----------
    bridge : str, path-like or BridgeSpec
        A built-in name, a bridge TOML file or a spec.
    speed : float
        Wind speed [m/s], ``>= 0``.
    inputs : {"gust", "flaps", "both"}, default "gust"
        The plant's inputs.
    n_modes : int, default 30
        Retained vertical + torsional modes.
    **options
        ``controller``, ``flaps``, ``flap_chord_m``, ``system``, as :func:`plant_data`.

    Returns
    -------
    control.StateSpace
        The open-loop plant with named signals (needs the ``control`` extra).

    Raises
    ------
    BridgeflapInputError
        A bad bridge, speed, ``inputs`` or option.
    """
    return to_control(plant_data(bridge, speed, inputs, n_modes, **options))
