"""The API reference is something to script against: every public name documents its inputs
and outputs (numpydoc sections), and the examples in them run.

Public names are the ``__all__`` of :mod:`bridgeflap.model` and :mod:`bridgeflap.design`.
A function needs a ``Returns`` section, and a ``Parameters`` section when it takes arguments;
a class needs ``Parameters`` or ``Attributes``. So does every public method (inherited ones
included: the reference gives each its page) of the public classes and of the classes the
public functions return (results, readers, configurations, models). The ``Examples`` of the
public functions users call first are run as doctests (tiny inputs; each is bounded by the time
limit below).
"""

from __future__ import annotations

import doctest
import importlib
import inspect
import time
import typing

import pytest
from numpydoc.docscrape import ClassDoc, FunctionDoc

PACKAGES = ("bridgeflap.model", "bridgeflap.design")


def _public():
    out = []
    for pkg in PACKAGES:
        module = importlib.import_module(pkg)
        for name in sorted(module.__all__):
            obj = getattr(module, name)
            if inspect.isclass(obj) or callable(obj):
                out.append((f"{pkg}.{name}", obj))
    return out


PUBLIC = _public()


def _takes_arguments(obj) -> bool:
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):  # a builtin without a signature: assume it does
        return True
    return any(p.name not in ("self", "cls") for p in sig.parameters.values())


@pytest.mark.parametrize("qualname, obj", PUBLIC, ids=[q for q, _ in PUBLIC])
def test_public_name_has_numpydoc_sections(qualname, obj):
    doc = inspect.getdoc(obj) or ""
    assert doc.strip(), f"{qualname}: no docstring"
    if inspect.isclass(obj):
        parsed = ClassDoc(obj, doc=doc, config={"show_class_members": False})
        assert parsed["Parameters"] or parsed["Attributes"], (
            f"{qualname}: a class needs a Parameters or an Attributes section")
        return
    parsed = FunctionDoc(obj, doc=doc)
    assert parsed["Returns"] or parsed["Yields"], f"{qualname}: no Returns section"
    if _takes_arguments(obj):
        assert parsed["Parameters"], f"{qualname}: takes arguments, has no Parameters section"


def _classes():
    """The public classes and the classes the public functions return, by name."""
    out = {}
    for pkg in PACKAGES:
        module = importlib.import_module(pkg)
        for name in module.__all__:
            obj = getattr(module, name)
            if not inspect.isclass(obj):
                obj = typing.get_type_hints(obj).get("return") if callable(obj) else None
            if (inspect.isclass(obj) and obj.__module__.startswith("bridgeflap.")
                    and not issubclass(obj, BaseException)):  # errors: no methods of their own
                out.setdefault(obj.__qualname__, obj)
    return out


def _methods():
    """``(qualified name, function)`` of every public method of :func:`_classes`, each
    definition once (a method a class inherits is checked where it is defined)."""
    seen = {}
    for cls in _classes().values():
        for attr in dir(cls):
            if attr.startswith("_"):
                continue
            raw = next((base.__dict__[attr] for base in cls.__mro__ if attr in base.__dict__),
                       None)
            fn = raw.__func__ if isinstance(raw, staticmethod | classmethod) else raw
            if inspect.isfunction(fn):  # properties and data are attributes, not methods
                seen.setdefault(f"{fn.__module__}.{fn.__qualname__}", fn)
    return sorted(seen.items())


METHODS = _methods()


def _method_problems(fn) -> list[str]:
    parsed = FunctionDoc(fn, doc=inspect.getdoc(fn) or "")
    problems = []
    if not (parsed["Returns"] or parsed["Yields"]):
        problems.append("no Returns section")
    if _takes_arguments(fn) and not parsed["Parameters"]:
        problems.append("takes arguments, has no Parameters section")
    return problems


def test_the_methods_are_found():
    """The classes of the results users read are among them (the list is not silently short:
    120 method definitions when written)."""
    names = {q.rsplit(".", 2)[-2] for q, _ in METHODS}
    assert {"DesignResult", "RunRecord", "FlutterResult", "BuffetingResult", "ErectionResult",
            "DoeResult", "HarmResult", "ResultData", "BridgeSpec"} <= names, names
    assert len(METHODS) >= 100


@pytest.mark.parametrize("qualname, fn", METHODS, ids=[q for q, _ in METHODS])
def test_public_method_has_numpydoc_sections(qualname, fn):
    problems = _method_problems(fn)
    assert not problems, f"{qualname}: {', '.join(problems)}"


def test_the_method_check_can_fail():
    """A method with an argument and only a summary line fails the check above."""
    class Bare:
        def plot(self, ax=None):
            """Draw it."""

    assert _method_problems(Bare.plot) == ["no Returns section",
                                           "takes arguments, has no Parameters section"]


def test_the_check_can_fail():
    """A function with arguments and only a summary line fails the check above."""
    def bare(x):
        """Just a sentence."""

    parsed = FunctionDoc(bare, doc=inspect.getdoc(bare))
    assert not parsed["Parameters"] and not parsed["Returns"] and _takes_arguments(bare)


#: The functions whose Examples run here: what a user calls first. Each example uses tiny
#: inputs (a few modes, a coarse grid); the limit leaves a loaded 2-core machine room.
EXAMPLE_LIMIT_S = 60.0
WITH_EXAMPLES = ("bridgeflap.model.load_bridge", "bridgeflap.model.flutter",
                 "bridgeflap.model.erection", "bridgeflap.model.modal_model",
                 "bridgeflap.model.buffeting", "bridgeflap.model.save_bridge",
                 "bridgeflap.design.load_settings", "bridgeflap.design.quick_settings",
                 "bridgeflap.design.parse_range", "bridgeflap.design.local_sensitivity",
                 "bridgeflap.design.make_design", "bridgeflap.design.open_run",
                 "bridgeflap.model.bridge_system", "bridgeflap.model.frequency_ratio",
                 "bridgeflap.model.closed_loop_flutter", "bridgeflap.model.BridgeSpec",
                 "bridgeflap.design.DesignSettings", "bridgeflap.design.doe_from_dict",
                 "bridgeflap.design.run_doe")


@pytest.mark.parametrize("qualname", WITH_EXAMPLES)
def test_examples_run(qualname):
    pkg, _, name = qualname.rpartition(".")
    obj = getattr(importlib.import_module(pkg), name)
    parser = doctest.DocTestParser()
    test = parser.get_doctest(inspect.getdoc(obj) or "", {}, qualname, None, 0)
    assert test.examples, f"{qualname}: no Examples"
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    t0 = time.perf_counter()
    result = runner.run(test, out=lambda s: print(s, end=""))
    elapsed = time.perf_counter() - t0
    assert result.failed == 0, f"{qualname}: {result.failed} example(s) failed (output above)"
    assert elapsed < EXAMPLE_LIMIT_S, f"{qualname}: examples took {elapsed:.0f} s"
