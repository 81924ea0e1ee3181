"""Realism profiles (sim/realism.py, issue 33): `realism: ideal | typical | harsh` lays a robot's senses under
the scenario's own keys, which win; `ideal` is exactly the world every earlier figure was measured in."""

from __future__ import annotations

from pathlib import Path

import pytest

from mission.core.config import merge_mappings
from mission.sim.realism import PROFILES, effective
from mission.sim.scenario import load_scenario, scenario_from_dict
from mission.sim.scenario_overrides import apply_overrides
from mission.sim.sim_adapter import SimAdapter

SCENARIOS = sorted(p.stem for p in (Path(__file__).resolve().parents[2] / "sim" / "scenarios").glob("*.yaml"))


def test_ideal_is_the_scenario_itself():
    sc = load_scenario("explore_dock")
    assert sc.realism == "ideal" and effective(sc) is sc


@pytest.mark.parametrize("name", ["typical", "harsh"])
def test_every_profile_is_a_valid_set_of_scenario_keys(name):
    sc = load_scenario("explore_dock")
    merged = scenario_from_dict(merge_mappings(sc.model_dump(mode="python"), PROFILES[name]))
    for section, keys in PROFILES[name].items():
        for key, value in keys.items():
            assert getattr(getattr(merged, section), key) == value


def test_a_config_chooses_a_profile_and_its_own_keys_win():
    sc = apply_overrides(load_scenario("follow_open"), {"realism": "harsh", "camera": {"jpeg_quality": 0}})
    real = effective(sc)
    assert real.camera.jpeg_quality == 0  # set by the config: wins over the profile's 60
    assert real.camera.distortion == PROFILES["harsh"]["camera"]["distortion"]
    assert real.localization.odom_scale_error_pct == 3.0
    assert real.camera.width == 640  # not in the profile: the scenario's


@pytest.mark.parametrize("name", SCENARIOS)
def test_every_shipped_scenario_round_trips_through_what_it_set(name):
    """Overrides merge over what a scenario set (so a profile can fill the rest): the same scenario either way."""
    sc = load_scenario(name)
    assert scenario_from_dict(sc.model_dump(mode="python", exclude_unset=True)) == sc


def test_the_simulation_runs_the_typical_robot():
    sim = SimAdapter(apply_overrides(load_scenario("explore_dock"), {"realism": "typical"}), seed=0)
    sim.setup()
    try:
        assert sim.camera_model is not None and sim.localization is not None
        frame = sim.capture()
        assert frame.intrinsics.distortion != ()  # the lens, as the detector is told it
    finally:
        sim.close()
