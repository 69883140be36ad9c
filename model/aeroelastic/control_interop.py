"""python-control first-class: the compensator, the controller, the closed loop, plant families.

Objects of the python-control package (``control``, the optional extra ``bridgeflap[control]``,
imported lazily; without it every function raises one
:class:`~bridgeflap.model.errors.BridgeflapError` line):

* :meth:`Compensator.to_control() <bridgeflap.model.aeroelastic.control.Compensator.to_control>` --
  ``K(s)`` as a ``control.TransferFunction`` (input ``pitch`` [rad], output ``beta`` [rad]);
* :meth:`Controller.to_statespace() <bridgeflap.model.aeroelastic.control.Controller.to_statespace>`
  -- the controller as a ``control.StateSpace`` from the deck pitch at each flap, ``pitch_flap[f]``,
  to the flap drives ``flap_te[f] = +K pitch_flap[f]`` and ``flap_le[f] = -K pitch_flap[f]`` (the
  fitted edges only): the signal names of :func:`bridgeflap.model.plant` with ``inputs="flaps"``, so
  ``control.feedback(P, K, sign=1)`` (or ``control.interconnect``) closes the package's loop;
* :func:`closed_loop` -- the package's own closed loop
  (:func:`bridgeflap.model.aeroelastic.flaps.closed_loop_system`, what ``bridgeflap flutter
  --controller`` sweeps) at one wind speed, gust inputs;
* :func:`plant_family` -- the open-loop plant (:func:`bridgeflap.model.plant`) over a list of wind
  speeds, the modal model solved once.

Conventions and signal names: :mod:`bridgeflap.model`,
:mod:`bridgeflap.model.aeroelastic.control_plant`.

The conversions of the compensator and the controller themselves
(:func:`compensator_tf`, :func:`controller_statespace`) are in
:mod:`bridgeflap.model.aeroelastic.python_control`, which imports nothing of the controller's
modules, so that :mod:`bridgeflap.model.aeroelastic.control` can call them without a cycle; they are
re-exported here.

May import: the foundation, bridgeflap.model.structure and bridgeflap.model.aeroelastic (the plant,
lazily).
"""

from __future__ import annotations

import numpy as np

from bridgeflap.model.aeroelastic.control_plant import INPUTS, MAX_FLAPS
from bridgeflap.model.aeroelastic.controller_file import as_controller

# the conversions, public here too
from bridgeflap.model.aeroelastic.python_control import (  # noqa: F401
    _control,
    compensator_tf,
    controller_statespace,
)
from bridgeflap.model.arguments import count, one_of, optional
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.grid import speed_grid
from bridgeflap.model.structure.bridge_arg import takes_bridge
from bridgeflap.model.vocabulary import DEFAULT_MODES

__all__ = ["closed_loop", "compensator_tf", "controller_statespace", "plant_family"]


@takes_bridge(controller=as_controller, inputs=None)
def closed_loop(bridge, speed: float, controller, n_modes: int = DEFAULT_MODES,
                flap_chord_m: float | None = None):
    """The package's closed loop at ``speed`` [m/s] as a named ``control.StateSpace``.

    The matrices of :func:`bridgeflap.model.aeroelastic.flaps.closed_loop_state_space` (the flap
    loads with ``beta``, ``beta'`` and ``beta''`` closed through the compensator): inputs
    ``gust[i]`` [m/s, up], outputs ``heave[i]`` [m], ``pitch[i]`` [rad] and ``beta[f]`` [rad], so
    its poles are the eigenvalues the flutter sweep of ``bridgeflap flutter --controller`` tracks.
    ``bridge``: a name, a bridge TOML path or a
    :class:`~bridgeflap.model.structure.spec.BridgeSpec`.

    Parameters
    ----------
    bridge : str, path-like or BridgeSpec
        A built-in name, a bridge TOML file or a spec.
    speed : float
        Wind speed [m/s], ``>= 0``.
    controller : Controller
        The compensator and its flap layout.
    n_modes : int, default 30
        Retained vertical + torsional modes.
    flap_chord_m : float, optional
        Chordwise flap size [m] (default: the controller's own).

    Returns
    -------
    control.StateSpace
        The closed loop with named signals (needs the ``control`` extra).

    Raises
    ------
    BridgeflapInputError
        A bad bridge, speed or controller.
    ImportError
        python-control is not installed (``pip install "bridgeflap[control]"``).
    """
    from bridgeflap.model.aeroelastic.control_plant import closed_loop_plant

    U = float(speed)
    if not (np.isfinite(U) and U >= 0):
        raise BridgeflapInputError("speed", f"must be a non-negative number, got {speed}")
    p = closed_loop_plant(bridge, controller, U, int(n_modes), flap_chord_m)
    return _control().ss(p.A, p.B, p.C, p.D, inputs=list(p.input_names),
                         outputs=list(p.output_names), states=list(p.state_names),
                         name="bridgeflap_closed_loop_U" + f"{U:g}".replace(".", "p"))


@takes_bridge(controller=optional(as_controller), inputs=one_of(*INPUTS),
              flaps=count(1, MAX_FLAPS))
def plant_family(bridge, speeds, inputs: str = "gust", n_modes: int = DEFAULT_MODES,
                 **options) -> dict:
    """``{speed [m/s]: control.StateSpace}``: :func:`bridgeflap.model.plant` at each of ``speeds``.

    The modal model and the aeroelastic system are built once (the speeds change only
    ``A(U)``, ``B(U)``); ``inputs`` and ``options`` (``controller``, ``flaps``,
    ``flap_chord_m``) as for :func:`bridgeflap.model.aeroelastic.control_plant.plant_data`.

    Parameters
    ----------
    bridge : str, path-like or BridgeSpec
        A built-in name, a bridge TOML file or a spec.
    speeds : sequence of float
        Wind speeds [m/s].
    inputs : {"gust", "flaps", "both"}, default "gust"
        The plant's inputs.
    n_modes : int, default 30
        Retained vertical + torsional modes.
    **options
        ``controller``, ``flaps``, ``flap_chord_m``, as :func:`bridgeflap.model.plant_data`.

    Returns
    -------
    dict of float to control.StateSpace
        One plant per speed (needs the ``control`` extra).

    Raises
    ------
    BridgeflapInputError
        A bad bridge, speed or option.
    """
    from bridgeflap.model.aeroelastic import statespace
    from bridgeflap.model.aeroelastic.control_plant import plant_data
    from bridgeflap.model.structure.fe import assemble
    from bridgeflap.model.structure.modes import solve

    u = speed_grid(speeds)  # "lo:hi:step" text or numbers [m/s], >= 0
    if options.get("system") is None:  # the system of plant_data, built once
        if int(n_modes) < 1:
            raise BridgeflapInputError("modes", f"must be at least 1, got {n_modes}")
        basis = solve(assemble(bridge)).structural_basis(int(n_modes))
        options["system"] = statespace.spec_system(bridge, basis)
    _control()
    return {float(U): plant_data(bridge, float(U), inputs, n_modes, **options).to_control()
            for U in u}
