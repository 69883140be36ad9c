"""bridgeflap: aeroelastic design of long-span suspension bridges with active deck flaps.

One import name, two subpackages:

* :mod:`bridgeflap.model` -- the physics (bridges, flutter, buffeting, flaps, the plant);
* :mod:`bridgeflap.design` -- optimisation, sensitivity, batches, studies and the CLI.

Their public names (``__all__``) are also here, resolved on first use (PEP 562), so
``import bridgeflap`` stays light (no CasADi, matplotlib or Dask)::

    from bridgeflap import design, model
    m = model.modal_model("humber")

    import bridgeflap as bf
    res = bf.flutter("humber", speeds="0:80:10")

``bridgeflap.design`` is always the subpackage; the function of that name is
:func:`bridgeflap.design.design`.
"""

from __future__ import annotations

import sys as _sys
from pathlib import Path as _Path

_HERE = _Path(__file__).resolve().parent
if not (_HERE / "model").is_dir() and all(
        (_HERE.parent / p / "__init__.py").is_file() for p in ("model", "design")):
    # a source checkout (nothing installed, or an editable install): the subpackages' sources
    # are the folders model/ and design/ next to this one (pyproject.toml, package-dir)
    __path__.append(str(_HERE.parent))  # noqa: F821 - a package's own __path__

from bridgeflap import design, model  # noqa: E402, F401 - light: lazy faces only

_SUBPACKAGES = ("model", "design")
#: public name -> the subpackage that defines it (the first one when both do)
_PUBLIC: dict[str, str] = {}
for _sub in _SUBPACKAGES:
    for _name in _sys.modules[f"{__name__}.{_sub}"].__all__:
        if _name not in _SUBPACKAGES:
            _PUBLIC.setdefault(_name, _sub)

__all__ = ["__version__", *_SUBPACKAGES, *sorted(_PUBLIC, key=str.lower)]


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("bridgeflap")
    except PackageNotFoundError:  # a source checkout that is not installed
        return "0+unknown"


def __getattr__(name: str):
    if name == "__version__":
        value = globals()["__version__"] = _version()
        return value
    if name in _PUBLIC:
        return getattr(_sys.modules[f"{__name__}.{_PUBLIC[name]}"], name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *__all__})
