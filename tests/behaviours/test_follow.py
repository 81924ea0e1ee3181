"""FollowTarget: the goal generator — offset goal behind the target, smoothed, rate-limited."""

from __future__ import annotations

import math

import numpy as np
import py_trees

from mission.behaviours.follow import FollowTarget
from mission.core import blackboard as bbk
from mission.core.config import TargetSpec
from mission.core.types import NavGoal, Pose2D, Twist
from tests.helpers.behaviour_world import Scene, board, marker_facing, read, tick

S = py_trees.common.Status


def follow_tree(scene: Scene, **ports) -> FollowTarget:
    scene.perceive_targets({"target": TargetSpec(marker_id=7)})
    root = FollowTarget(**ports)
    root.setup_with_descendants()
    return root


def test_the_goal_is_offset_before_the_target_on_the_robot_side_facing_it():
    scene = Scene(robot=Pose2D(1.0, 1.0, math.radians(45)), marker=marker_facing(3.0, 3.0, math.radians(-135)))
    root = follow_tree(scene)
    assert scene.cycle(root) == S.RUNNING
    goal: NavGoal = read(bbk.NAV_GOAL)
    d = 0.5 / math.sqrt(2)
    assert math.isclose(goal.pose.x, 3.0 - d, abs_tol=1e-9) and math.isclose(goal.pose.y, 3.0 - d, abs_tol=1e-9)
    assert math.isclose(goal.pose.yaw, math.radians(45), abs_tol=1e-9)
    assert read(bbk.TWIST) is None and read(bbk.STATE) == "FOLLOW"
    follow = root
    assert follow.feedback_message == f"following target 2.8 m away, goal (2.65, 2.65) seq {goal.seq}"


def test_goals_are_sent_at_most_at_rate_hz_with_increasing_seq():
    scene = Scene(marker=marker_facing(3.0, 0.0, math.pi), dt=1.0 / 30.0)
    root = follow_tree(scene, rate_hz=10.0)
    seqs, stamps = [], []
    for _ in range(60):  # 2 s at 30 Hz
        scene.cycle(root)
        goal = read(bbk.NAV_GOAL)
        if not seqs or goal.seq != seqs[-1]:
            seqs.append(goal.seq)
            stamps.append(goal.stamp)
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)
    assert 19 <= len(seqs) <= 21
    assert min(np.diff(stamps)) >= 0.1 - 1e-6


def test_goal_jitter_stays_under_20_cm_while_the_target_stands_still_under_noisy_detections():
    scene = Scene(marker=marker_facing(3.0, 0.5, math.pi), noise_m=0.08, noise_rad=0.05, rng=np.random.default_rng(42))
    root = follow_tree(scene, window=5)
    goals, raw = {}, []
    for _ in range(150):  # 10 s at 15 Hz
        scene.cycle(root)
        goal = read(bbk.NAV_GOAL)
        goals[goal.seq] = (goal.pose.x, goal.pose.y)
        tr = read(bbk.TRACKS)["target"]
        raw.append(tr.pose_map[:2, 3].copy())
    xy = np.array(list(goals.values()))
    jitter = float(np.sqrt(xy.var(axis=0).sum()))  # s.d. of the goal position (radial)
    raw_jitter = float(np.sqrt(np.array(raw).var(axis=0).sum()))
    assert jitter < 0.2
    assert jitter < 0.6 * raw_jitter  # the moving average is doing the work
    expected = np.array([3.0, 0.5]) * (1.0 - 0.5 / math.hypot(3.0, 0.5))  # 0.5 m short, on the robot's side
    assert np.allclose(xy.mean(axis=0), expected, atol=0.05)


