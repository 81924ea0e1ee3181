"""Real closed-loop missions in the simulation meet the design notes' criteria, as a user reads them in
report.json: occlusion detected within 0.5 s (ground-truth line of sight blocked → LOST), target
re-acquired within 10 s (LOST/SEARCH → FOLLOW), docking within 3 cm lateral / 2.5 cm distance / 10° skew
at the 0.30 m stand-off, no collisions, mission success.

Each run is the `mission run` code path (`mission.app.sim_run.run_scenario`): pybullet renders, the real
ArUco source, the shipped trees ticked by py_trees. One seed per scenario runs by default (cut to the
stretch that holds the hard part where a full run adds nothing); every other seed of 0..9 runs with
``-m slow``.
"""

from __future__ import annotations

from typing import Any

import pytest

from mission.app.sim_run import RunOutcome, run_scenario

OCCLUSION_LATENCY_S = 0.5
REACQUISITION_S = 10.0
LATERAL_TOL_M, DISTANCE_TOL_M, SKEW_TOL_DEG = 0.03, 0.025, 10.0

SEEDS = range(10)
FAST = {  # scenario → (seed, simulated seconds) run by default
    "search_corner": (2, 40.0),  # the corner: lost round the partition's end, found down the far corridor
    "follow_occlusion": (0, 40.0),  # through the pillars and round their west end
    "explore_dock": (0, None),  # ends when docked
}


def run(scenario: str, seed: int, max_duration: float | None = None) -> RunOutcome:
    outcome, _, _ = run_scenario(scenario, seed=seed, max_duration=max_duration)
    return outcome


def loss_starts(metrics: dict[str, Any]) -> list[float]:
    """When each loss event began (entering LOST or SEARCH from FOLLOW or another state)."""
    starts, prev = [], ""
    for tr in metrics["state_transitions"]:
        if tr["state"] in ("LOST", "SEARCH") and prev not in ("LOST", "SEARCH"):
            starts.append(tr["t"])
        prev = tr["state"]
    return starts


def assert_follow_criteria(o: RunOutcome) -> None:
    m = o.metrics
    assert o.success, f"{o.scenario} seed {o.seed}: {o.reason}"
    assert m["collisions"] == 0
    # every occlusion of 0.5 s or more was called LOST, each within 0.5 s of the line of sight breaking
    assert m["occlusions_missed"] == 0, m["state_transitions"]
    if m["occlusions_detected"]:
        assert m["occlusion_detection_latency_s"]["max"] <= OCCLUSION_LATENCY_S
    # every loss was recovered within 10 s, except one that began less than 10 s before the run ended
    if m["reacquisition_time_s"] is not None:
        assert m["reacquisition_time_s"]["max"] <= REACQUISITION_S, m["state_transitions"]
    open_losses = m["loss_events"] - m["loss_events_recovered"]
    late = [t for t in loss_starts(m) if o.sim_time_s - t < REACQUISITION_S]
    assert open_losses <= min(len(late), 1), m["state_transitions"]


def assert_dock_criteria(o: RunOutcome) -> None:
    dock = o.metrics["dock"]
    assert o.success, f"{o.scenario} seed {o.seed}: {o.reason}"
    assert o.metrics["collisions"] == 0
    assert dock is not None
    assert dock["lateral_m"] <= LATERAL_TOL_M
    assert dock["distance_m"] <= DISTANCE_TOL_M
    assert dock["skew_deg"] <= SKEW_TOL_DEG


# -- the default (CI) set: one seed each ---------------------------------------------------------------


@pytest.mark.slow  # CI keeps the ladder's closed loops in hide_and_wait and the Nav2 follow goal (CI time)
def test_search_corner_the_robot_goes_round_the_corner_and_finds_the_target_again():
    seed, duration = FAST["search_corner"]
    o = run("search_corner", seed, duration)
    assert_follow_criteria(o)
    states = [t["state"] for t in o.metrics["state_transitions"]]
    assert "LOST" in states  # the hard part happened (LOST that looks round the corner may find it itself) …
    assert states[-1] == "FOLLOW" and o.metrics["loss_events_recovered"] >= 1  # … and was recovered


def test_follow_occlusion_the_robot_keeps_the_target_through_the_pillars():
    seed, duration = FAST["follow_occlusion"]
    o = run("follow_occlusion", seed, duration)
    assert_follow_criteria(o)
    assert o.metrics["occlusions_detected"] >= 1  # the pillars did hide it, and the tree called LOST in time
    assert o.metrics["loss_events"] >= 1 and o.metrics["loss_events_recovered"] >= 1


def test_explore_dock_finds_the_tag_and_docks_within_tolerance():
    seed, duration = FAST["explore_dock"]
    o = run("explore_dock", seed, duration)
    assert_dock_criteria(o)
    assert o.final_state == "DONE"


# -- every other seed (slow) ---------------------------------------------------------------------------


def _other_seeds(scenario: str) -> list[int]:
    return [s for s in SEEDS if scenario not in FAST or s != FAST[scenario][0]]


@pytest.mark.slow
@pytest.mark.parametrize("seed", _other_seeds("search_corner"))
def test_search_corner_every_seed(seed: int) -> None:
    assert_follow_criteria(run("search_corner", seed))


@pytest.mark.slow
@pytest.mark.parametrize("seed", _other_seeds("follow_occlusion"))
def test_follow_occlusion_every_seed(seed: int) -> None:
    assert_follow_criteria(run("follow_occlusion", seed))


@pytest.mark.slow
@pytest.mark.parametrize("seed", _other_seeds("explore_dock"))
def test_explore_dock_every_seed(seed: int) -> None:
    assert_dock_criteria(run("explore_dock", seed))


@pytest.mark.slow
@pytest.mark.parametrize("seed", SEEDS)
def test_mission_full_every_seed(seed: int) -> None:
    o = run("mission_full", seed)
    assert_dock_criteria(o)
    assert_follow_criteria(o)
