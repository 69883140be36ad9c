"""One vocabulary of the scripting API: docs/api_vocabulary.md is the contract.

The table's canonical names and their old names are read from the doc; every public function
of ``model.__all__`` and ``design.__all__`` is checked with :func:`inspect.signature`, and each
old name is refused in one line naming the new one. No physics runs here (signatures, parsing
and errors only), so there are no numerical tolerances: the comparisons are exact.
"""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import numpy as np
import pytest

from bridgeflap import design, model
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.vocabulary import DEFAULT_MODES, RENAMED, RenamedArgumentError

DOC = Path(__file__).resolve().parents[2] / "docs" / "api_vocabulary.md"


def _table() -> dict[str, list[str]]:
    """``{canonical name: [old names]}`` from the doc's vocabulary table."""
    text = DOC.read_text(encoding="utf-8")
    block = text.split("<!-- vocabulary-table")[1].split("\n\n")[0]
    rows = {}
    for line in block.splitlines()[3:]:  # the marker, the header and its rule
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        name = cells[0].strip("`")
        rows[name] = re.findall(r"`([^`]+)`", cells[4])
    return rows


def _public_functions():
    for pkg in (model, design):
        for name in pkg.__all__:
            obj = getattr(pkg, name)
            if inspect.isfunction(obj):
                yield f"{pkg.__name__}.{name}", obj


def test_the_doc_table_and_the_code_agree():
    rows = _table()
    assert {"bridge", "speeds", "speed", "n_modes", "modes_per_family", "kind",
            "out_dir"} <= set(rows)
    # every keyword rename of the code is a row's old name, and the other way round
    # (the sampler's old spellings are values, not keywords)
    doc_old = {old: new for new, olds in rows.items() for old in olds if new != "kind"}
    assert doc_old == RENAMED
    assert f"`bridgeflap.model.DEFAULT_MODES` = {DEFAULT_MODES}" in DOC.read_text(encoding="utf-8")


def test_every_public_function_uses_the_canonical_names():
    old = set(RENAMED)
    checked = 0
    for qual, fn in _public_functions():
        params = inspect.signature(fn).parameters
        names = list(params)
        # buffeting's keyword-only ``spec`` is the BridgeSpec of a built system; do_no_harm's
        # ``count`` counts bridge variants, not modes (both documented in the doc's decisions)
        bad = [n for n in names if n in old
               and not (qual == "bridgeflap.model.buffeting" and n == "spec"
                        and params[n].kind is inspect.Parameter.KEYWORD_ONLY)
               and not (qual == "bridgeflap.design.do_no_harm" and n == "count")]
        assert not bad, f"{qual} takes {bad}: the vocabulary's names are {RENAMED}"
        if getattr(fn, "takes_bridge", False):
            assert names[0] == "bridge", f"{qual}: first parameter {names[0]!r}, not 'bridge'"
        if "n_modes" in params and params["n_modes"].default is not inspect.Parameter.empty:
            assert params["n_modes"].default == DEFAULT_MODES, qual
        assert not {"U", "wind_speeds", "speed_grid"} & set(names), qual
        checked += 1
    assert checked >= 30  # the survey counted 36 public functions


@pytest.mark.parametrize("call, old, new", [
    (lambda: model.modal_model("humber", count=6), "count", "modes_per_family"),
    (lambda: model.plant_data("humber", wind_speed=10.0), "wind_speed", "speed"),
    (lambda: model.flutter(spec="humber", speeds=[0.0, 1.0]), "spec", "bridge"),
    (lambda: model.buffeting(spec_or_system="humber", speeds=[10.0]), "spec_or_system",
     "bridge"),
    (lambda: design.local_sensitivity(spec="humber"), "spec", "bridge"),
    (lambda: design.run_study(None, out="x"), "out", "out_dir"),
    (lambda: design.design(design.load_settings(None), spec="humber"), "spec", "bridge"),
    (lambda: model.save_bridge(spec="humber", path="x.toml"), "spec", "bridge"),
    (lambda: design.run_doe("x.toml", out="x"), "out", "out_dir"),
])
def test_an_old_keyword_raises_naming_the_new(call, old, new):
    with pytest.raises(RenamedArgumentError) as e:
        call()
    assert isinstance(e.value, TypeError) and isinstance(e.value, BridgeflapInputError)
    assert e.value.field == old and f"{new}=" in str(e.value)
    assert "\n" not in str(e.value)


