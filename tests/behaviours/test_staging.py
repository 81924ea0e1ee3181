"""GoToStaging: navigate to the pose 0.7 m in front of the dock tag, facing it."""

from __future__ import annotations

import math

import py_trees

from mission.behaviours.staging import GoToStaging
from mission.core import blackboard as bbk
from mission.core.config import TargetSpec
from mission.core.types import NavStatus, Pose2D, TargetTrack
from tests.helpers.behaviour_world import Scene, ScriptedNavigator, board, marker_facing, read, tick

S = py_trees.common.Status
DOCK = marker_facing(4.0, 2.0, math.radians(180))  # on a wall at x = 4, facing −x


def staging_tree(scene: Scene, **ports) -> GoToStaging:
    scene.perceive_targets({"dock": TargetSpec(marker_id=0)})
    root = GoToStaging(**ports)
    root.setup_with_descendants()
    return root


def test_it_navigates_to_the_staging_pose_in_front_of_the_tag_and_succeeds_on_arrival():
    scene = Scene(robot=Pose2D(1.0, 1.5, 0.0), marker=DOCK, marker_id=0, navigator=ScriptedNavigator())
    root = staging_tree(scene)
    statuses = [scene.cycle(root) for _ in range(5)]
    assert statuses == [S.RUNNING] * 4 + [S.SUCCESS]  # goal → 3 ticks driving → arrival reported → success
    goal = scene.navigator.goals[0].pose
    assert math.isclose(goal.x, 3.3, abs_tol=1e-9) and math.isclose(goal.y, 2.0, abs_tol=1e-9)
    assert math.isclose(goal.yaw, 0.0, abs_tol=1e-9)
    assert read(bbk.STATE) == "DOCK"
    assert root.feedback_message == "DOCK: at the staging pose (3.30, 2.00, 0°)"


def test_navigation_failure_fails_with_a_reason():
    nav = ScriptedNavigator(unreachable=((3.3, 2.0),))
    scene = Scene(robot=Pose2D(1.0, 1.5, 0.0), marker=DOCK, marker_id=0, navigator=nav)
    root = staging_tree(scene)
    while root.status != S.FAILURE and scene.clock < 2.0:
        scene.cycle(root)
    assert read(bbk.REASON) == "DOCK: navigation to the staging pose (3.30, 2.00, 0°) failed"


def test_a_succeeded_status_left_from_the_previous_goal_is_not_taken_for_this_one():
    track = TargetTrack("dock", last_seen=1.0, pose_map=DOCK)
    w = board()
    bbk.set_(w, bbk.TRACKS, {"dock": track})
    bbk.set_(w, bbk.CLOCK, 5.0)
    bbk.set_(w, bbk.NAV_STATUS, NavStatus.SUCCEEDED)  # what the previous phase's goal ended with
    node = GoToStaging()
    assert tick(node) == S.RUNNING
    bbk.set_(w, bbk.CLOCK, 5.1)  # the navigator has now had the goal for a cycle and reports on it
    assert tick(node) == S.SUCCESS


def test_a_dock_never_seen_fails_at_once_and_a_slow_navigation_times_out():
    bbk.set_(board(), bbk.TRACKS, {})
    bbk.set_(board(), bbk.CLOCK, 0.0)
    assert tick(GoToStaging()) == S.FAILURE
    assert read(bbk.REASON) == "DOCK: dock was never seen, no staging pose"

    scene = Scene(robot=Pose2D(1.0, 1.5, 0.0), marker=DOCK, marker_id=0, dt=1.0)  # no navigator: never arrives
    root = staging_tree(scene, timeout_s=5.0)
    while root.status != S.FAILURE and scene.clock < 10.0:
        scene.cycle(root)
    assert read(bbk.REASON) == "DOCK: staging pose not reached within 5 s"


def test_the_goal_is_refined_when_the_tag_is_re_measured_from_closer():
    far = marker_facing(4.0, 2.0, math.radians(150))  # a far-away, 30° wrong orientation estimate
    track = TargetTrack("dock", last_seen=1.0, pose_map=far)
    track.detection = None
    w = board()
    bbk.set_(w, bbk.TRACKS, {"dock": track})
    bbk.set_(w, bbk.CLOCK, 1.0)
    node = GoToStaging()
    tick(node)
    first = read(bbk.NAV_GOAL)
    scene = Scene(robot=Pose2D(2.5, 2.0, 0.0), marker=DOCK, marker_id=0)  # closer now, correct orientation
    scene.perceive_targets({"dock": TargetSpec(marker_id=0)})
    scene.clock = 2.0
    scene.sense()
    scene.perceive()
    tick(node)
    second = read(bbk.NAV_GOAL)
    assert second.seq > first.seq
    assert math.isclose(second.pose.y, 2.0, abs_tol=1e-9) and "1 refinement" in node.feedback_message


def test_connected_output_ports_carry_the_dock_and_the_last_seen_pose_to_the_blackboard(tmp_path):
    """A tree that wires the outputs gets them; the same leaves in a tree that does not compute nothing for them."""
    from mission.core.docking import floor_pose
    from mission.trees.loader import load_tree

    path = tmp_path / "wired.xml"
    path.write_text("""<root BTCPP_format="4">
  <BehaviorTree ID="Wired">
    <Sequence>
      <IsTargetVisible target="dock" last_seen_pose="{seen}"/>
      <GoToStaging dock_pose="{dock}" staging_pose="{staging}"/>
    </Sequence>
  </BehaviorTree>
</root>
""")
    scene = Scene(robot=Pose2D(1.0, 1.5, 0.0), marker=DOCK, marker_id=0, navigator=ScriptedNavigator())
    scene.perceive_targets({"dock": TargetSpec(marker_id=0)})
    root = load_tree(path)
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup()
    scene.sense()
    scene.perceive()
    tree.tick()
    storage = py_trees.blackboard.Blackboard.storage
    expected = floor_pose(read(bbk.TRACKS)["dock"].pose_map)
    assert storage["/tree/seen"] == expected and storage["/tree/dock"] == expected
    assert storage["/tree/staging"] == read(bbk.NAV_GOAL).pose
    visible, staging = root.children
    assert visible.output_connected("last_seen_pose") and staging.output_connected("dock_pose")
    unwired = GoToStaging()
    assert not unwired.output_connected("dock_pose")