def test_preempted_follow_stops_the_robot_only_if_its_goal_is_still_the_command():
    scene = Scene(marker=marker_facing(3.0, 0.0, math.pi))
    root = follow_tree(scene)
    scene.cycle(root)
    follow = root
    follow.stop(S.INVALID)  # what a parent does when another branch takes over
    assert read(bbk.NAV_GOAL) is None and read(bbk.TWIST) == Twist(0.0, 0.0)

    scene.cycle(root)
    bbk.set_(board(), bbk.TWIST, Twist(0.0, 0.6))  # another leaf already took over this tick
    bbk.set_(board(), bbk.NAV_GOAL, None)
    follow.stop(S.INVALID)
    assert read(bbk.TWIST) == Twist(0.0, 0.6)


def test_without_a_map_position_it_waits_and_holds_the_robot():
    scene = Scene(marker=None)
    root = follow_tree(scene)
    scene.cycle(root)
    follow = root
    assert follow.status == S.RUNNING and follow.feedback_message == "waiting for target's map position"
    assert read(bbk.TWIST) == Twist(0.0, 0.0)
    assert tick(follow) == S.RUNNING


def near_target_scene(distance: float, bearing_deg: float, robot_yaw_deg: float) -> Scene:
    """A marker `distance` from the camera at `bearing_deg` from the x axis, facing it; the robot at the origin."""
    b = math.radians(bearing_deg)
    x, y = 0.15 + distance * math.cos(b), distance * math.sin(b)
    return Scene(robot=Pose2D(0.0, 0.0, math.radians(robot_yaw_deg)), marker=marker_facing(x, y, b + math.pi))


def test_a_near_target_lost_off_the_images_side_is_faced_by_a_turn_on_the_spot_then_followed_again():
    scene = near_target_scene(0.9, 40.0, robot_yaw_deg=40.0)
    root = follow_tree(scene, face_range_m=1.2)
    scene.cycle(root)  # seen straight ahead
    assert read(bbk.NAV_GOAL) is not None
    scene.robot = Pose2D(0.0, 0.0, 0.0)  # the path's bend turned the robot: the target is 40° left, off the image
    scene.cycle(root)
    twist = read(bbk.TWIST)
    assert twist is not None and twist.v == 0.0 and twist.w > 0.0 and read(bbk.NAV_GOAL) is None
    assert root.feedback_message.startswith("turning to face target: 40° to the left")
    for _ in range(15):
        scene.cycle(root)
        if read(bbk.NAV_GOAL) is not None:
            break
    assert read(bbk.NAV_GOAL) is not None and read(bbk.TWIST) is None  # seen again: following, by goals
    assert 0.0 < scene.robot.yaw < math.radians(10.0)


def test_without_face_range_m_a_near_target_off_the_image_is_followed_by_goals_as_before():
    scene = near_target_scene(0.9, 40.0, robot_yaw_deg=40.0)
    root = follow_tree(scene)
    scene.cycle(root)
    scene.robot = Pose2D(0.0, 0.0, 0.0)
    scene.cycle(root)
    scene.cycle(root)
    assert read(bbk.NAV_GOAL) is not None and read(bbk.TWIST) is None


def test_a_target_off_the_image_farther_than_face_range_is_left_to_the_navigators_path():
    scene = near_target_scene(2.0, 40.0, robot_yaw_deg=40.0)
    root = follow_tree(scene, face_range_m=1.2)
    scene.cycle(root)
    scene.robot = Pose2D(0.0, 0.0, 0.0)
    scene.cycle(root)
    scene.cycle(root)
    assert read(bbk.NAV_GOAL) is not None and read(bbk.TWIST) is None
    assert root.feedback_message.startswith("following target 2.1 m away")  # from the base, 15 cm behind the camera


def test_a_near_target_seen_at_the_images_side_is_followed_without_a_turn():
    scene = near_target_scene(0.9, 32.0, robot_yaw_deg=0.0)  # inside the 35° half-view, near its side
    root = follow_tree(scene, face_range_m=1.2)
    for _ in range(3):
        scene.cycle(root)
        assert read(bbk.NAV_GOAL) is not None and read(bbk.TWIST) is None
