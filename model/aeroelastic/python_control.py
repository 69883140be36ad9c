"""The compensator and the controller as python-control objects (the optional extra).

:meth:`Compensator.to_control() <bridgeflap.model.aeroelastic.control.Compensator.to_control>` and
:meth:`Controller.to_statespace() <bridgeflap.model.aeroelastic.control.Controller.to_statespace>`
call
:func:`compensator_tf` and :func:`controller_statespace`;
:mod:`bridgeflap.model.aeroelastic.control_interop` (the closed loop, plant families) re-exports
both. python-control (``control``, the extra ``bridgeflap[control]``) is imported lazily; without it
every function raises one
:class:`~bridgeflap.model.errors.BridgeflapError` line. Signal names:
:mod:`bridgeflap.model.aeroelastic.control_interop`.

May import: numpy and :mod:`bridgeflap.model.errors` only -- it takes the compensator and controller
as arguments and imports none of bridgeflap.model.aeroelastic, so that
:mod:`bridgeflap.model.aeroelastic.control` imports it without a cycle.
"""

from __future__ import annotations

import numpy as np

from bridgeflap.model.errors import BridgeflapError

__all__ = ["compensator_tf", "controller_statespace"]


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
    compensator's realisation
    (:meth:`~bridgeflap.model.aeroelastic.control.Compensator.state_space`), states ``xc[f,i]``,
    inputs ``pitch_flap[f]``, outputs ``flap_te[f]`` then ``flap_le[f]``."""
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
