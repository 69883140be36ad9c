"""What ``controller.toml`` records of the plant it was designed on, and the checks on loading.

A controller closes its loop through flaps of a given chord, width, strip positions and edges
(:class:`bridgeflap.model.aeroelastic.control.Controller`) on one bridge and mode count
(:class:`bridgeflap.model.aeroelastic.control.PlantRecord`). :func:`plant_record` builds the record
of a design;
:func:`check_controller_plant` compares a loaded controller with the bridge it is about to be
checked on: a different bridge is one warning line, a flap geometry the bridge cannot carry is
:class:`~bridgeflap.model.errors.BridgeflapInputError` naming the field (exit status 2 in the CLI).
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import re
import sys
from importlib import resources
from pathlib import Path

from bridgeflap.model.aeroelastic.control import Compensator, Controller, PlantRecord, _check_number
from bridgeflap.model.arguments import check_path, checked, describe
from bridgeflap.model.errors import BridgeflapInputError, BridgeflapTypeError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised only on Python 3.10
    import tomli as tomllib

__all__ = ["as_controller", "bridge_sha256", "check_controller_plant", "load_controller",
           "plant_record", "save_controller", "split_bridge"]


def split_bridge(bridge: str) -> tuple[str, str]:
    """``(base, variant)`` of a ``--bridge`` value (``"humber:box"`` -> ``("humber", "box")``;
    ``""`` for no variant), as :func:`bridgeflap.model.structure.loader.load_bridge` reads it."""
    from bridgeflap.model.structure.loader import _split_variant

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
    from bridgeflap.model.structure.builtin_bridges import BUILTIN_BRIDGES, BUILTIN_FILES

    base, _ = split_bridge(bridge)
    if base in BUILTIN_BRIDGES:
        content = resources.files("bridgeflap.model.bridges").joinpath(
            BUILTIN_FILES[base]).read_bytes()
    else:
        try:
            content = Path(base).read_bytes()
        except OSError as exc:
            raise BridgeflapInputError("bridge", f"cannot read {base}: {exc}") from None
    return hashlib.sha256(content).hexdigest()


def plant_record(bridge: str, design_modes: int, spec=None) -> PlantRecord:
    """The :class:`~bridgeflap.model.aeroelastic.control.PlantRecord` of a design on ``bridge`` (the
    ``load_bridge`` string) with ``design_modes`` modes.

    ``spec``: the bridge the design actually ran on when it was not
    ``load_bridge(bridge)`` (a modified or erected spec): its canonical form is hashed then.
    """
    from bridgeflap.model.structure.loader import load_bridge

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
    from bridgeflap.model.structure.builtin_bridges import BUILTIN_BRIDGES

    return tuple(BUILTIN_BRIDGES)


def _label(base: str, variant: str) -> str:
    return f"{base}:{variant}" if variant else base


# ---------------------------------------------------------------------------- TOML I/O
_COMPENSATOR_KEYS = ("b2", "b1", "b0", "a2", "a1")
_LAYOUT_KEYS = (
    "flap_strip_positions_m",
    "flap_width_m",
    "leading_edge",
    "trailing_edge",
    "gain_limit",
    "flap_chord_m",
)
#: the plant record (:class:`PlantRecord`): all of these or none
_PLANT_KEYS = ("bridge", "bridge_variant", "bridge_name", "bridge_sha256", "design_modes")
_REQUIRED_KEYS = _COMPENSATOR_KEYS + ("flap_strip_positions_m", "flap_width_m")
#: largest magnitude of a coefficient read from a controller file: b0 is a static gain
#: [rad/rad] (flaps turn a few tenths of a radian, the default gain limit is 15), b1, a1 [s] and
#: b2, a2 [s^2] are time constants of a deck controller (bridge modes at 0.03..10 Hz give
#: 0.01..100 s); 1e6 is four orders beyond both, and keeps their squares (sup |K(jw)|) finite,
#: where b0 = 1e300 overflowed
MAX_COEFFICIENT = 1.0e6
#: smallest positive a1 [s] and a2 [s^2] read from a file: a time constant T of 1 microsecond
#: (a1 = T, a2 = T^2) is three orders faster than any flap actuator, and b/a2, b/a1 of the
#: realisation stay finite (a2 = 1e-300 overflowed)
MIN_DENOMINATOR_COEFFICIENT = {"a1": 1.0e-6, "a2": 1.0e-12}


def as_controller(value, field: str = "controller") -> Controller:
    """``value`` if it is a :class:`Controller`; a controller file's path is loaded
    (:func:`load_controller`); anything else is a
    :class:`~bridgeflap.model.errors.BridgeflapTypeError` naming ``field``."""
    if isinstance(value, Controller):
        return value
    if isinstance(value, str | os.PathLike):
        return load_controller(value)
    raise BridgeflapTypeError(field, "must be a Controller or a controller .toml path "
                                     f"(bridgeflap.model.load_controller), got {describe(value)}")


@checked(path=check_path)
def load_controller(path) -> Controller:
    """Read a controller definition from a TOML file.

    Parameters
    ----------
    path : str or pathlib.Path
        File written by :func:`save_controller` (flat keys: ``b2 b1 b0 a2 a1``,
        ``flap_strip_positions_m``, ``flap_width_m``, optional ``leading_edge``,
        ``trailing_edge``, ``gain_limit``, ``flap_chord_m`` and the plant record
        ``bridge bridge_variant bridge_name bridge_sha256 design_modes``, all or none).

    Returns
    -------
    Controller
        ``flap_chord_m`` and ``plant`` are ``None`` for a file without them (written before
        they were recorded): such a file is read as before, with the default 3 m chord.

    Raises
    ------
    BridgeflapInputError
        Field ``"controller"`` for a missing or unparsable file, ``"controller.<key>"`` for a
        missing, unknown or invalid key.
    """
    path = Path(path)
    try:
        text = path.read_bytes()
    except FileNotFoundError:
        raise BridgeflapInputError("controller", f"file not found: {path}") from None
    except OSError as exc:
        raise BridgeflapInputError("controller", f"cannot read {path}: {exc}") from None
    try:
        data = tomllib.loads(text.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise BridgeflapInputError("controller", f"invalid TOML in {path}: {exc}") from None
    unknown = sorted(set(data) - set(_COMPENSATOR_KEYS) - set(_LAYOUT_KEYS) - set(_PLANT_KEYS))
    if unknown:
        raise BridgeflapInputError(f"controller.{unknown[0]}", "unknown field")
    for key in _REQUIRED_KEYS:
        if key not in data:
            raise BridgeflapInputError(f"controller.{key}", f"missing in {path}")
    for k in _COMPENSATOR_KEYS:
        v = _check_number(f"controller.{k}", data[k])
        if abs(v) > MAX_COEFFICIENT:
            raise BridgeflapInputError(f"controller.{k}", f"|{k}| = {abs(v):g} is beyond the "
                                       f"plausible {MAX_COEFFICIENT:g}")
        low = MIN_DENOMINATOR_COEFFICIENT.get(k, 0.0)
        if 0.0 < v < low:
            hint = " (a2 = 0 gives a first-order K)" if k == "a2" else ""
            raise BridgeflapInputError(f"controller.{k}", f"{k} = {v:g} is below the plausible "
                                       f"{low:g}{hint}")
    plant = None
    given = [k for k in _PLANT_KEYS if k in data]
    if given:
        missing = [k for k in _PLANT_KEYS if k not in data]
        if missing:
            raise BridgeflapInputError(f"controller.{missing[0]}",
                                       f"missing in {path} (the plant record is "
                                       f"{', '.join(_PLANT_KEYS)}: all or none)")
        if "flap_chord_m" not in data:  # written with the plant, so with the chord it closed on
            raise BridgeflapInputError("controller.flap_chord_m",
                                       f"missing in {path} (a file with the plant record "
                                       "records the flap chord it was designed with)")
        plant = PlantRecord(**{k: data[k] for k in _PLANT_KEYS})
    compensator = Compensator(*(data[k] for k in _COMPENSATOR_KEYS))
    layout = {k: data[k] for k in _LAYOUT_KEYS if k in data}
    return Controller(compensator=compensator, plant=plant, **layout)


_CONTROLLER_HEADER = """\
# bridgeflap controller definition (the paper, section 6)
# K(s) = (b2 s^2 + b1 s + b0) / (a2 s^2 + a1 s + 1)
# flap angle beta [rad] from local deck pitch alpha [rad]
# The leading-edge flap is driven by -K, the trailing-edge flap by +K.
# Units: b2, a2 [s^2]; b1, a1 [s]; b0 [rad/rad]; a2 >= 0, a1 > 0.
# flap_strip_positions_m: strip centres along the main span from its mid-point [m];
# flap_width_m: spanwise width per strip [m]; gain_limit: bound on sup_w |K(jw)| [rad/rad];
# flap_chord_m: chordwise flap size from each edge inside the deck chord [m].
# Designed on: bridge (built-in name or file), bridge_variant, bridge_name, bridge_sha256
# (SHA-256 of the bridge file's content) and design_modes (retained modes).

