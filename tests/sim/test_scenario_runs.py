"""The shipped follow scenarios do what their descriptions promise, for an ideal follower (slow).

The follower knows the target's true position (no perception, no tree): it sends a navigator goal a
metre short of the target at 5 Hz and, once line of sight is lost, keeps the last position it saw. So
any loss of line of sight here comes from the scenario's geometry, not from a detector or a tree.
"""

from __future__ import annotations

import math

import pytest

from mission.core import blackboard as bbk
from mission.core.types import NavGoal, Pose2D
from mission.sim.scenario import load_scenario
from mission.sim.scenario_overrides import apply_overrides
from mission.sim.sim_adapter import SimAdapter


def ideal_follow(name: str, seed: int) -> tuple[list[tuple[float, float]], int]:
    """(line-of-sight breaks as (start, duration), collisions) over the whole scenario."""
    sc = apply_overrides(load_scenario(name), {"camera": {"width": 160, "height": 120}})
    adapter = SimAdapter(sc, seed=seed)
    adapter.setup()
    bb = bbk.writer("test")
    bbk.set_(bb, bbk.TWIST, None)
    bbk.set_(bb, bbk.NAV_GOAL, None)
    breaks: list[tuple[float, float]] = []
    hidden_since = None
    last_seen = None
    seq, last_goal = 0, -1.0
    try:
        while adapter.t < sc.duration_s:
            adapter.sense(bb)
            truth = adapter.ground_truth()
            assert truth.target is not None
            if truth.target_in_los:
                if hidden_since is not None:
                    breaks.append((hidden_since, truth.stamp - hidden_since))
                    hidden_since = None
                if truth.target_in_fov or last_seen is None:
                    last_seen = (truth.target.x, truth.target.y)
            elif hidden_since is None:
                hidden_since = truth.stamp
            if adapter.t - last_goal >= 0.2 and last_seen is not None:
                dx, dy = last_seen[0] - truth.robot.x, last_seen[1] - truth.robot.y
                d = math.hypot(dx, dy)
                if d > 1.0:
                    seq += 1
                    goal = Pose2D(last_seen[0] - dx / d, last_seen[1] - dy / d, math.atan2(dy, dx))
                    bbk.set_(bb, bbk.NAV_GOAL, NavGoal(goal, adapter.t, seq))
                last_goal = adapter.t
            adapter.act(bb)
            adapter.advance(1 / 15)
        if hidden_since is not None:
            breaks.append((hidden_since, adapter.t - hidden_since))
        collisions = adapter.collisions
    finally:
        adapter.close()
    return [b for b in breaks if b[1] >= 0.3], collisions


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_follow_open_keeps_line_of_sight_all_the_way(seed: int) -> None:
    breaks, collisions = ideal_follow("follow_open", seed)
    assert (breaks, collisions) == ([], 0)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_follow_occlusion_hides_the_target_behind_pillars_for_seconds(seed: int) -> None:
    breaks, collisions = ideal_follow("follow_occlusion", seed)
    assert collisions == 0
    assert any(duration >= 1.0 for _, duration in breaks), breaks


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_search_corner_loses_the_target_round_the_partition(seed: int) -> None:
    breaks, collisions = ideal_follow("search_corner", seed)
    assert collisions == 0
    assert any(duration >= 1.5 for _, duration in breaks), breaks
