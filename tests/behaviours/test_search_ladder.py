"""The search ladder, rung by rung: SEARCH a (TurnToBearing), the belief of where a lost target can be, SEARCH b
(SearchBelief: viewpoints by belief per second of travel), SEARCH d (GiveUpSearch) and the
opennav_following-style baseline (RotateSearch). LOST that looks (PursueLastSeen), the rung before them, is in
test_lost_looks.py; the own-footprint scan filter is in test_line_of_sight.py."""

from __future__ import annotations

import itertools
import math

import numpy as np
import py_trees
import pytest

from mission.behaviours.belief import TargetBelief
from mission.behaviours.search_give_up import GiveUpSearch
from mission.behaviours.search_grid import line_clear, search_grid
from mission.behaviours.search_turn import RotateSearch, TurnToBearing
from mission.behaviours.search_views import SearchBelief, Visit
from mission.core import blackboard as bbk
from mission.core.types import Pose2D, RobotState, Twist
from tests.helpers.behaviour_world import (
    WALL,
    Scene,
    ScriptedNavigator,
    board,
    grid_with_boxes,
    legs,
    lost_at,
    read,
    tick,
    turns,
)

S = py_trees.common.Status


# ------------------------------------------------------------------------------------ SEARCH a
def test_turn_to_bearing_turns_toward_the_target_the_nearer_way_first_then_back_the_other_way():
    for (x, y), first in [((1.0, -2.0), -1), ((1.0, 2.0), +1)]:
        scene = Scene(robot=Pose2D(0.0, 0.0, 0.0), dt=0.1)
        lost_at(x, y)
        node = TurnToBearing(angular_speed=1.0)
        rates, statuses = turns(scene, node, 200)
        assert legs(rates) == [first, -first]
        assert statuses[-1] == S.FAILURE and S.FAILURE not in statuses[:-1]
        assert read(bbk.REASON).startswith(
            f"SEARCH a: turned toward target's predicted bearing {math.degrees(math.atan2(y, x)):+.0f}° and back "
            "the other way"
        )


def test_turn_to_bearing_goes_past_the_bearing_by_the_overshoot_before_turning_back():
    scene = Scene(robot=Pose2D(0.0, 0.0, 0.0), dt=0.05)
    lost_at(1.0, -1.0)  # 45° right
    node = TurnToBearing(angular_speed=1.0, overshoot_deg=30.0)
    yaws = []
    for _ in range(400):
        if scene.cycle(node) != S.RUNNING:
            break
        yaws.append(scene.robot.yaw)
    assert math.degrees(min(yaws)) == pytest.approx(-75.0, abs=3.0)  # 45° + 30° to the right, then back left
    assert scene.robot.yaw > math.radians(100)  # … to 180° − 45° = 135° past the start on the other side


def test_straight_ahead_the_turn_follows_the_way_the_target_was_walking_across_the_view():
    scene = Scene(robot=Pose2D(0.0, 0.0, 0.0), dt=0.1)
    lost_at(2.0, 0.05, walking=(0.0, -0.6))  # 1° left of ahead, but it was walking off to the right
    node = TurnToBearing()
    scene.cycle(node)
    assert read(bbk.TWIST).w < 0
    assert node.feedback_message.startswith("SEARCH a: turning right (toward the predicted bearing")