"""


def _a_controller(value, field: str) -> Controller:
    if not isinstance(value, Controller):
        raise BridgeflapTypeError(field, f"must be a Controller, got {describe(value)}")
    return value


@checked(controller=_a_controller, path=check_path)
def save_controller(controller: Controller, path) -> Path:
    """Write a controller definition as TOML (readable by :func:`load_controller`).

    Parameters
    ----------
    controller : Controller
        Definition to write.
    path : str or pathlib.Path
        Output file; parent directories must exist.

    Returns
    -------
    pathlib.Path
        The path written.

    Notes
    -----
    Written by :mod:`tomli_w` (floats round-trip exactly) under a comment header stating the
    transfer function, the drive signs and the units.
    """
    import tomli_w

    k = controller.compensator
    data = {"b2": float(k.b2), "b1": float(k.b1), "b0": float(k.b0), "a2": float(k.a2),
            "a1": float(k.a1),
            "flap_strip_positions_m": [float(x) for x in controller.flap_strip_positions_m],
            "flap_width_m": float(controller.flap_width_m),
            "leading_edge": bool(controller.leading_edge),
            "trailing_edge": bool(controller.trailing_edge),
            "gain_limit": float(controller.gain_limit)}
    if controller.flap_chord_m is not None:
        data["flap_chord_m"] = float(controller.flap_chord_m)
    if controller.plant is not None:
        p = controller.plant
        data.update(bridge=p.bridge, bridge_variant=p.bridge_variant, bridge_name=p.bridge_name,
                    bridge_sha256=p.bridge_sha256, design_modes=int(p.design_modes))
    path = Path(path)
    path.write_text(_CONTROLLER_HEADER + tomli_w.dumps(data), encoding="utf-8")
    return path
