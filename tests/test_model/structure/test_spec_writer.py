"""BridgeSpec.to_toml / save_bridge (bridgeflap.model.structure.spec_writer): the loader's format,
round trip.

``load_bridge -> to_toml -> write -> load_bridge`` gives an equal spec with the same sources
and deck section, for every built-in bridge and variant. The IABSE section cases
(``iabse-1.1a``, ``iabse-1.1c``) are 2-DOF section cases
(:mod:`bridgeflap.model.cases.section_cases`), not bridges: they have no BridgeSpec to write.
"""

from __future__ import annotations

import pytest

from bridgeflap import model
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.structure.loader import load_bridge
from bridgeflap.model.structure.spec_writer import save_bridge, to_toml

BRIDGES = ["humber", "humber:box", "humber:flap_deck_flap", "great-belt",
           "great-belt:benchmark_mass_is_deck", "iabse-2a", "iabse-2a:bb3"]


@pytest.mark.parametrize("name", BRIDGES)
def test_round_trip_every_builtin(tmp_path, name):
    spec = load_bridge(name)
    path = save_bridge(spec, tmp_path / "bridge.toml")
    back = load_bridge(path)
    assert back == spec
    assert back.sources == spec.sources            # every source survives, none added
    assert back.deck_section == spec.deck_section  # the lumped items (compare=False on ==)
    assert back.name == spec.name
    # writing the reloaded spec gives the same text: the format is a fixed point
    assert to_toml(back) == spec.to_toml()


def test_modified_spec_round_trips_with_its_values(tmp_path):
    spec = load_bridge("humber")
    gj = spec.deck.gj_nm2 * 1.05
    mod = spec.replace(**{"deck.gj_nm2": gj, "deck.mass_kg_per_m": 11000.0})
    back = load_bridge(save_bridge(mod, tmp_path / "mod.toml"))
    assert back == mod and back != spec
    assert back.deck.gj_nm2 == gj                  # floats by repr: exact
    # the deck mass no longer is the items' sum: written as a value, and its source says so
    assert back.deck_section is None
    # every changed value is marked user-set, with the source it had (written and read back)
    for path in ("deck.gj_nm2", "deck.mass_kg_per_m"):
        assert back.sources[path] == f"user-set value (was: {spec.sources[path]})"
    # the inertia did not follow the mass: still the items' sum, which the file no longer holds
    assert back.deck.mass_inertia_kgm2_per_m == spec.deck.mass_inertia_kgm2_per_m
    assert back.sources["deck.mass_inertia_kgm2_per_m"].startswith(
        spec.sources["deck.mass_inertia_kgm2_per_m"])
    assert "which are not written" in back.sources["deck.mass_inertia_kgm2_per_m"]
    # an unchanged value keeps its source
    assert back.sources["cable.main_sag_m"] == spec.sources["cable.main_sag_m"]


def test_a_value_set_through_replace_is_marked_user_set_once():
    spec = load_bridge("humber")
    old = spec.sources["aero.turbulence_intensity"]
    once = spec.replace(**{"aero.turbulence_intensity": 0.08})
    twice = once.replace(**{"aero.turbulence_intensity": 0.09})
    assert once.sources["aero.turbulence_intensity"] == f"user-set value (was: {old})"
    assert twice.sources["aero.turbulence_intensity"] == once.sources["aero.turbulence_intensity"]
    assert spec.sources["aero.turbulence_intensity"] == old  # the original is not touched
    same = spec.replace(**{"aero.turbulence_intensity": spec.aero.turbulence_intensity})
    assert same.sources["aero.turbulence_intensity"] == old  # not changed: not user-set


def test_public_face_and_refusals(tmp_path):
    assert model.save_bridge is save_bridge
    with pytest.raises(BridgeflapInputError, match="erection stage") as e:
        to_toml(load_bridge("humber").erected(0.5))
    assert e.value.field == "erected_fraction"
    with pytest.raises(BridgeflapInputError) as e:
        save_bridge(load_bridge("humber"), tmp_path / "bridge.txt")
    assert e.value.field == "path"
    with pytest.raises(BridgeflapInputError) as e:
        to_toml("humber")
    assert e.value.field == "bridge"


def test_load_bridge_takes_a_spec_and_refuses_other_types():
    spec = load_bridge("humber")
    assert load_bridge(spec) is spec
    for bad in (None, 3, ""):
        with pytest.raises(BridgeflapInputError) as e:
            load_bridge(bad)
        assert e.value.field == "bridge" and "\n" not in str(e.value)