def test_the_first_turn_goes_on_past_the_overshoot_while_what_is_beside_the_view_is_where_the_target_can_be():
    # lost 18° to the right: the first leg is planned to 18° + 30°. Where the target can be is fixed (a belief that
    # does not grow): a patch ahead on the left, and — or not — a strip far round to the right (a corridor it
    # walked down after turning a corner).
    def lowest_yaw(strip: bool) -> float:
        grid = grid_with_boxes([])
        sg = search_grid(grid)
        scene = Scene(robot=Pose2D(0.0, 0.0, 0.0), grid=grid, dt=0.05, clock=0.5)
        track = lost_at(1.5, -0.5, last_seen=0.0)
        belief = TargetBelief.start("target", 0.0, (1.5, -0.5), None, sg, now=0.5, speed_mps=0.0)
        xs, ys = sg.centres()
        front = np.hypot(xs - 1.5, ys - 2.5) < 0.8  # ahead on the left
        if strip:
            front |= (np.abs(xs - 0.2) < 0.3) & (ys < -1.0) & (ys > -3.5)  # round to the right, -85° or so
        belief.front = front
        bbk.set_(board(), bbk.BELIEFS, {track.name: belief})
        node = TurnToBearing(angular_speed=1.0, overshoot_deg=30.0)
        lowest = 0.0
        for _ in range(60):  # 3 s: the first leg and the start of the second
            scene.cycle(node)
            lowest = min(lowest, scene.robot.yaw)
        return math.degrees(lowest)

    assert lowest_yaw(strip=True) < -48.0 - 15.0  # it turned on until the strip came into view
    assert lowest_yaw(strip=False) > -48.0 - 4.0  # nothing there: no further than planned (here: not at all)


def test_turning_in_place_hands_over_at_once_when_a_whole_turn_would_show_little_of_where_it_can_be():
    # lost just ahead on the right, so the first turn is short; where the target can be is mostly behind the
    # wall, which no heading from here sees through — or, the other way round, mostly in the open
    def first_tick(behind_the_wall: bool) -> S:
        grid = grid_with_boxes([WALL])
        sg = search_grid(grid)
        scene = Scene(robot=Pose2D(0.0, -1.0, 0.0), grid=grid, dt=0.05, clock=0.5)
        track = lost_at(0.8, -1.2, last_seen=0.0)
        belief = TargetBelief.start("target", 0.0, (0.8, -1.2), None, sg, now=0.5, speed_mps=0.0)
        xs, ys = sg.centres()
        patch = np.hypot(xs - 0.6, ys - 0.0) < 0.3  # in sight, ahead on the left
        far = (xs > 1.4) & (xs < 3.0) & (ys > -3.5) & (ys < 0.5) if behind_the_wall else (xs < -0.3) & (ys > 0.0)
        belief.front = patch | far
        bbk.set_(board(), bbk.BELIEFS, {track.name: belief})
        return scene.cycle(TurnToBearing())

    assert first_tick(behind_the_wall=True) == S.FAILURE
    assert "moving instead" in read(bbk.REASON)
    assert first_tick(behind_the_wall=False) == S.RUNNING


def test_the_first_turn_goes_the_way_most_of_where_the_target_can_be_lies_whatever_the_bearing_says():
    # lost 10° to the left, where LOST has looked already; where the target can be (a belief that does not grow) is
    # a patch ahead on the left and a strip round to the right (a corridor it turned down): the right holds half
    # as much again, and the turn goes that way first. Without the strip, the bearing's way.
    def first_turn(strip: bool) -> tuple[int, str]:
        grid = grid_with_boxes([])
        sg = search_grid(grid)
        scene = Scene(robot=Pose2D(0.0, 0.0, 0.0), grid=grid, dt=0.05, clock=0.5)
        track = lost_at(2.0, 0.35, last_seen=0.0)
        belief = TargetBelief.start("target", 0.0, (2.0, 0.35), None, sg, now=0.5, speed_mps=0.0)
        xs, ys = sg.centres()
        where = np.hypot(xs - 1.0, ys - 1.6) < 0.3  # ahead on the left, about 60°
        if strip:
            where |= (np.abs(xs - 1.0) < 0.3) & (ys < -0.8) & (ys > -2.5)  # round to the right, -40° to -70°
        belief.front = where
        bbk.set_(board(), bbk.BELIEFS, {track.name: belief})
        node = TurnToBearing(angular_speed=1.0)
        scene.cycle(node)
        return int(math.copysign(1, read(bbk.TWIST).w)), node.feedback_message

    right, said = first_turn(strip=True)
    assert right == -1 and said.startswith("SEARCH a: turning right (toward the side where it can be")
    left, said = first_turn(strip=False)
    assert left == +1 and said.startswith("SEARCH a: turning left (toward the predicted bearing +10°)")


