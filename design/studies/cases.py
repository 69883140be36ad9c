"""Picklable case functions for the DOE batch runner
(:func:`bridgeflap.design.batch.runner.run_batch`).

A case function is ``fn(params) -> dict`` once its settings are bound with
:func:`functools.partial` (which keeps it picklable for Dask workers): ``params`` maps dotted
parameter paths (:data:`bridgeflap.model.structure.spec.PARAMETER_PATHS`, plus
``"erected_fraction"``) to values in SI units; the settings are the bridge and the options of an
analysis of the registry (:data:`bridgeflap.design.studies.analyses.ANALYSES`), whose defaults apply
to every option not given. Each returns the analysis' case row (plain numbers with units in the key
names and the solver statuses); a failure raises, and the runner records the row as failed.

The bridge is a built-in name, a bridge TOML path or an in-memory
:class:`~bridgeflap.model.structure.spec.BridgeSpec` (a script's modified bridge): the spec itself
goes to the workers (pickled with the case function) and
:func:`bridgeflap.design.io.identity.bridge_identity` names it in the fingerprint of a batch by the
SHA-256 of its canonical form, so two different specs never share a ``--resume`` record.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.structure.loader import load_bridge
from bridgeflap.model.structure.spec import PARAMETER_PATHS, BridgeSpec

__all__ = ["ERECTED_FRACTION", "analysis_case", "apply_parameters", "check_applicable",
           "flutter_case"]

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


def analysis_case(params: Mapping, analysis: str, bridge: str | BridgeSpec = "humber",
                  **options) -> dict:
    """The case row of registered ``analysis`` on ``bridge`` with ``params`` applied.

    Parameters
    ----------
    params : Mapping
        Dotted parameter path -> value [SI].
    analysis : str
        A registered analysis with a case row (flutter, modes, buffeting).
    bridge : str or BridgeSpec
        Built-in name, bridge TOML path or an in-memory spec.
    **options
        Options of the analysis; the registry's defaults fill in the rest.
    """
    from bridgeflap.design.studies.analyses import ANALYSES, RunContext

    entry = ANALYSES[analysis]
    if entry.case is None:
        raise BridgeflapInputError("analysis", f"{analysis!r} has no DOE case")
    spec = apply_parameters(load_bridge(bridge), params)
    return entry.case(entry(spec, options, RunContext(bridge=bridge, figures=False)))


def check_applicable(bridge: str, values: Mapping) -> None:
    """Each parameter applied alone to ``bridge`` before a batch runs: an FE parameter on a
    modal bridge (or a value the bridge refuses) is refused in one line naming
    ``parameters.<path>``, not recorded as the failure of every case."""
    if not isinstance(bridge, str | Path | BridgeSpec):
        raise BridgeflapInputError(
            "bridge", f"a batch takes a built-in name, a bridge TOML path or a BridgeSpec, got "
                      f"{type(bridge).__name__}")
    spec = load_bridge(bridge)
    for path, value in values.items():
        try:
            apply_parameters(spec, {path: value})
        except BridgeflapInputError as exc:
            raise BridgeflapInputError(f"parameters.{path}", exc.reason) from None


def flutter_case(params: Mapping, bridge: str | BridgeSpec = "humber", **options) -> dict:
    """Flutter and divergence speeds [m/s] and statuses of one parameter set."""
    return analysis_case(params, "flutter", bridge, **options)
