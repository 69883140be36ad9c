"""The design problem's bridge and closed-loop flap model (:func:`build_model`), below the
multistart driver so that the flap-count, pair-failure and acceptance steps can build a
model without importing :mod:`design.driver`; the driver re-exports it."""

from __future__ import annotations

import numpy as np

from design.settings import DesignSettings


def build_model(settings: DesignSettings, count=None, modal=None, n_modes=None,
                positions=None, spec=None):
    """Bridge and closed-loop flap model of a design problem.

    Parameters
    ----------
    settings : DesignSettings
    count : int, optional
        Evenly spaced flap count (default ``settings.flap_count``).
    modal : model.modes.ModalModel, optional
        Reused modal model.
    n_modes : int, optional
        Retained modes (default ``settings.n_modes``).
    positions : array_like, optional
        Flap centres from the main-span mid-point [m] (overrides ``count``).
    spec : model.spec.BridgeSpec, optional
        The bridge (default: the built-in ``settings.bridge``).

    Returns
    -------
    spec : model.spec.BridgeSpec
    model : model.flaps.ClosedLoopModel
    """
    from model.flaps import closed_loop_model
    from model.spec import load_bridge

    spec = load_bridge(settings.bridge if spec is None else spec)
    pos = settings.positions(count) if positions is None else np.asarray(positions, float)
    return spec, closed_loop_model(spec, pos, settings.flap_width_m,
                                   settings.n_modes if n_modes is None else int(n_modes),
                                   settings.flap_chord_m, settings.leading_edge,
                                   settings.trailing_edge, modal=modal)
