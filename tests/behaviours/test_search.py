"""SearchSweep: turn first toward where the target was last seen, then a full circle, then give up."""

from __future__ import annotations

import math

import py_trees

from mission.behaviours.search import SearchSweep
from mission.core import blackboard as bbk
from mission.core.types import Pose2D, TargetTrack, Twist
from tests.helpers.behaviour_world import Scene, board, marker_facing, read

S = py_trees.common.Status


def last_seen_at(x: float, y: float) -> None:
    track = TargetTrack("target", last_seen=0.0, misses=9, pose_map=marker_facing(x, y, math.pi))
    bbk.set_(board(), bbk.TRACKS, {"target": track})


def test_it_turns_toward_the_side_the_target_was_last_seen_on():
    for (x, y), sign in [((1.0, 2.0), +1), ((1.0, -2.0), -1)]:
        scene = Scene(robot=Pose2D(0.0, 0.0, 0.0))
        last_seen_at(x, y)
        node = SearchSweep(angular_speed=0.6)
        assert scene.cycle(node) == S.RUNNING
        assert read(bbk.TWIST) == Twist(0.0, sign * 0.6) and read(bbk.NAV_GOAL) is None
        assert read(bbk.STATE) == "SEARCH"
        side = "left" if sign > 0 else "right"
        assert node.feedback_message.startswith(f"searching: turning {side} toward last bearing 63°")


def test_after_the_last_bearing_it_completes_a_full_circle():
    scene = Scene(robot=Pose2D(0.0, 0.0, 0.0), dt=0.1)
    last_seen_at(0.0, -1.0)  # 90° to the right
    node = SearchSweep(angular_speed=0.6, duration_s=30.0)
    said = []
    yaw_total = 0.0
    while yaw_total < math.radians(90 + 360 + 10):
        before = scene.robot.yaw
        scene.cycle(node)
        yaw_total += abs(math.remainder(scene.robot.yaw - before, 2 * math.pi))
        said.append(node.feedback_message)
    assert read(bbk.TWIST).w < 0
    assert any("toward last bearing 90°" in s for s in said[:5])
    assert any(s.startswith("searching: circle 1 turning right, 50% done") for s in said)
    assert said[-1].startswith("searching: circle 2 turning right")


def test_with_no_known_target_position_it_sweeps_counter_clockwise():
    scene = Scene()
    bbk.set_(board(), bbk.TRACKS, {})
    node = SearchSweep()
    scene.cycle(node)
    assert read(bbk.TWIST).w > 0 and node.feedback_message.startswith("searching: circle 1 turning left")


def test_it_fails_with_a_reason_after_duration_s_and_stops_the_robot():
    scene = Scene(dt=0.5)
    last_seen_at(2.0, 0.0)
    node = SearchSweep(duration_s=15.0)
    statuses = [scene.cycle(node) for _ in range(32)]
    assert statuses[:31] == [S.RUNNING] * 31 and statuses[31] == S.FAILURE
    assert read(bbk.REASON) == "SEARCH: target not found after 15.5 s of sweeping (limit 15 s)"
    assert read(bbk.TWIST) == Twist(0.0, 0.0)


def test_re_entering_search_during_the_same_loss_continues_the_sweep_and_its_clock():
    scene = Scene(dt=0.5)
    last_seen_at(2.0, 0.0)
    node = SearchSweep(duration_s=10.0)
    for _ in range(12):
        scene.cycle(node)  # 6 s of sweeping
    node.stop(S.INVALID)  # preempted for a moment by a higher branch, no sighting in between
    scene.cycle(node)
    assert node.feedback_message.endswith("6.0 s of 10 s")  # not "0.0 s": the clock went on
    statuses = [scene.cycle(node) for _ in range(9)]  # … to 10.5 s
    assert statuses[-1] == S.FAILURE and S.FAILURE not in statuses[:-1]


def test_a_new_loss_starts_a_new_search():
    scene = Scene(dt=0.5)
    last_seen_at(2.0, 0.0)
    node = SearchSweep(duration_s=10.0)
    for _ in range(12):
        scene.cycle(node)
    node.stop(S.INVALID)
    track = TargetTrack("target", last_seen=6.2, misses=5, pose_map=marker_facing(2.0, 0.0, math.pi))
    bbk.set_(board(), bbk.TRACKS, {"target": track})  # seen again at 6.2 s, lost again
    scene.cycle(node)
    assert node.feedback_message.endswith("0.0 s of 10 s")


def test_standing_where_the_target_was_last_seen_it_turns_the_way_the_target_was_walking():
    # LOST brought the robot next to the last position (1, 0.1), facing +x; the target was walking south (−y)
    scene = Scene(robot=Pose2D(0.5, 0.0, 0.0))
    history = [(i * 0.1, 1.0, 1.0 - 0.09 * i) for i in range(11)]
    track = TargetTrack("target", last_seen=1.0, misses=30, pose_map=marker_facing(1.0, 0.1, math.pi))
    track.history = history
    bbk.set_(board(), bbk.TRACKS, {"target": track})
    node = SearchSweep(angular_speed=0.6)
    scene.cycle(node)
    assert read(bbk.TWIST) == Twist(0.0, -0.6)
    assert node.feedback_message.startswith("searching: turning right")
