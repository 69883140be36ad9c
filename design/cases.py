"""Picklable case functions for the DOE batch runner (:func:`design.doe.run_batch`).

A case function is ``fn(params, **settings) -> dict``: ``params`` maps dotted parameter paths
(:data:`model.spec.PARAMETER_PATHS`, plus ``"erected_fraction"``) to values in SI units; the
settings (bridge, speed grid, modes, ...) are bound with :func:`functools.partial`, which keeps
the function picklable for Dask workers. Each returns plain numbers with units in the key names
and the solver statuses; a failure raises, and the runner records the row as failed.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping

import numpy as np

from model.errors import BridgeflapInputError
from model.spec import PARAMETER_PATHS, BridgeSpec, load_bridge

__all__ = ["ANALYSES", "apply_parameters", "buffeting_case", "flutter_case", "modes_case"]

ERECTED_FRACTION = "erected_fraction"


def apply_parameters(spec: BridgeSpec, params: Mapping) -> BridgeSpec:
    """``spec`` with the dotted-path values of ``params`` (and ``erected_fraction``) applied."""
    changes = {}
    fraction = None
    for key, value in params.items():
        if key == ERECTED_FRACTION:
            fraction = value
        elif key in PARAMETER_PATHS:
            changes[key] = value
        else:
            raise BridgeflapInputError("parameters", f"unknown parameter {key!r}")
    spec = spec.replace(**changes)
    return spec if fraction is None else spec.erected(float(fraction))


def flutter_case(params: Mapping, bridge: str = "humber", speeds: str = "0:120:1",
                 modes: int = 10, rfa: str = "rfa4", order: str = "modal") -> dict:
    """Flutter and divergence speeds [m/s] and statuses of one parameter set."""
    from model.analysis import flutter

    spec = apply_parameters(load_bridge(bridge), params)
    s = flutter(spec, speeds, n_modes=int(modes), order=order, rfa=rfa).summary()
    return {k: s[k] for k in ("flutter_speed_m_s", "flutter_frequency_hz", "flutter_status",
                              "divergence_speed_m_s", "divergence_status",
                              "divergence_static_speed_m_s", "critical_branch_label")}


def modes_case(params: Mapping, bridge: str = "humber") -> dict:
    """Frequencies [Hz] of the first symmetric vertical and torsional main-span modes."""
    from model.analysis import _first, modal_model

    spec = apply_parameters(load_bridge(bridge), params)
    modal = modal_model(spec)
    fv, ft = _first(modal, "vertical"), _first(modal, "torsional")
    return {"vs1_hz": fv, "ts1_hz": ft, "frequency_ratio": ft / fv,
            "cable_horizontal_tension_n": modal.structure.statics.horizontal_tension_n}


def buffeting_case(params: Mapping, bridge: str = "humber", **options) -> dict:
    """Buffeting RMS summary of one parameter set (needs :mod:`model.buffeting`)."""
    from model.buffeting import buffeting

    spec = apply_parameters(load_bridge(bridge), params)
    res = buffeting(spec, **accepted_kwargs(buffeting, options))
    s = res.summary()
    rms = np.asarray(s.get("rms_vertical_m", []), dtype=float)
    return {"max_rms_vertical_m": float(np.nanmax(rms)) if rms.size else float("nan"),
            "status": s.get("status", "unknown")}


def accepted_kwargs(fn, options: Mapping) -> dict:
    """The subset of ``options`` that ``fn`` accepts (for analyses written in parallel)."""
    try:
        params = inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return dict(options)
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return dict(options)
    return {k: v for k, v in options.items() if k in params}


#: analysis name -> (case function, option names it takes besides ``bridge``)
ANALYSES = {
    "flutter": (flutter_case, ("speeds", "modes", "rfa", "order")),
    "modes": (modes_case, ()),
    "buffeting": (buffeting_case, None),  # options passed through (see accepted_kwargs)
}
