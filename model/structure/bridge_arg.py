"""Every function that takes a bridge takes a name, a file or a
:class:`~bridgeflap.model.structure.spec.BridgeSpec`.

:func:`takes_bridge` decorates a public function whose first parameter is the bridge: a
built-in name (``"humber"``, ``"humber:box"``), a bridge TOML path (``str`` or
:class:`os.PathLike`) is loaded with :func:`bridgeflap.model.structure.loader.load_bridge`; anything
else (a spec, an erection stage, an aeroelastic system where the function also takes one) is passed
on as it is. The bad-input contract is :func:`~bridgeflap.model.structure.loader.load_bridge`'s: one
line naming ``bridge``. A keyword the API no longer uses (``spec=``, ``count=``, ``wind_speed=``)
raises naming its new name (:func:`bridgeflap.model.vocabulary.check_renamed`).
"""

from __future__ import annotations

import inspect
import os
from typing import TYPE_CHECKING, Union

from bridgeflap.model.arguments import (
    check_choice,
    check_path,
    check_text,
    checked,
    describe,
    number,
    one_of,
    optional,
)
from bridgeflap.model.errors import BridgeflapTypeError

if TYPE_CHECKING:
    from bridgeflap.model.structure.spec import BridgeSpec

__all__ = ["BRIDGE_RULES", "BridgeArg", "as_bridge", "as_rfa", "check_bridge_kind", "check_system",
           "takes_bridge"]

#: what a ``bridge`` argument may be: a built-in name, a bridge TOML path or a spec
BridgeArg = Union[str, os.PathLike, "BridgeSpec"]  # noqa: UP007 - a forward reference


def _is_system(value) -> bool:
    """An aeroelastic system (``A(U)`` and a basis): what :func:`bridgeflap.model.buffeting` also
    takes."""
    return callable(getattr(value, "A", None)) and hasattr(value, "basis")


def as_bridge(bridge, field: str = "bridge"):
    """``load_bridge(bridge)`` for a name or a path; a spec (an erection stage is one) or an
    aeroelastic system as it is; anything else is a
    :class:`~bridgeflap.model.errors.BridgeflapTypeError` naming ``field``.
    """
    from bridgeflap.model.structure.spec import BridgeSpec

    if isinstance(bridge, str | os.PathLike):
        from bridgeflap.model.structure.loader import load_bridge

        check_path(bridge, field)
        return load_bridge(bridge)
    if isinstance(bridge, BridgeSpec) or _is_system(bridge):
        return bridge
    raise BridgeflapTypeError(field, "must be a built-in bridge name, a bridge .toml path or a "
                                     f"BridgeSpec, got {describe(bridge)}")


def check_system(value, field: str = "system"):
    """``value`` if it is an aeroelastic system (``A(U)`` and a basis)."""
    if not _is_system(value):
        raise BridgeflapTypeError(field,
                                  "must be an aeroelastic system (bridgeflap.model.bridge_system), "
                                         f"got {describe(value)}")
    return value


def check_bridge_kind(bridge, field: str = "bridge"):
    """``bridge`` if it is a name or a path (read later, by the caller) or a spec."""
    from bridgeflap.model.structure.spec import BridgeSpec

    if isinstance(bridge, str | os.PathLike):
        return check_path(bridge, field)
    if isinstance(bridge, BridgeSpec):
        return bridge
    raise BridgeflapTypeError(field, "must be a built-in bridge name, a bridge .toml path or a "
                                     f"BridgeSpec, got {describe(bridge)}")


def as_rfa(value, field: str = "rfa"):
    """``value`` if it names a rational approximation (:data:`bridgeflap.model.aero.rfa.RFA_NAMES`)
    or is a :class:`~bridgeflap.model.aero.rfa.RationalApprox`."""
    from bridgeflap.model.aero.rfa import RFA_NAMES, RationalApprox

    if isinstance(value, RationalApprox):
        return value
    return check_choice(value, field, RFA_NAMES)


def _modal(value, field: str = "modal"):
    from bridgeflap.model.structure.modal_model import ImportedModalModel
    from bridgeflap.model.structure.modes import ModalModel

    if not isinstance(value, ModalModel | ImportedModalModel):
        raise BridgeflapTypeError(field, "must be a ModalModel (bridgeflap.model.modal_model), got "
                                         f"{describe(value)}")
    return value


#: the rules of a bridge function's other arguments beyond the vocabulary's (model.arguments)
BRIDGE_RULES = {
    "rfa": as_rfa,
    "order": one_of("modal", "full"),  # model.aeroelastic.assembly.ORDERS (a test holds them equal)
    "erection_gj_factor": number(0.0, 1.0, strict=True),
    "side_spans": optional(check_text),
    "modal": optional(_modal),
    "system": optional(check_system),
}


def takes_bridge(fn=None, **rules):
    """Decorate ``fn`` so that its first parameter accepts a name, a file or a spec.

    The other arguments pass :func:`bridgeflap.model.arguments.checked` (the vocabulary's rules and
    ``rules``): ``@takes_bridge`` or ``@takes_bridge(controller=as_controller)``.
    """
    if fn is None:
        return lambda f: takes_bridge(f, **rules)
    first = next(iter(inspect.signature(fn).parameters))
    wrapper = checked(**{first: as_bridge, **BRIDGE_RULES, **rules})(fn)
    wrapper.takes_bridge = True  # read by tests/test_vocabulary.py
    return wrapper
