"""What ``load_settings`` gives is what the docs say it gives.

``load_settings()`` is the packaged card that ``bridgeflap optimise`` runs without a card;
``load_settings(None)`` is the bare ``DesignSettings`` defaults (no flap layout, no scenario
bridges, no buffeting term). The docs once called ``None`` "the packaged card".
"""

from __future__ import annotations

import re
from pathlib import Path

from bridgeflap import design
from bridgeflap.design.control.settings import DEFAULT_CARD

DOCS = Path(__file__).resolve().parents[2] / "docs"


def test_no_argument_is_the_packaged_card_and_none_is_bare():
    card = design.load_settings()
    assert card == design.load_settings("default") == design.load_settings(DEFAULT_CARD)
    bare = design.load_settings(None)
    assert bare == design.DesignSettings()
    # what the docs name as the differences
    assert card.flap_positions_m and not bare.flap_positions_m
    assert card.variants > 0 and bare.variants == 0
    assert card.weight_buffeting > 0 and bare.weight_buffeting == 0
    # a keyword changes one key of the packaged card, nothing else
    assert design.load_settings(starts=2) == design.DesignSettings(
        **{**card.__dict__, "starts": 2})


def test_the_docs_do_not_call_none_the_packaged_card():
    pages = [DOCS / "tutorials" / "optimisation.md", DOCS / "reference" / "formats" / "card.md"]
    for page in pages:
        for line in page.read_text(encoding="utf-8").splitlines():
            if re.search(r"load_settings\(\s*None", line) or "(`None`)" in line:
                assert "packaged" not in line or "not the packaged" in line, (page.name, line)
    card = (DOCS / "reference" / "formats" / "card.md").read_text(encoding="utf-8")
    assert "load_settings()" in card and "bare" in card
