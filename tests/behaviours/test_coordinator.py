"""The FOLLOW / LOST / SEARCH coordinator built from the catalogue leaves, as follow.xml composes them.

ReactiveFallback = Selector(memory=False), ReactiveSequence = Sequence(memory=False), ForceSuccess =
FailureIsSuccess. A target walks behind a pillar, stays hidden, then shows itself again; another walks
out of the field of view. The assertions are on what a user watching /mission/state would see.
"""

from __future__ import annotations

import math

import py_trees

from mission.behaviours.follow import FollowTarget
from mission.behaviours.line_of_sight import IsLineOfSightBlocked
from mission.behaviours.lost import HoldLastGoal
from mission.behaviours.search import SearchSweep
from mission.behaviours.visibility import IsTargetVisible
from mission.core import blackboard as bbk
from mission.core.config import TargetSpec
from mission.core.types import Pose2D
from tests.helpers.behaviour_world import Scene, grid_with_boxes, marker_facing, read

S = py_trees.common.Status
PILLAR = (1.5, -0.3, 1.9, 0.3)


def follow_mission(scene: Scene) -> py_trees.behaviour.Behaviour:
    scene.perceive_targets({"target": TargetSpec(marker_id=7)})
    Seq, Sel = py_trees.composites.Sequence, py_trees.composites.Selector
    coordinator = Sel(
        "coordinator",
        memory=False,
        children=[
            Seq("FOLLOW", memory=False, children=[IsTargetVisible(max_misses=4), FollowTarget()]),
            Seq("LOST", memory=False, children=[IsLineOfSightBlocked(min_misses=5), HoldLastGoal(timeout_s=3.0)]),
            SearchSweep(duration_s=20.0),
        ],
    )
    root = coordinator
    root.setup_with_descendants()
    return root


def timeline(states: list[tuple[float, str]]) -> list[tuple[float, str]]:
    """(time, state) at each change, as a user watching /mission/state sees it."""
    out: list[tuple[float, str]] = []
    for t, s in states:
        if not out or out[-1][1] != s:
            out.append((t, s))
    return out


def test_occlusion_behind_a_pillar_goes_lost_then_search_and_re_detection_returns_to_follow():
    scene = Scene(robot=Pose2D(0.0, 0.0, 0.0), marker=marker_facing(3.0, 0.9, math.pi), occluders=[PILLAR])
    scene.grid = grid_with_boxes([PILLAR])
    root = follow_mission(scene)
    states, goals_in_lost, hidden_at = [], set(), None
    while scene.clock < 12.0:
        t = scene.clock
        if 2.0 <= t < 3.5:  # the target walks behind the pillar at 0.6 m/s and stays there
            scene.marker = marker_facing(3.0, 0.9 - 0.6 * (t - 2.0), math.pi)
        if t >= 9.0:  # ... and steps out again, where the robot looks now
            p = scene.robot
            scene.marker = marker_facing(p.x + 2.0 * math.cos(p.yaw), p.y + 2.0 * math.sin(p.yaw), p.yaw + math.pi)
        if hidden_at is None and scene.occluded():
            hidden_at = t
        scene.cycle(root)
        state = read(bbk.STATE)
        states.append((t, state))
        if state == "LOST":
            goals_in_lost.add(read(bbk.NAV_GOAL).seq)
        if t >= 9.0 and read(bbk.TRACKS)["target"].misses == 0:
            break

    seen = timeline(states)
    assert [s for _, s in seen] == ["FOLLOW", "LOST", "SEARCH", "FOLLOW"]
    (_, _), (t_lost, _), (t_search, _), (t_back, _) = seen
    assert hidden_at is not None and 0.0 < t_lost - hidden_at <= 0.5  # occlusion detected within 0.5 s
    assert len(goals_in_lost) == 1  # the goal is frozen while LOST
    assert 2.9 <= t_search - hidden_at <= 3.2  # the 3 s loss timer runs from the last sighting
    assert t_back == states[-1][0]  # FOLLOW on the very tick the target is seen again
    assert read(bbk.TWIST) is None and read(bbk.NAV_GOAL) is not None  # navigating to it again


def test_a_target_leaving_the_field_of_view_goes_straight_to_search_toward_its_last_bearing():
    scene = Scene(robot=Pose2D(0.0, 0.0, 0.0), marker=marker_facing(2.5, 0.0, math.pi))
    scene.grid = grid_with_boxes([])
    root = follow_mission(scene)
    states = []
    while scene.clock < 8.0:
        t = scene.clock
        if 1.0 <= t < 4.0:  # walks off to the robot's left, out of the 35° half field of view
            y = min(1.0 * (t - 1.0), 2.5)
            scene.marker = marker_facing(2.5, y, math.pi)
        scene.cycle(root)
        states.append((scene.clock, read(bbk.STATE), read(bbk.TWIST)))
        if len(states) > 40 and states[-1][1] == "FOLLOW" and states[-2][1] == "SEARCH":
            break
    seen = timeline([(t, s) for t, s, _ in states])
    assert [s for _, s in seen] == ["FOLLOW", "SEARCH", "FOLLOW"]
    first_search = next(tw for _, s, tw in states if s == "SEARCH")
    assert first_search.w > 0  # turns left, where the target went
