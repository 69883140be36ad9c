"""What names a bridge in the records of a run: a one-line label, and the identity that keys a
batch fingerprint and a study's or DOE's resolved configuration.

A bridge is given as a built-in name, a bridge TOML path or an in-memory
:class:`~bridgeflap.model.structure.spec.BridgeSpec` (a script's modified bridge). A name or path is
its own identity; a spec is named by the SHA-256 of its canonical form, so two different specs
never share a ``--resume`` record. The batch runner
(:func:`bridgeflap.design.batch.runner.function_fingerprint`), the DOE and study files
(:mod:`bridgeflap.design.studies.experiments`, :mod:`bridgeflap.design.studies.study`) and the
report use these.
"""

from __future__ import annotations

from bridgeflap.model.structure.spec import BridgeSpec

__all__ = ["bridge_identity", "bridge_label"]


def bridge_label(bridge) -> str:
    """A one-line name of ``bridge`` for JSON records and reports: the name or path given, or
    ``"<in-memory BridgeSpec 'humber'>"`` for a spec."""
    if isinstance(bridge, BridgeSpec):
        return f"<in-memory BridgeSpec {bridge.name!r}>"
    return str(bridge)


def bridge_identity(bridge) -> dict:
    """What identifies ``bridge`` in a batch fingerprint: ``{"bridge": label}`` and, for an
    in-memory spec, ``bridge_spec_sha256``: the SHA-256 of its canonical form (every resolved
    value and source; the same in every process;
    :mod:`bridgeflap.model.aeroelastic.controller_file`)."""
    if not isinstance(bridge, BridgeSpec):
        return {"bridge": str(bridge)}
    from bridgeflap.model.aeroelastic.controller_file import _canonical_sha256

    return {"bridge": bridge_label(bridge), "bridge_spec_sha256": _canonical_sha256(bridge)}
