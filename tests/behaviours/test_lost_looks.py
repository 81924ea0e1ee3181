"""LOST that looks (PursueLastSeen), the search ladder's first step: the glance toward where the target left the
view, the drive to where the camera sees where it went (or the peek round the edge it went behind), the sweep
there and the loss timer. The rungs after it are in test_search_ladder.py."""

from __future__ import annotations

import math

import numpy as np
import py_trees
import pytest

from mission.behaviours.pursue import PursueLastSeen, Pursuit
from mission.behaviours.search_grid import line_clear, search_grid
from mission.behaviours.search_leaf import predicted_walk
from mission.core import blackboard as bbk
from mission.core.types import CameraIntrinsics, Pose2D
from tests.helpers.behaviour_world import (
    WALL,
    Scene,
    board,
    detection_of,
    grid_with_boxes,
    legs,
    lost_at,
    read,
    turns,
)

S = py_trees.common.Status


def test_lost_first_turns_to_where_the_target_left_the_view_then_drives_to_look_round_the_edge():
    # last seen standing at the wall's north end, 63° to the left of the robot's heading, nothing in between:
    # it left through the image's side. LOST turns to it on the spot first, and 30° on (a target's fitted velocity
    # lags its turning), and only then drives off to peek.
    grid = grid_with_boxes([WALL])
    scene = Scene(robot=Pose2D(0.0, -1.0, 0.0), grid=grid, dt=0.05, clock=0.5)
    lost_at(0.6, 0.2, last_seen=0.0)
    node = PursueLastSeen()
    assert scene.cycle(node) == S.RUNNING and read(bbk.STATE) == "LOST"
    assert read(bbk.NAV_GOAL) is None and read(bbk.TWIST).v == 0.0 and read(bbk.TWIST).w > 0
    assert node.feedback_message.startswith("LOST: turning to where target left the view")
    for _ in range(40):
        if read(bbk.NAV_GOAL) is not None:
            break
        scene.cycle(node)
    assert read(bbk.NAV_GOAL) is not None  # then on to where it can see round the edge
    assert scene.robot.yaw == pytest.approx(math.atan2(1.2, 0.6) + math.radians(30.0), abs=0.12)
    assert node.pursuit.deadline - node.pursuit.started >= 2 * math.atan2(1.2, 0.6)  # the glance is on the timer


def test_lost_does_not_glance_at_a_target_that_went_behind_something_or_round_a_corner():
    scene = Scene(robot=Pose2D(0.0, -1.0, 0.0), grid=grid_with_boxes([WALL, (0.2, -0.5, 0.4, -0.3)]), clock=0.5)
    lost_at(0.6, 0.2, last_seen=0.0)  # a box between the robot and where it was last seen
    node = PursueLastSeen()
    assert scene.cycle(node) == S.RUNNING
    assert node.pursuit.glance_to is None and not node.feedback_message.startswith("LOST: turning to where")

    def glances(walking: tuple[float, float]) -> bool:
        # facing north, west of the wall; last seen a second ago just past its north end, far off to the right
        scene = Scene(robot=Pose2D(-0.5, 1.5, math.pi / 2), grid=grid_with_boxes([WALL]), clock=1.0)
        lost_at(1.5, 1.4, last_seen=0.0, walking=walking)
        node = PursueLastSeen()
        scene.cycle(node)
        return node.pursuit.glance_to is not None

    assert not glances((0.0, -1.0))  # walking south: by now behind the wall
    assert glances((0.0, 1.0))  # walking north: still in the open, off the image's side


def test_lost_glances_at_a_target_seen_too_briefly_to_tell_a_walk_south_from_the_localisations_noise():
    # re-acquired for 0.2 s standing just past the wall's north end, then lost off the image's side; its four
    # placings crept 12 cm south (an AMCL correction, a calibration bias moving across the image): 0.6 m/s
    # "south", which would put it behind the wall by now. Too short to be a walk: LOST glances.
    scene = Scene(robot=Pose2D(-0.5, 1.5, math.pi / 2), grid=grid_with_boxes([WALL]), clock=1.0)
    track = lost_at(1.5, 1.4, last_seen=0.0)
    track.history = [(-0.2 + 0.2 * i / 3, 1.5, 1.4 + 0.04 * (3 - i)) for i in range(4)]
    node = PursueLastSeen()
    scene.cycle(node)
    assert node.pursuit.glance_to is not None
    assert node.feedback_message.startswith("LOST: turning to where target left the view")


