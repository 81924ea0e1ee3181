"""The robustness benchmark's plan and verdicts (bench/robustness.py, issue 33): every factor level is a set of
scenario keys a sweep accepts, level 1 is the typical profile's value and level 3 the harsh one's where a
profile has the factor, and the factor named as breaking a mission first is the one that breaks at the lowest
level."""

from __future__ import annotations

import pytest

from bench.robustness import FACTORS, PROFILES, _breaking_level, _jobs, first_to_break
from mission.app.overrides import parse_value
from mission.sim.realism import PROFILES as REALISM


def test_every_level_of_every_factor_is_a_run_a_sweep_accepts(tmp_path):
    jobs = _jobs(("explore_dock",), 1, FACTORS, 1, tmp_path, max_duration=1.0)
    assert {j.part for j in jobs} == {"profiles", *(f.name for f in FACTORS)}
    for job in jobs:
        job.plan.check()  # each scenario × cell prepared as its runs will be: keys, values, ranges


@pytest.mark.parametrize(
    ("factor", "key", "section"),
    [
        ("blur", "exposure_s", "camera"),
        ("latency", "latency_s", "camera"),
        ("drift", "odom_scale_error_pct", "localization"),
        ("calibration", "calibration_focal_pct", "camera"),
        ("depth_noise", "depth_noise_pct_at_2m", "camera"),
    ],
)
def test_level_1_is_the_typical_profile_and_level_3_the_harsh_one(factor, key, section):
    f = next(f for f in FACTORS if f.name == factor)

    def value(level: int) -> float:
        sets = dict(s.split("=", 1) for s in f.levels[level - 1][1])
        return float(parse_value(sets[f"{section}.{key}"], key))

    assert value(1) == pytest.approx(REALISM["typical"][section][key])
    assert value(3) == pytest.approx(REALISM["harsh"][section][key])
    assert value(1) < value(2) < value(3)


def cell(rate: float) -> dict:
    return {"success_rate": rate}


def test_the_factor_that_breaks_a_mission_first_is_the_one_at_the_lowest_level():
    blur = next(f for f in FACTORS if f.name == "blur")
    levels = {label: {s: cell(1.0) for s in blur.scenarios} for label, _ in blur.levels}
    assert _breaking_level(blur, levels) == (None, None, None)
    levels[blur.levels[1][0]][blur.scenarios[0]] = cell(0.6)
    assert _breaking_level(blur, levels) == (2, blur.scenarios[0], 0.6)
    factors = {
        "blur": {"breaks_at_level": 2, "breaks_scenario": "search_corner", "breaks_success": 0.6},
        "light": {"breaks_at_level": 3, "breaks_scenario": "follow_open", "breaks_success": 0.0},
        "latency": {"breaks_at_level": 2, "breaks_scenario": "follow_occlusion", "breaks_success": 0.4},
        "drift": {"breaks_at_level": None, "breaks_scenario": None, "breaks_success": None},
    }
    assert first_to_break(factors) == {
        "factor": "latency",
        "level": 2,
        "scenario": "follow_occlusion",
        "success_rate": 0.4,
    }
    assert first_to_break({"drift": factors["drift"]}) is None


def test_the_profiles_are_the_three_the_scenario_key_accepts():
    assert set(PROFILES) == set(REALISM)