PILLAR = (0.15, -1.6, 0.35, -1.4)  # between the robot at (0, −1) and a place 63° to its right, (0.5, −2)


def test_a_target_that_left_through_the_side_of_the_view_is_looked_for_there_before_turning_is_given_up():
    # where the target can be is mostly behind the wall, so a whole turn here would show little of it and the
    # rung would hand over at once; but it was last seen 63° to the right, in the open: it walked out of the
    # image's side, and a glance that way comes first. Behind a pillar instead, no glance: it went behind it.
    def run(boxes: list[tuple[float, float, float, float]]) -> tuple[S, float]:
        grid = grid_with_boxes(boxes)
        sg = search_grid(grid)
        scene = Scene(robot=Pose2D(0.0, -1.0, 0.0), grid=grid, dt=0.05, clock=0.5)
        track = lost_at(0.5, -2.0, last_seen=0.0)
        belief = TargetBelief.start("target", 0.0, (0.5, -2.0), None, sg, now=0.5, speed_mps=0.0)
        xs, ys = sg.centres()
        belief.front = (xs > 1.4) & (xs < 3.0) & (ys > -3.5) & (ys < 0.5)
        bbk.set_(board(), bbk.BELIEFS, {track.name: belief})
        node = TurnToBearing(angular_speed=1.0)
        lowest, status = 0.0, S.RUNNING
        for _ in range(100):
            status = scene.cycle(node)
            lowest = min(lowest, scene.robot.yaw)
            if status != S.RUNNING:
                break
        return status, math.degrees(lowest)

    status, lowest = run([WALL])
    assert status == S.FAILURE and "moving instead" in read(bbk.REASON)
    assert lowest == pytest.approx(math.degrees(math.atan2(-1.0, 0.5)), abs=5.0)  # it faced where it left the view
    status, lowest = run([WALL, PILLAR])
    assert status == S.FAILURE and lowest == 0.0  # behind the pillar: handed over without turning


# ------------------------------------------------------------------------------------ the belief


def test_the_belief_grows_with_the_targets_top_speed_and_does_not_go_through_walls():
    sg = search_grid(grid_with_boxes([WALL]))
    belief = TargetBelief.start("target", 0.0, (0.0, -1.0), None, sg, now=0.0, speed_mps=1.0)

    def possible(x: float, y: float) -> bool:
        return bool(belief.possible[sg.cell(x, y)])

    assert possible(0.0, -1.0) and not possible(0.0, 0.5)  # at first: where it was last seen
    belief.grow(2.0)  # two seconds at 1 m/s: 2.3 m round the last position
    assert possible(0.0, 0.5) and possible(-1.5, -1.0) and not possible(-2.8, -1.0)
    assert not possible(2.0, -1.0)  # 2 m away in a straight line, but through the wall: a long way round
    belief.grow(9.0)
    assert possible(2.0, -1.0)  # by now it could have walked round the north end


def test_what_the_camera_sees_is_no_longer_where_the_target_can_be():
    sg = search_grid(grid_with_boxes([WALL]))
    belief = TargetBelief.start("target", 0.0, (0.0, -1.0), None, sg, now=0.0, speed_mps=1.0)
    unlooked = TargetBelief.start("target", 0.0, (0.0, -1.0), None, sg, now=0.0, speed_mps=1.0)
    unlooked.grow(3.0)
    belief.look(3.0, camera=(-2.0, -1.0), yaw=0.0, hfov=math.radians(70), blocked=sg.occupied)
    assert not belief.possible[sg.cell(0.0, -1.0)] and not belief.possible[sg.cell(0.5, -1.2)]  # in view
    assert belief.possible[sg.cell(-2.0, 0.5)] and belief.possible[sg.cell(0.0, 1.8)]  # beside and beyond the view
    assert belief.mass() < 0.9 * unlooked.mass()  # as much grew, less is left: the camera's view is cleared
    assert 0 < belief.seen_fraction() < 1