def test_lost_glances_where_the_marker_was_last_read_at_the_images_side_though_its_placing_is_inside_the_view():
    # last placed 17° left of the heading, well inside the 70° view, walking north (left) at 0.5 m/s; the placing
    # lags the picture (latency, calibration, the marker on the target's face), and its last reading touched
    # the image's left side: it left that way. Read mid-image instead, it is in view and simply not detected.
    def glance(corner_xs: tuple[float, float] | None) -> tuple[float | None, str]:
        scene = Scene(robot=Pose2D(0.0, -1.0, 0.0), grid=grid_with_boxes([]), clock=1.0)
        scene.camera = CameraIntrinsics(fx=457.0, fy=457.0, cx=320.0, cy=240.0, width=640, height=480)
        track = lost_at(2.0, -0.4, last_seen=0.0, walking=(0.0, 0.5))
        if corner_xs is not None:
            x0, x1 = corner_xs
            track.detection = detection_of(track.pose_map, Pose2D(0.0, -1.0, 0.0))
            track.detection.corners = np.array([[x0, 200.0], [x1, 200.0], [x1, 260.0], [x0, 260.0]])
        node = PursueLastSeen()
        scene.cycle(node)
        return node.pursuit.glance_to, node.feedback_message

    assert glance(None)[0] is None
    assert glance((280.0, 340.0))[0] is None
    at_the_side, feedback = glance((7.0, 57.0))
    assert feedback.startswith("LOST: turning to where target left the view")
    # it turns past where the target has walked on to in the second since (not where it was last placed), and 30° on
    assert at_the_side == pytest.approx(math.atan2(-0.4 + 0.5 + 1.0, 2.0) + math.radians(30.0), abs=0.05)


def test_a_target_placed_in_a_doorways_margin_still_walks_on_through_the_door():
    # a wall along y ≈ 1.1 with a doorway from x = 0 to 0.8; the target walks north through it at 0.8 m/s, and
    # the localisation's error places it 15 cm from the left jamb, where its centre cannot stand. Where it went
    # is beyond the door, not where it was placed (which made LOST take it for a target that stood still).
    sg = search_grid(grid_with_boxes([(-3.0, 1.0, 0.0, 1.2), (0.8, 1.0, 3.0, 1.2)]))
    track = lost_at(0.15, 0.9, walking=(0.0, 0.8))
    assert not sg.target_free()[sg.cell(0.15, 0.9)]
    last, went = predicted_walk(sg, sg.target_free(), track, 2.0)
    assert last == pytest.approx((0.15, 0.9))
    assert went[1] > 2.0 and 0.0 < went[0] < 0.8
    # placed against the wall itself, walking into it: it stops there, as before
    track = lost_at(-1.0, 0.9, walking=(0.0, 0.8))
    assert predicted_walk(sg, sg.target_free(), track, 2.0)[1][1] < 1.0


def test_lost_drives_to_where_the_camera_sees_where_the_target_went_facing_it_with_a_timer_for_the_detour():
    grid = grid_with_boxes([WALL])
    scene = Scene(robot=Pose2D(0.0, -1.0, 0.0), grid=grid, clock=0.5)
    lost_at(2.0, -1.0, last_seen=0.0, walking=(0.0, -0.5))  # behind the wall, walking south
    node = PursueLastSeen(speed_mps=0.35)
    assert scene.cycle(node) == S.RUNNING and read(bbk.STATE) == "LOST"
    goal = read(bbk.NAV_GOAL)
    plan = node.pursuit
    sg = search_grid(grid)
    assert line_clear(sg.occupied, sg, (goal.pose.x, goal.pose.y), plan.aim)  # from there it sees the target's way
    aim_bearing = math.atan2(plan.aim[1] - goal.pose.y, plan.aim[0] - goal.pose.x)
    assert abs(math.remainder(goal.pose.yaw - aim_bearing, 2 * math.pi)) < 1e-6  # and arrives facing it
    assert plan.aim[1] < -1.0  # where it went: on along its last velocity, not where it was last seen
    timer = plan.deadline - plan.started
    assert timer >= plan.path_m / 0.35 and plan.path_m > 2.0  # a timer long enough for the detour
    assert f"{plan.path_m:.1f} m detour" in node.feedback_message


def test_with_no_heading_lost_peeks_round_the_edge_the_target_went_behind_sweeping_across_it():
    # last seen at the wall's north end, standing still: it can have gone on round the end, out of sight
    grid = grid_with_boxes([WALL])
    scene = Scene(robot=Pose2D(-0.5, -1.5, math.radians(60)), grid=grid, clock=0.5)
    lost_at(0.9, 1.3, last_seen=0.0)
    node = PursueLastSeen()
    assert scene.cycle(node) == S.RUNNING and read(bbk.STATE) == "LOST"
    plan = node.pursuit
    sg = search_grid(grid)
    behind = (1.5, 0.6)  # round the end, on the far side of the wall: hidden from where the robot stands
    assert not line_clear(sg.occupied, sg, (-0.5, -1.5), behind)
    assert line_clear(sg.occupied, sg, (plan.view.x, plan.view.y), behind)  # from where it goes, in sight
    assert plan.sweep_to is not None or abs(
        math.remainder(math.atan2(behind[1] - plan.view.y, behind[0] - plan.view.x) - plan.view.yaw, 2 * math.pi)
    ) < math.radians(35)


DOORWAY = [(1.0, -4.0, 1.2, -0.5), (1.0, 0.5, 1.2, 4.0)]  # a wall at x ≈ 1.1 with a 1 m doorway at y = 0


