"""What ``controller.toml`` records of the plant it was designed on, and the checks on loading.

A controller closes its loop through flaps of a given chord, width, strip positions and edges
(:class:`model.control.Controller`) on one bridge and mode count
(:class:`model.control.PlantRecord`). :func:`plant_record` builds the record of a design;
:func:`check_controller_plant` compares a loaded controller with the bridge it is about to be
checked on: a different bridge is one warning line, a flap geometry the bridge cannot carry is
:class:`~model.errors.BridgeflapInputError` naming the field (exit status 2 in the CLI).
"""

from __future__ import annotations

import dataclasses
import hashlib
import re
from importlib import resources
from pathlib import Path

from model.control import Controller, PlantRecord
from model.errors import BridgeflapInputError

__all__ = ["bridge_sha256", "check_controller_plant", "plant_record", "split_bridge"]


def split_bridge(bridge: str) -> tuple[str, str]:
    """``(base, variant)`` of a ``--bridge`` value (``"humber:box"`` -> ``("humber", "box")``;
    ``""`` for no variant), as :func:`model.spec.load_bridge` reads it."""
    from model.spec import _split_variant

    base, variant = _split_variant(str(bridge))
    return base, variant or ""


def _canonical_sha256(spec) -> str:
    """SHA-256 of a spec's canonical form: its repr with object addresses removed (every
    resolved value; the same in every process)."""
    text = re.sub(r" at 0x[0-9a-fA-F]+", "", repr(spec))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def bridge_sha256(bridge: str) -> str:
    """SHA-256 (hex) of the content of the definition file of ``bridge`` (a built-in name:
    the packaged file; a path: that file), variant suffix ignored (recorded apart)."""
    from model.spec import BUILTIN_BRIDGES, BUILTIN_FILES

    base, _ = split_bridge(bridge)
    if base in BUILTIN_BRIDGES:
        content = resources.files("model.bridges").joinpath(BUILTIN_FILES[base]).read_bytes()
    else:
        try:
            content = Path(base).read_bytes()
        except OSError as exc:
            raise BridgeflapInputError("bridge", f"cannot read {base}: {exc}") from None
    return hashlib.sha256(content).hexdigest()


def plant_record(bridge: str, design_modes: int, spec=None) -> PlantRecord:
    """The :class:`~model.control.PlantRecord` of a design on ``bridge`` (the
    ``load_bridge`` string) with ``design_modes`` modes.

    ``spec``: the bridge the design actually ran on when it was not
    ``load_bridge(bridge)`` (a modified or erected spec): its canonical form is hashed then.
    """
    from model.spec import load_bridge

    base, variant = split_bridge(bridge)
    loaded = load_bridge(bridge)
    if spec is None or _canonical_sha256(spec) == _canonical_sha256(loaded):
        digest, name = bridge_sha256(bridge), loaded.name
    else:
        digest, name = _canonical_sha256(spec), spec.name
    return PlantRecord(bridge=base, bridge_variant=variant, bridge_name=name,
                       bridge_sha256=digest, design_modes=int(design_modes))


def _check_geometry(controller: Controller, spec) -> None:
    """Raise naming the field where ``spec`` cannot carry the controller's flaps."""
    b = float(spec.deck.half_chord_m)
    chord = controller.chord_m
    if not chord < b:
        raise BridgeflapInputError(
            "controller.flap_chord_m",
            f"flap chord {chord:g} m does not fit in the deck of {spec.name!r}: it must be "
            f"below the half-chord b = {b:g} m (LE and TE flaps inside the chord)")
    lengths = [s.length_m for s in spec.spans]
    half = 0.5 * float(lengths[spec.main_span_index])
    w = controller.flap_width_m
    for i, x in enumerate(controller.flap_strip_positions_m):
        if abs(x) + 0.5 * w > half + 1e-9:
            raise BridgeflapInputError(
                "controller.flap_strip_positions_m",
                f"flap {i} at {x:g} m (width {w:g} m) reaches outside the main span of "
                f"{spec.name!r} (|x| + width/2 <= {half:g} m)")


def check_controller_plant(controller: Controller, bridge: str, spec) -> str | None:
    """Check a loaded controller against the bridge ``spec`` (loaded from ``bridge``).

    Returns
    -------
    str or None
        One warning line when the controller was designed on another bridge (name, variant
        or definition-file hash differ) or records no plant (a file written before the
        geometry was recorded: the default 3 m flap chord applies); ``None`` when it matches.

    Raises
    ------
    BridgeflapInputError
        ``controller.flap_chord_m`` or ``controller.flap_strip_positions_m`` when the flaps do
        not fit on ``spec`` (chord not below the half-chord, a strip outside the main span).
    """
    _check_geometry(controller, spec)
    rec = controller.plant
    if rec is None:
        chord = ("the default 3 m flap chord" if controller.flap_chord_m is None else
                 f"its {controller.chord_m:g} m flap chord")
        return (f"has no geometry record (bridge, design modes, bridge hash): checked with "
                f"{chord} on {bridge}")
    base, variant = split_bridge(bridge)
    try:
        digest = bridge_sha256(bridge)
    except BridgeflapInputError:
        digest = None
    here = dataclasses.replace(rec, bridge=base, bridge_variant=variant,
                               bridge_sha256=digest or "", bridge_name=spec.name)
    diff = [f for f in ("bridge_name", "bridge_variant", "bridge_sha256", "bridge")
            if getattr(rec, f) != getattr(here, f)]
    # the path a bridge file was given by may differ (relative, copied): same content, same
    # name and variant is the same bridge
    if diff == ["bridge"] and base not in _builtin():
        diff = []
    if not diff:
        return None
    return (f"designed on bridge {_label(rec.bridge, rec.bridge_variant)} "
            f"({rec.bridge_name!r}, sha256 {rec.bridge_sha256[:12]}), checked on "
            f"{_label(base, variant)} ({spec.name!r}, sha256 {(digest or '?')[:12]}): "
            f"{', '.join(diff)} differ")


def _builtin() -> tuple:
    from model.spec import BUILTIN_BRIDGES

    return tuple(BUILTIN_BRIDGES)


def _label(base: str, variant: str) -> str:
    return f"{base}:{variant}" if variant else base