def test_a_place_the_target_reaches_by_a_short_walk_outweighs_one_it_reaches_by_a_long_way_round():
    # two places 2 m from where it was lost: one in the open, one behind the wall (a long walk round its end)
    sg = search_grid(grid_with_boxes([WALL]))
    belief = TargetBelief.start("target", 0.0, (0.0, -1.0), None, sg, now=0.0, speed_mps=1.0)
    assert belief.density is not None
    total = float(belief.density.sum())
    belief.grow(8.0)  # long enough to have walked to either
    near, round_the_end = sg.cell(-2.0, -1.0), sg.cell(2.0, -1.0)
    assert belief.possible[near] and belief.possible[round_the_end]
    w = belief.weights()
    assert w[near] > 1.5 * w[round_the_end] > 0  # the prior alone weighs them alike: as far, no heading
    assert float(belief.density.sum()) == pytest.approx(total, rel=1e-3)  # spread, none lost
    assert not belief.density[~sg.target_free()].any()  # and none of it where the target cannot stand


CORRIDOR = [(-7.0, 0.5, 7.0, 0.7), (-7.0, -0.7, 7.0, -0.5)]  # a corridor 1 m wide along x


def test_the_target_cannot_get_past_the_camera_unseen():
    # the robot looks down a corridor toward where the target was lost, beyond what its camera can read
    sg = search_grid(grid_with_boxes(CORRIDOR, size_m=16.0))
    belief = TargetBelief.start("target", 0.0, (5.0, 0.0), None, sg, now=0.0, speed_mps=1.0)
    for k in range(1, 81):  # 8 s of looking, 10 looks a second
        belief.look(0.1 * k, camera=(0.0, 0.0), yaw=0.0, hfov=math.radians(70), blocked=sg.occupied)
    assert belief.radius_m > 6.5  # near enough by walking: the reach alone would allow it behind the robot
    assert not belief.possible[sg.cell(-1.5, 0.0)]  # but only through the camera's view
    assert not belief.possible[sg.cell(2.0, 0.0)]  # in view
    assert belief.possible[sg.cell(6.5, 0.0)]  # beyond the view's range it can be


def test_a_target_missed_in_plain_view_is_looked_for_where_the_camera_has_not_looked():
    sg = search_grid(grid_with_boxes([]))
    belief = TargetBelief.start("target", 0.0, (2.0, 0.0), None, sg, now=0.0, speed_mps=1.0)
    for t in (0.1, 0.2, 0.3):  # everywhere it could have walked is in view, and it is not seen
        belief.look(t, camera=(0.0, 0.0), yaw=0.0, hfov=math.radians(70), blocked=sg.occupied)
    belief.grow(2.0)
    assert (belief.possible & ~belief.seen).any()  # not nowhere: somewhere it has not looked


def test_a_place_looked_at_fills_again_once_the_target_could_have_walked_back_into_it():
    sg = search_grid(grid_with_boxes([WALL]))
    belief = TargetBelief.start("target", 0.0, (-1.0, -1.0), None, sg, now=0.0, speed_mps=1.0)
    belief.grow(1.0)
    belief.look(1.0, camera=(-3.0, -1.0), yaw=0.0, hfov=math.radians(30), blocked=sg.occupied)
    looked, aside = sg.cell(-0.2, -1.0), sg.cell(-1.0, -1.8)  # as far from where it was lost; one in the view
    assert not belief.possible[looked]
    belief.grow(4.0)  # no more looks: from either side of the narrow view it can have walked back
    assert belief.possible[looked] and belief.possible[aside]
    w = belief.weights()
    assert 0 < w[looked] < w[aside]  # looked at 3 s ago: worth less than a place as near, never looked at


# ------------------------------------------------------------------------------------ SEARCH b
def test_search_belief_drives_first_to_the_viewpoint_that_sees_most_of_the_belief_per_second():
    # the target went behind the wall at (2, −1); round the north end is 2 m of driving, round the south end 6 m
    grid = grid_with_boxes([WALL])
    scene = Scene(robot=Pose2D(0.0, -1.0, 0.0), grid=grid, clock=2.0)
    lost_at(2.0, -1.0, last_seen=0.0)
    node = SearchBelief(target_speed_mps=0.6)
    assert scene.cycle(node) == S.RUNNING
    goal = read(bbk.NAV_GOAL)
    assert goal is not None and read(bbk.STATE) == "SEARCH"
    assert goal.pose.y > 0.6  # the north end: the south end sees the same place but costs three times the drive
    sg = search_grid(grid)
    assert line_clear(sg.occupied, sg, (goal.pose.x, goal.pose.y), (2.0, -1.0))  # it sees where the target went
    assert node.feedback_message.startswith(
        f"SEARCH b: to ({goal.pose.x:.2f}, {goal.pose.y:.2f}) to look at where it can be"
    )