def test_lost_goes_into_the_doorway_the_target_went_through_and_looks_round_both_edges():
    # the target walked east through the doorway; from the nearest place that sees where it was going the robot
    # would look through the gap, and a target that turned along the wall on the far side is not there
    grid = grid_with_boxes(DOORWAY)
    scene = Scene(robot=Pose2D(-1.5, 0.0, 0.0), grid=grid, clock=0.5)
    lost_at(1.6, 0.1, last_seen=0.0, walking=(1.0, 0.0))
    node = PursueLastSeen()
    assert scene.cycle(node) == S.RUNNING and read(bbk.STATE) == "LOST"
    plan = node.pursuit
    sg = search_grid(grid)
    view = (plan.view.x, plan.view.y)
    for along_the_wall in [(1.5, 1.8), (1.5, -1.8)]:  # round the north edge, round the south edge
        assert not line_clear(sg.occupied, sg, (-1.5, 0.0), along_the_wall)
        assert line_clear(sg.occupied, sg, view, along_the_wall)
    assert plan.sweep_to is not None  # wider than one look: it sweeps across them
    assert plan.deadline - plan.started >= plan.path_m / 0.35


def lost_through_the_doorway() -> tuple[Scene, PursueLastSeen, Pursuit]:
    """The doorway above, the target lost walking east through it: the scene, LOST, and its plan (a sweep)."""
    scene = Scene(robot=Pose2D(-1.5, 0.0, 0.0), grid=grid_with_boxes(DOORWAY), clock=0.5)
    lost_at(1.6, 0.1, last_seen=0.0, walking=(1.0, 0.0))
    node = PursueLastSeen()
    scene.cycle(node)
    return scene, node, node.pursuit


def test_lost_that_arrives_as_its_timer_runs_out_still_sweeps_round_both_edges_before_handing_over():
    # the doorway above; the drive there took all but 0.2 s of the timer (the navigator is slower than the
    # timer's speed through turns): the sweep it came for is given in full, then its look, then SEARCH
    scene, node, plan = lost_through_the_doorway()
    assert plan.sweep_to is not None
    scene.robot = Pose2D(plan.view.x, plan.view.y, math.atan2(plan.aim[1] - plan.view.y, plan.aim[0] - plan.view.x))
    scene.clock = plan.deadline - 0.2
    _, statuses = turns(scene, node, 200)
    assert statuses[-1] == S.FAILURE and scene.clock > plan.deadline + 1.0
    assert plan.swept and abs(math.remainder(scene.robot.yaw - plan.sweep_to, 2 * math.pi)) <= 0.15
    assert read(bbk.REASON).startswith(f"LOST: looked from ({plan.view.x:.2f}, {plan.view.y:.2f})")


def test_lost_that_arrives_facing_the_far_edge_sweeps_from_there_rather_than_turning_back_first():
    # the doorway above; the drive there ended with the camera on the sweep's far edge (hide_and_wait seed 5002,
    # typical: it arrived facing almost where the target stood, turned 130° away to the aim, then swept back)
    scene, node, plan = lost_through_the_doorway()
    near, far = plan.view.yaw, plan.sweep_to
    scene.robot = Pose2D(plan.view.x, plan.view.y, far)
    rates, statuses = turns(scene, node, 200)
    assert statuses[-1] == S.FAILURE and read(bbk.REASON).startswith("LOST: looked from")
    assert len(legs(rates)) == 1  # one turn across, from the far edge to the near one
    assert abs(math.remainder(scene.robot.yaw - near, 2 * math.pi)) <= 0.15


def test_a_longer_detour_gets_a_longer_loss_timer():
    timers = []
    for wall in [(1.0, -4.0, 1.2, 0.0), (1.0, -4.0, 1.2, 2.5)]:  # the wall's north end 1 m, then 3.5 m away
        bbk.set_(board(), bbk.BELIEFS, {})
        scene = Scene(robot=Pose2D(0.0, -1.0, 0.0), grid=grid_with_boxes([wall]), clock=0.5)
        lost_at(2.0, -1.0, last_seen=0.0)
        node = PursueLastSeen()
        scene.cycle(node)
        timers.append(node.pursuit.deadline - node.pursuit.started)
    assert timers[1] > timers[0] + 3.0


def test_lost_hands_over_to_search_when_the_detour_takes_longer_than_its_timer():
    scene = Scene(robot=Pose2D(0.0, -1.0, 0.0), grid=grid_with_boxes([WALL]), clock=0.5, dt=0.5)
    lost_at(2.0, -1.0, last_seen=0.0)
    node = PursueLastSeen(max_timeout_s=3.0)  # the navigator never moves the robot here
    statuses = [scene.cycle(node) for _ in range(8)]
    assert statuses[-1] == S.FAILURE
    assert read(bbk.REASON).startswith("LOST: target not seen again within the loss timer 3.0 s")
    assert scene.cycle(node) == S.FAILURE  # one pursuit per loss: re-entered, it fails at once
