"""Every function that takes a bridge takes a name, a file or a
:class:`~model.structure.spec.BridgeSpec`.

:func:`takes_bridge` decorates a public function whose first parameter is the bridge: a
built-in name (``"humber"``, ``"humber:box"``), a bridge TOML path (``str`` or
:class:`os.PathLike`) is loaded with :func:`model.structure.loader.load_bridge`; anything else (a
spec, an erection stage, an aeroelastic system where the function also takes one) is passed on as it
is. The bad-input contract is :func:`~model.structure.loader.load_bridge`'s: one line naming
``bridge``. A keyword the API no longer uses (``spec=``, ``count=``, ``wind_speed=``) raises naming
its new name (:func:`model.vocabulary.check_renamed`).
"""

from __future__ import annotations

import functools
import inspect
import os
from typing import TYPE_CHECKING, Union

from model.vocabulary import check_renamed

if TYPE_CHECKING:
    from model.structure.spec import BridgeSpec

__all__ = ["BridgeArg", "as_bridge", "takes_bridge"]

#: what a ``bridge`` argument may be: a built-in name, a bridge TOML path or a spec
BridgeArg = Union[str, os.PathLike, "BridgeSpec"]  # noqa: UP007 - a forward reference


def as_bridge(bridge):
    """``load_bridge(bridge)`` for a name or a path; anything else as it is."""
    if isinstance(bridge, str | os.PathLike):
        from model.structure.loader import load_bridge

        return load_bridge(bridge)
    return bridge


def takes_bridge(fn):
    """Decorate ``fn`` so that its first parameter accepts a name, a file or a spec."""
    parameters = tuple(inspect.signature(fn).parameters)
    first = parameters[0]

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        check_renamed(fn.__name__, parameters, kwargs)
        if args:
            args = (as_bridge(args[0]), *args[1:])
        elif first in kwargs:
            kwargs[first] = as_bridge(kwargs[first])
        return fn(*args, **kwargs)

    wrapper.takes_bridge = True  # read by tests/test_vocabulary.py
    return wrapper
