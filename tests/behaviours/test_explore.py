"""Explore: look for the dock marker — waypoints with a look-around at each, or an in-place sweep."""

from __future__ import annotations

import math

import py_trees
import pytest

from mission.behaviours.explore import READABLE_SMEAR_PX, Explore, parse_waypoints
from mission.core import blackboard as bbk
from mission.core.config import TargetSpec
from mission.core.types import CameraIntrinsics, Pose2D, Twist
from tests.helpers.behaviour_world import Scene, ScriptedNavigator, marker_facing, read

S = py_trees.common.Status


def explore_tree(scene: Scene, **ports) -> Explore:
    scene.perceive_targets({"dock": TargetSpec(marker_id=0)})
    root = Explore(**ports)
    root.setup_with_descendants()
    return root


def test_without_waypoints_it_sweeps_in_place_until_the_dock_is_seen_then_stops():
    # the dock is behind the robot: it has to turn about 180° to see it
    scene = Scene(robot=Pose2D(0.0, 0.0, 0.0), marker=marker_facing(-2.0, 0.0, 0.0), marker_id=0)
    root = explore_tree(scene, angular_speed=0.5)
    statuses = []
    while root.status != S.SUCCESS and scene.clock < 20.0:
        statuses.append(scene.cycle(root))
        if root.status == S.RUNNING:
            assert read(bbk.TWIST) == Twist(0.0, 0.5) and read(bbk.STATE) == "EXPLORE"
    assert root.status == S.SUCCESS
    assert 4.0 < scene.clock < 6.5  # ≈ (180° − 35° half FOV) / 0.5 rad/s
    assert read(bbk.TWIST) == Twist(0.0, 0.0) and read(bbk.NAV_GOAL) is None
    assert read(bbk.REASON).startswith("EXPLORE: dock found after")


def test_a_long_exposure_slows_the_sweep_to_a_smear_the_marker_survives_and_says_so():
    # a webcam indoors at 30 ms, fx 416 px: the default 0.5 rad/s would smear a marker over 6.2 px
    lens = CameraIntrinsics(fx=416.0, fy=416.0, cx=320.0, cy=240.0, width=640, height=480)
    scene = Scene(
        robot=Pose2D(0.0, 0.0, 0.0), marker=marker_facing(-2.0, 0.0, 0.0), marker_id=0, camera=lens, exposure_s=0.030
    )
    root = explore_tree(scene, angular_speed=0.5)
    rates, said = set(), []
    while root.status != S.SUCCESS and scene.clock < 30.0:
        scene.cycle(root)
        if root.status == S.RUNNING:
            rates.add(round(read(bbk.TWIST).w, 4))
            said.append(root.feedback_message)
    cap = READABLE_SMEAR_PX / (0.030 * 416.0)  # ≈ 0.16 rad/s: a 2 px smear
    assert rates == {round(cap, 4)}
    assert root.status == S.SUCCESS and 12.0 < scene.clock < 18.0  # ≈ (180° − 35° half FOV) / 0.16 rad/s
    assert said[-1].startswith("EXPLORE: sweeping for dock at 0.16 rad/s (30 ms exposure), turned")


def test_an_instant_exposure_or_an_unknown_one_leaves_the_sweep_at_its_speed():
    lens = CameraIntrinsics(fx=416.0, fy=416.0, cx=320.0, cy=240.0, width=640, height=480)
    for exposure in (0.0, None):
        scene = Scene(robot=Pose2D(0.0, 0.0, 0.0), marker=None, camera=lens, exposure_s=exposure)
        root = explore_tree(scene, angular_speed=0.5)
        scene.cycle(root)
        assert read(bbk.TWIST) == Twist(0.0, 0.5)
        assert root.feedback_message.startswith("EXPLORE: sweeping for dock, turned")


def test_with_waypoints_it_visits_each_and_looks_around_until_the_dock_shows_up():
    # the dock hangs on a wall visible only from the second waypoint, looking back toward where it came from
    scene = Scene(marker=marker_facing(6.0, 4.0, math.pi), marker_id=0, navigator=ScriptedNavigator(), dt=0.1)
    root = explore_tree(scene, waypoints="2,0; 4,4", angular_speed=1.0)
    explore = root
    said = []
    while root.status != S.SUCCESS and scene.clock < 40.0:
        scene.cycle(root)
        said.append(explore.feedback_message)
    assert root.status == S.SUCCESS
    goals = [(g.pose.x, g.pose.y) for g in scene.navigator.goals]
    assert goals == [(2.0, 0.0), (4.0, 4.0)]
    assert any(s.startswith("EXPLORE: looking around at waypoint 1/2") for s in said)
    assert any(s.startswith("EXPLORE: going to waypoint 2/2 (4.0, 4.0)") for s in said)


def test_unreachable_waypoints_are_skipped_and_exhausting_them_fails_with_a_reason():
    nav = ScriptedNavigator(unreachable=((1.0, 1.0),))
    scene = Scene(marker=None, navigator=nav, dt=0.2)
    root = explore_tree(scene, waypoints="1,1;-1,0", angular_speed=1.5)
    while root.status != S.FAILURE and scene.clock < 60.0:
        scene.cycle(root)
    assert root.status == S.FAILURE
    assert read(bbk.REASON) == "EXPLORE: visited 2 waypoint(s) (1 unreachable) without seeing dock"
    assert read(bbk.TWIST) == Twist(0.0, 0.0) and read(bbk.NAV_GOAL) is None


def test_it_fails_at_timeout():
    scene = Scene(marker=None, dt=0.5)
    root = explore_tree(scene, timeout_s=5.0)
    while root.status != S.FAILURE and scene.clock < 10.0:
        scene.cycle(root)
    assert read(bbk.REASON) == "EXPLORE: dock not found within 5 s"


def test_waypoints_are_parsed_and_a_bad_item_is_named():
    assert parse_waypoints(" 1.5, -2 ; 3,4; ") == [(1.5, -2.0), (3.0, 4.0)]
    assert parse_waypoints("") == []
    with pytest.raises(ValueError, match=r"waypoints: item 2 '3' is not 'x,y' in metres"):
        parse_waypoints("1,2;3;4")
    with pytest.raises(ValueError, match="item 1 'a,b'"):
        Explore(waypoints="a,b")
