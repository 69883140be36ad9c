"""One design: `bridgeflap study` and `bridgeflap optimise` design the same
controller because the study's design step runs the packaged card `optimise` runs."""

from __future__ import annotations

import pytest

from bridgeflap.design.control.settings import (
    DEFAULT_CARD,
    load_settings,
    packaged_card,
    quick_settings,
)
from bridgeflap.design.studies.analyses import ANALYSES, design_settings
from bridgeflap.design.studies.study import load_study
from bridgeflap.model.errors import BridgeflapInputError


def _study_design_options(quick=False):
    study = load_study(None, quick=quick) if quick else load_study(None)
    return study, dict(dict(study.analyses)["design"])


def test_default_study_designs_with_the_optimise_card():
    import bridgeflap.design.cli.optimise as cmd

    study, opts = _study_design_options()
    assert cmd.DEFAULT_DEFINITION == DEFAULT_CARD
    s_study = design_settings(ANALYSES["design"].resolve(opts), study.bridge)
    s_opt = load_settings(DEFAULT_CARD)
    # the same frozen settings -> the same deterministic design (Sobol starts, seed)
    assert s_study == s_opt
    assert quick_settings(s_study) == quick_settings(s_opt)


def test_card_overrides_and_errors():
    s = design_settings({"card": "humber_flaps", "starts": 1}, "humber")
    assert s.starts == 1 and s.bridge == load_settings(DEFAULT_CARD).bridge
    # no card: the study's bridge and the settings' defaults (the old behaviour)
    assert design_settings({}, "humber:box").bridge == "humber:box"
    assert packaged_card("default") == DEFAULT_CARD
    with pytest.raises(BridgeflapInputError, match="card"):
        packaged_card("no_such_card")
    with pytest.raises(BridgeflapInputError, match="unknown design setting.*did you mean starts"):
        design_settings({"card": "default", "stars": 1}, "humber")
