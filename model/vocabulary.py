"""The one vocabulary of the scripting API (docs/api_vocabulary.md).

The public functions of :mod:`bridgeflap.model` and :mod:`bridgeflap.design` name the same thing the
same way: ``bridge`` (a name, a TOML path or a
:class:`~bridgeflap.model.structure.spec.BridgeSpec`), ``speeds`` (a grid [m/s], read by
:func:`bridgeflap.model.grid.speed_grid`), ``speed`` (one speed [m/s]), ``n_modes`` (vertical +
torsional modes retained, default :data:`DEFAULT_MODES`), ``modes_per_family``, ``out_dir``.
:data:`RENAMED` lists the names they replaced; :func:`renamed` refuses one in one line naming the
new name.
"""

from __future__ import annotations

import functools
import inspect

from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["DEFAULT_MODES", "RENAMED", "RenamedArgumentError", "check_renamed", "renamed"]

#: retained vertical + torsional modes of every analysis unless told otherwise
#: (vertical and torsional together). Criterion (model.stability.convergence.mode_convergence): the
# count at
#: which flutter and divergence speeds, and those of every larger count, are within 0.05 % of
#: 40 modes. Measured by runs/mode_convergence on humber, humber:box and the 64 corners of the
#: estimated-input ranges: 30 modes converge in all 66 cases (largest flutter error 0.0013 %);
#: 16 modes converge in 43 (largest 0.70 %), 24 in 65 (0.062 %). Cost: 180 instead of 96 states.
DEFAULT_MODES = 30

#: former keyword names of the public API -> the name that replaced them
RENAMED = {
    "spec": "bridge",
    "spec_or_system": "bridge",
    "count": "modes_per_family",
    "wind_speed": "speed",
    "out": "out_dir",
}


class RenamedArgumentError(BridgeflapInputError, TypeError):
    """A keyword argument given by a name the API no longer uses (the message names the new one).

    A :class:`~bridgeflap.model.errors.BridgeflapInputError` (one line, ``field`` the old name) and
    a
    :class:`TypeError` (what Python raises for any other unexpected keyword).
    """


def check_renamed(name: str, parameters, kwargs) -> None:
    """Raise :class:`RenamedArgumentError` for a keyword of ``kwargs`` that is a former name.

    ``parameters``: the names the function takes now; a former name that is still one of them
    (``buffeting``'s keyword ``spec``) is accepted.
    """
    for old in kwargs:
        new = RENAMED.get(old)
        if new is not None and old not in parameters and new in parameters:
            raise RenamedArgumentError(old, f"{name}() takes {new}= now (renamed from {old}=; "
                                            "docs/api_vocabulary.md)")


def renamed(fn):
    """Decorate ``fn`` so that a former keyword name (:data:`RENAMED`) raises naming the new."""
    parameters = frozenset(inspect.signature(fn).parameters)

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        check_renamed(fn.__name__, parameters, kwargs)
        return fn(*args, **kwargs)

    return wrapper