def test_one_speed_grammar():
    from bridgeflap.model.grid import speed_grid
    from bridgeflap.model.stability.sweeps import check_speeds

    want = 0.5 * np.arange(171)  # 0:85:0.5, 85 included
    for form in ("0:85:0.5", list(want), tuple(want), want):
        np.testing.assert_array_equal(check_speeds(form), want)
    np.testing.assert_array_equal(speed_grid("20,40,60"), [20.0, 40.0, 60.0])
    np.testing.assert_array_equal(design.parse_range("0:85:0.5", "speeds"), want)
    for bad in ("fast", "0:85", "10:0:1", [1.0, float("nan")], [-1.0, 2.0]):
        with pytest.raises(BridgeflapInputError) as e:
            check_speeds(bad)
        assert e.value.field == "speeds"
    # flutter reads text like local_sensitivity and the CLI (refused before any physics)
    with pytest.raises(BridgeflapInputError) as e:
        model.flutter("humber", "0:85:-1")
    assert e.value.field == "speeds"


def test_sampler_spelling():
    from bridgeflap.design.batch.designs import DESIGN_KINDS

    assert set(DESIGN_KINDS) == {"full_factorial", "latin_hypercube", "sobol"}
    with pytest.raises(BridgeflapInputError) as e:
        design.make_design("latin-hypercube", ranges={"a": (0.0, 1.0)}, n=4, seed=1)
    assert e.value.field == "kind" and "'latin_hypercube'" in str(e.value)
    base = {"name": "k", "bridge": "humber", "analysis": "flutter",
            "parameters": {"deck.gj_nm2": [4.7e11, 7.1e11]}}
    # a DOE file is a published format: its former spellings read as the canonical ones
    for kind, canonical in (("latin_hypercube", "latin_hypercube"),
                            ("latin-hypercube", "latin_hypercube"),
                            ("full-factorial", "full_factorial"),
                            ("full_factorial", "full_factorial")):
        cfg = design.doe_from_dict({**base, "design": {"kind": kind, "n": 4, "levels": 2}})
        assert cfg.kind == canonical


def test_public_functions_are_not_shadowed_by_submodules():
    import importlib

    # the submodule of the same name, imported
    import bridgeflap.model.response.buffeting  # noqa: F401
    import bridgeflap.model.structure.modal_model  # noqa: F401

    assert inspect.isfunction(model.buffeting) and model.buffeting.__name__ == "buffeting"
    assert inspect.isfunction(model.modal_model)
    assert inspect.ismodule(importlib.import_module("bridgeflap.model.response.buffeting"))
    # the submodule's names still import
    from bridgeflap.model.response.buffeting import BuffetingResult

    assert BuffetingResult.__name__ == "BuffetingResult"


def test_load_settings_is_the_default_card():
    from bridgeflap.design.control.settings import DEFAULT_CARD, DesignSettings

    assert design.load_settings() == design.load_settings(DEFAULT_CARD)
    assert design.load_settings(None) == DesignSettings()
    assert design.load_settings(starts=1).starts == 1


def test_results_table_is_a_method_and_the_path_has_its_own_name():
    import dataclasses

    from bridgeflap.design.studies.experiments import DoeResult

    fields = {f.name for f in dataclasses.fields(DoeResult)}
    assert "table_path" in fields and "table" not in fields
    assert callable(DoeResult.table) and callable(model.FlutterResult.table)