def test_search_belief_drives_off_from_a_place_its_pose_estimate_puts_inside_a_walls_margin():
    # the robot's pose estimate is 10 cm from the wall the target went behind (AMCL under `typical` is 0.1–0.2 m
    # off): every cell round it is within the robot's clearance of the wall, yet it stands there and can drive
    # off. It goes round the north end, as from a metre back; it swept in place for 24 s instead
    grid = grid_with_boxes([WALL])
    scene = Scene(robot=Pose2D(0.9, -1.0, 0.0), grid=grid, clock=2.0)
    lost_at(2.0, -1.0, last_seen=0.0)
    node = SearchBelief(target_speed_mps=0.6)
    assert scene.cycle(node) == S.RUNNING
    goal = read(bbk.NAV_GOAL)
    assert goal is not None and goal.pose.y > 0.6, node.feedback_message


def test_search_belief_sweeps_from_the_end_of_its_window_where_the_target_most_likely_is():
    # two places it can be, 2 m away at 30° and at 120°, out of the camera's view (it faces south): one large, one
    # small. The sweep starts at the large one's end of the window, whichever that is.
    grid = grid_with_boxes([])
    sg = search_grid(grid)
    xs, ys = sg.centres()

    def patch(deg: float, radius: float) -> np.ndarray:
        a = math.radians(deg)
        return np.hypot(xs - 2.0 * math.cos(a), ys - 2.0 * math.sin(a)) < radius

    for heavy_at, light_at, turns_cw in [(120.0, 30.0, True), (30.0, 120.0, False)]:
        scene = Scene(robot=Pose2D(0.0, 0.0, -math.pi / 2), grid=grid, clock=3.0, navigator=ScriptedNavigator())
        track = lost_at(0.0, 0.0, last_seen=0.0)  # 3 s ago: both are within its reach
        belief = TargetBelief.start("target", 0.0, (0.0, 0.0), None, sg, now=3.0)
        belief.front = patch(heavy_at, 0.6) | patch(light_at, 0.25)
        bbk.set_(board(), bbk.BELIEFS, {track.name: belief})
        node = SearchBelief()
        scene.cycle(node)
        visit = node.hunt.visit
        assert (visit.sweep_rad < 0) == turns_cw
        facing_first = math.degrees(visit.pose.yaw)
        assert abs(facing_first - heavy_at) < abs(facing_first - light_at)


def test_a_sweep_turns_through_its_angle_whichever_way_it_goes():
    for sweep_rad in (-1.2, 1.2):
        grid = grid_with_boxes([])
        sg = search_grid(grid)
        scene = Scene(robot=Pose2D(0.0, 0.0, 0.0), grid=grid, clock=3.0, dt=0.05)
        track = lost_at(0.0, 0.0, last_seen=0.0)
        belief = TargetBelief.start("target", 0.0, (0.0, 0.0), None, sg, now=3.0)
        bbk.set_(board(), bbk.BELIEFS, {track.name: belief})
        node = SearchBelief()
        scene.cycle(node)
        hunt = node.hunt
        hunt.visit = Visit(Pose2D(0.0, 0.0, scene.robot.yaw), sweep_rad, 10.0, 1.0)
        hunt.phase, hunt.sweep_turned, hunt.yaw_prev = "sweep", 0.0, scene.robot.yaw
        swept = 0.0
        while hunt.phase == "sweep" and abs(swept) < 7.0:
            yaw = scene.robot.yaw
            scene.cycle(node)
            swept += math.remainder(scene.robot.yaw - yaw, 2 * math.pi)
        assert swept == pytest.approx(sweep_rad, abs=0.1)


