"""Scenario design (bridgeflap.design.control.solve.scenarios): the scenario bridges and the
do-no-harm range of each, read from its own open loop."""

from __future__ import annotations

import numpy as np
import pytest

from bridgeflap.design.control.formulation.problem_model import build_model
from bridgeflap.design.control.settings import load_settings
from bridgeflap.design.control.solve.scenarios import (
    NO_HARM_GRID_FACTOR,
    NO_HARM_SPEED_MARGIN,
    corner_specs,
    open_loop_limit,
    scenario_settings,
    scenario_specs,
)
from bridgeflap.design.control.uncertainty import DEFAULT_UNCERTAIN_RANGES
from bridgeflap.model.analysis import flutter
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.structure.loader import load_bridge


@pytest.fixture(scope="module")
def card():
    # 8 modes and 5 flap pairs: the scenario path at a test's cost
    return load_settings("default", n_modes=8, flap_count=5, flap_positions_m=(), variants=2)


def test_corners_and_draws(card):
    base = load_bridge(card.bridge)
    corners = corner_specs(card, base)
    assert len(corners) == 4
    gj = DEFAULT_UNCERTAIN_RANGES["deck.gj_nm2"]
    inertia = DEFAULT_UNCERTAIN_RANGES["deck.mass_inertia_kgm2_per_m"]
    got = [(c.deck.gj_nm2, c.deck.mass_inertia_kgm2_per_m) for c in corners]
    assert got == [(g, i) for g in gj for i in inertia]            # a fixed order
    # the other inputs stay nominal at a corner
    assert all(c.deck.ei_vertical_nm2 == base.deck.ei_vertical_nm2 for c in corners)
    specs = scenario_specs(card, base)
    assert len(specs) == 4 + card.variants
    # the same card gives the same scenarios (a fixed seed)
    again = scenario_specs(card, base)
    assert [s.deck.gj_nm2 for s in specs] == [s.deck.gj_nm2 for s in again]


def test_open_loop_limit_is_the_open_loop_critical_speed(card):
    # cross-method: the K = 0 loop's last stable speed on the 0.25 m/s check grid against the
    # open-loop flutter/divergence of model.analysis on the same modes (a verified crossing);
    # they agree to the grid step (the refined check keeps the dense grid's decisions)
    spec = load_bridge(card.bridge)
    _, model = build_model(card, spec=spec)
    u = open_loop_limit(card, spec, model)
    s = flutter(spec, np.arange(0.0, 127.5, 0.5), n_modes=card.n_modes,
                sweep_method="fast").summary()
    assert u == pytest.approx(s["critical_speed_m_s"], abs=card.check_step_m_s + 1e-9)
    sv = scenario_settings(card, spec, model)
    assert sv.speed_max_m_s == pytest.approx(min(u * (1 + NO_HARM_SPEED_MARGIN),
                                                 NO_HARM_GRID_FACTOR * card.speed_max_m_s))
    # the "stable" rule keeps the card's own range
    assert scenario_settings(card.__class__(**{**card.__dict__, "variant_rule": "stable"}),
                             spec, model).speed_max_m_s == card.speed_max_m_s


def test_scenario_settings_are_checked():
    with pytest.raises(BridgeflapInputError, match="variant_rule"):
        load_settings(None, variant_rule="nice")
    with pytest.raises(BridgeflapInputError, match="variant_corners"):
        load_settings(None, variant_corners=["deck.half_chord_m"])   # held fixed
    with pytest.raises(BridgeflapInputError, match="compensator_damping_min"):
        load_settings(None, compensator_damping_min=1.0)
    with pytest.raises(BridgeflapInputError, match="layout_dead_band"):
        load_settings(None, layout_dead_band=0.5)
