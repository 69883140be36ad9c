"""python-control first-class: the compensator, the controller, the closed loop, plant families.

Objects of the python-control package (``control``, the optional extra ``bridgeflap[control]``,
imported lazily; without it every function raises one :class:`~model.errors.BridgeflapError`
line):

* :meth:`Compensator.to_control() <model.aeroelastic.control.Compensator.to_control>` -- ``K(s)`` as
  a ``control.TransferFunction`` (input ``pitch`` [rad], output ``beta`` [rad]);
* :meth:`Controller.to_statespace() <model.aeroelastic.control.Controller.to_statespace>` -- the
  controller as a ``control.StateSpace`` from the deck pitch at each flap, ``pitch_flap[f]``, to
  the flap drives ``flap_te[f] = +K pitch_flap[f]`` and ``flap_le[f] = -K pitch_flap[f]`` (the
  fitted edges only): the signal names of :func:`model.plant` with ``inputs="flaps"``, so
  ``control.feedback(P, K, sign=1)`` (or ``control.interconnect``) closes the package's loop;
* :func:`closed_loop` -- the package's own closed loop
  (:func:`model.aeroelastic.flaps.closed_loop_system`, what ``bridgeflap flutter --controller``
  sweeps) at one wind speed, gust inputs;
* :func:`plant_family` -- the open-loop plant (:func:`model.plant`) over a list of wind speeds,
  the modal model solved once.

Conventions and signal names: :mod:`model`, :mod:`model.aeroelastic.control_plant`.
"""

from __future__ import annotations

import numpy as np

from model.errors import BridgeflapError, BridgeflapInputError
from model.grid import speed_grid
from model.structure.bridge_arg import takes_bridge
from model.vocabulary import DEFAULT_MODES

__all__ = ["closed_loop", "compensator_tf", "controller_statespace", "plant_family"]


def _control():
    try:
        import control
    except ImportError as exc:  # the optional extra
        raise BridgeflapError("python-control is not installed: pip install "
                              "'bridgeflap[control]' (or pip install control)") from exc
    return control


def compensator_tf(compensator):
    """``K(s) = (b2 s^2 + b1 s + b0) / (a2 s^2 + a1 s + 1)`` as a ``control.TransferFunction``
    (first order, ``a2 = 0``: ``(b1 s + b0) / (a1 s + 1)``); input ``pitch``, output ``beta``."""
    control = _control()
    c = compensator
    num, den = ([c.b2, c.b1, c.b0], [c.a2, c.a1, 1.0]) if c.a2 > 0.0 else (
        [c.b1, c.b0], [c.a1, 1.0])
    return control.tf(num, den, inputs="pitch", outputs="beta", name="K")


def controller_statespace(controller):
    """The controller as a ``control.StateSpace`` (module docstring): ``n_flaps`` copies of the
    compensator's realisation (:meth:`~model.aeroelastic.control.Compensator.state_space`), states
    ``xc[f,i]``, inputs ``pitch_flap[f]``, outputs ``flap_te[f]`` then ``flap_le[f]``."""
    control = _control()
    Ac, Bc, Cc, Dc = controller.compensator.state_space()
    nf, nc = controller.n_flaps, Ac.shape[0]
    eye = np.eye(nf)
    signs = [s for s, on in ((1.0, controller.trailing_edge), (-1.0, controller.leading_edge))
             if on]
    edges = [e for e, on in (("te", controller.trailing_edge), ("le", controller.leading_edge))
             if on]
    A, B = np.kron(eye, Ac), np.kron(eye, Bc)
    C = np.vstack([s * np.kron(eye, Cc) for s in signs])
    D = np.vstack([s * np.kron(eye, Dc) for s in signs])
    return control.ss(A, B, C, D, inputs=[f"pitch_flap[{f}]" for f in range(nf)],
                      outputs=[f"flap_{e}[{f}]" for e in edges for f in range(nf)],
                      states=[f"xc[{f},{i}]" for f in range(nf) for i in range(nc)],
                      name="controller")


@takes_bridge
def closed_loop(bridge, speed: float, controller, n_modes: int = DEFAULT_MODES,
                flap_chord_m: float | None = None):
    """The package's closed loop at ``speed`` [m/s] as a named ``control.StateSpace``.

    The matrices of :func:`model.aeroelastic.flaps.closed_loop_state_space` (the flap loads with
    ``beta``, ``beta'`` and ``beta''`` closed through the compensator): inputs ``gust[i]`` [m/s,
    up], outputs ``heave[i]`` [m], ``pitch[i]`` [rad] and ``beta[f]`` [rad], so its poles are the
    eigenvalues the flutter sweep of ``bridgeflap flutter --controller`` tracks.
    ``bridge``: a name, a bridge TOML path or a :class:`~model.structure.spec.BridgeSpec`.
    """
    from model.aeroelastic.control_plant import closed_loop_plant

    U = float(speed)
    if not (np.isfinite(U) and U >= 0):
        raise BridgeflapInputError("speed", f"must be a non-negative number, got {speed}")
    p = closed_loop_plant(bridge, controller, U, int(n_modes), flap_chord_m)
    return _control().ss(p.A, p.B, p.C, p.D, inputs=list(p.input_names),
                         outputs=list(p.output_names), states=list(p.state_names),
                         name=f"bridgeflap_closed_loop_U{U:g}")


@takes_bridge
def plant_family(bridge, speeds, inputs: str = "gust", n_modes: int = DEFAULT_MODES,
                 **options) -> dict:
    """``{speed [m/s]: control.StateSpace}``: :func:`model.plant` at each of ``speeds``.

    The modal model and the aeroelastic system are built once (the speeds change only
    ``A(U)``, ``B(U)``); ``inputs`` and ``options`` (``controller``, ``flaps``,
    ``flap_chord_m``) as for :func:`model.aeroelastic.control_plant.plant_data`.
    """
    from model.aeroelastic import statespace
    from model.aeroelastic.control_plant import plant_data
    from model.structure.fe import assemble
    from model.structure.modes import solve

    u = speed_grid(speeds)  # "lo:hi:step" text or numbers [m/s], >= 0
    if options.get("system") is None:  # the system of plant_data, built once
        if int(n_modes) < 1:
            raise BridgeflapInputError("modes", f"must be at least 1, got {n_modes}")
        basis = solve(assemble(bridge)).structural_basis(int(n_modes))
        options["system"] = statespace.spec_system(bridge, basis)
    _control()
    return {float(U): plant_data(bridge, float(U), inputs, n_modes, **options).to_control()
            for U in u}