def test_where_it_can_be_weighs_less_behind_it_than_beside_it():
    sg = search_grid(grid_with_boxes([]))
    belief = TargetBelief.start("target", 0.0, (0.0, 0.0), (1.0, 0.0), sg, now=0.5)  # it was walking east
    row, col = sg.cell(-3.0, 0.0)
    behind = belief.prior[row, col]
    row, col = sg.cell(0.0, 3.0)
    beside = belief.prior[row, col]
    assert behind < 0.5 * beside  # the way it came, which the robot followed it along


def test_search_belief_gives_up_with_a_reason_when_its_time_is_up():
    scene = Scene(robot=Pose2D(0.0, -1.0, 0.0), grid=grid_with_boxes([WALL]), clock=2.0, dt=0.5)
    lost_at(2.0, -1.0, last_seen=0.0)
    node = SearchBelief(timeout_s=3.0)
    statuses = [scene.cycle(node) for _ in range(8)]
    assert statuses[-1] == S.FAILURE
    assert read(bbk.REASON).startswith("SEARCH b: target not found in 3 s (searched where it could be for")


# ------------------------------------------------------------------------------------ SEARCH d
def test_give_up_search_fails_with_where_it_was_lost_what_was_tried_and_how_much_was_seen():
    sg = search_grid(grid_with_boxes([WALL]))
    track = lost_at(2.0, -1.0, last_seen=5.0)
    belief = TargetBelief.start("target", track.last_seen, (2.0, -1.0), None, sg, now=5.0)
    belief.log += ["LOST went 2.4 m to look (6 s)", "searched where it could be for 25 s, 4 viewpoint(s)"]
    belief.seen[:, : sg.shape[1] // 2] = True  # the camera has seen half of the map
    bbk.set_(board(), bbk.BELIEFS, {"target": belief})
    w = board()
    bbk.set_(w, bbk.CLOCK, 65.0)
    bbk.set_(w, bbk.ROBOT_STATE, RobotState(Pose2D(0.0, 0.0, 0.0), Twist(), 65.0))
    node = GiveUpSearch()
    assert tick(node) == S.FAILURE
    reason = read(bbk.REASON)
    assert reason.startswith(
        "SEARCH gave up: target not found 60 s after it was last seen at (2.00, -1.00): "
        "LOST went 2.4 m to look (6 s); searched where it could be for 25 s, 4 viewpoint(s); "
        "the camera saw "
    )
    assert reason.endswith("% of where it could have walked — it has left, or hides where this robot cannot look")
    assert read(bbk.STATE) == "FAILED" and read(bbk.TWIST) == Twist(0.0, 0.0)


def test_give_up_search_says_so_when_the_target_was_never_seen():
    bbk.set_(board(), bbk.TRACKS, {})
    bbk.set_(board(), bbk.CLOCK, 1.0)
    node = GiveUpSearch()
    assert tick(node) == S.FAILURE and read(bbk.REASON) == "SEARCH gave up: target was never seen"


# ------------------------------------------------------------------------------------ the baseline
def test_rotate_search_turns_to_plus_and_minus_ninety_degrees_three_times_then_fails():
    scene = Scene(robot=Pose2D(0.0, 0.0, 0.0), dt=0.05)
    lost_at(2.0, 0.0)
    node = RotateSearch()
    yaws = []
    statuses = []
    for _ in range(2000):
        statuses.append(scene.cycle(node))
        yaws.append(scene.robot.yaw)
        if statuses[-1] != S.RUNNING:
            break
    assert statuses[-1] == S.FAILURE
    assert read(bbk.REASON) == "SEARCH (rotate ±90°): target not found after 3 round(s)"
    assert 80 < math.degrees(max(yaws)) < 95 and -95 < math.degrees(min(yaws)) < -80  # ±90° within 0.15 rad
    rates = [b - a for a, b in itertools.pairwise(yaws)]
    assert legs(rates)[:6] == [+1, -1] * 3  # left, right: three rounds about the start heading
