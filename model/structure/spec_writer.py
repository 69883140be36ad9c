"""Write a :class:`~bridgeflap.model.structure.spec.BridgeSpec` back as a bridge TOML file (the
loader's format).

:func:`to_toml` gives the text (checking that it is given a spec), :func:`save_bridge` writes it
(a name, a file or a spec); :meth:`BridgeSpec.to_toml` is the same text. What is written and the
round trip ``load_bridge(path) -> to_toml -> write -> load_bridge`` (an equal spec with the same
``sources``): :mod:`bridgeflap.model.structure.bridge_toml`, which builds the text.
"""

from __future__ import annotations

import os
from pathlib import Path

from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.structure.bridge_arg import takes_bridge
from bridgeflap.model.structure.bridge_toml import bridge_toml
from bridgeflap.model.structure.spec import BridgeSpec

__all__ = ["save_bridge", "to_toml"]


def to_toml(spec) -> str:
    """The bridge TOML text of ``spec`` (:func:`bridgeflap.model.structure.bridge_toml.bridge_toml`:
    what is written, the round trip).

    Raises
    ------
    BridgeflapInputError
        ``bridge`` when ``spec`` is not a :class:`~bridgeflap.model.structure.spec.BridgeSpec`;
        ``erected_fraction`` for an erection stage.
    """
    if not isinstance(spec, BridgeSpec):
        raise BridgeflapInputError("bridge", f"must be a BridgeSpec, got {type(spec).__name__}")
    return bridge_toml(spec)


@takes_bridge
def save_bridge(bridge, path: str | os.PathLike) -> Path:
    """Write a bridge as a complete, commented bridge TOML file.

    Every value is written with its source note (a value changed by
    :meth:`BridgeSpec.replace` says ``user-set value (was: ...)``); ``load_bridge`` reads the file
    back as an equal spec.

    Parameters
    ----------
    bridge : str, path-like or BridgeSpec
        A built-in name, a bridge file or a spec (not an erection stage: write
        ``spec.completed()``).
    path : str or path-like
        The file to write; its name ends in ``.toml``.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    BridgeflapInputError
        ``path`` for another suffix or an unwritable place; ``erected_fraction`` for an
        erection stage.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from bridgeflap import model
    >>> path = model.save_bridge("humber", pathlib.Path(tempfile.mkdtemp()) / "mine.toml")
    >>> model.load_bridge(path) == model.load_bridge("humber")
    True
    """
    p = Path(path)
    if p.suffix.lower() != ".toml":
        raise BridgeflapInputError("path", f"a bridge file ends in .toml, got {p.name!r}")
    text = to_toml(bridge)
    try:
        p.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise BridgeflapInputError("path", f"cannot write {p}: {exc.strerror or exc}") from None
    return p
