"""Every function that takes a bridge takes a name, a file or a :class:`~model.spec.BridgeSpec`.

:func:`takes_bridge` decorates a public function whose first parameter is the bridge: a
built-in name (``"humber"``, ``"humber:box"``), a bridge TOML path (``str`` or
:class:`os.PathLike`) is loaded with :func:`model.spec.load_bridge`; anything else (a spec, an
erection stage, an aeroelastic system where the function also takes one) is passed on as it is.
The bad-input contract is :func:`~model.spec.load_bridge`'s: one line naming ``bridge``.
"""

from __future__ import annotations

import functools
import inspect
import os

__all__ = ["as_bridge", "takes_bridge"]


def as_bridge(bridge):
    """``load_bridge(bridge)`` for a name or a path; anything else as it is."""
    if isinstance(bridge, str | os.PathLike):
        from model.spec import load_bridge

        return load_bridge(bridge)
    return bridge


def takes_bridge(fn):
    """Decorate ``fn`` so that its first parameter accepts a name, a file or a spec."""
    first = next(iter(inspect.signature(fn).parameters))

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        if args:
            args = (as_bridge(args[0]), *args[1:])
        elif first in kwargs:
            kwargs[first] = as_bridge(kwargs[first])
        return fn(*args, **kwargs)

    return wrapper
