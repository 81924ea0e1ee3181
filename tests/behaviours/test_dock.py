"""VisualServoDock, closed loop: a kinematic base driven by the leaf's TWIST, detections synthesised from geometry."""

from __future__ import annotations

import math

import numpy as np
import py_trees
import pytest

from mission.behaviours.dock import FloorTagFilter, VisualServoDock
from mission.core import blackboard as bbk
from mission.core.config import TargetSpec
from mission.core.docking import dock_offsets
from mission.core.types import DockSetpoint, Pose2D, Twist
from tests.helpers.behaviour_world import Scene, camera_in_map, marker_facing, read

S = py_trees.common.Status
TAG = marker_facing(2.0, 0.0, math.pi)  # dock tag on a wall at x = 2, facing −x


def dock_tree(scene: Scene, **ports) -> VisualServoDock:
    scene.perceive_targets({"dock": TargetSpec(marker_id=0)})
    root = VisualServoDock(**ports)
    root.setup_with_descendants()
    return root


def run(scene: Scene, root: py_trees.behaviour.Behaviour, until: float = 40.0) -> None:
    while root.status not in (S.SUCCESS, S.FAILURE) and scene.clock < until:
        scene.cycle(root)


@pytest.mark.parametrize(
    ("x", "y", "yaw_deg"),
    [
        (1.30, 0.00, 0),  # at the staging pose (0.7 m), square
        (1.30, 0.15, 0),  # 15 cm to the side: needs to back off and come in again
        (1.30, -0.12, 15),
        (1.10, 0.10, -15),
        (1.40, 0.05, 20),
        (1.20, -0.20, 10),
    ],
)
def test_docks_within_tolerance_from_offset_starts(x: float, y: float, yaw_deg: float):
    scene = Scene(
        robot=Pose2D(x, y, math.radians(yaw_deg)),
        marker=TAG,
        marker_id=0,
        noise_m=0.002,
        noise_rad=math.radians(1.0),
        rng=np.random.default_rng(7),
    )
    root = dock_tree(scene)
    run(scene, root)
    assert root.status == S.SUCCESS, root.feedback_message
    truth = dock_offsets(camera_in_map(scene.robot), TAG, scene.robot.yaw)
    assert abs(truth.standoff_m - 0.30) <= 0.025
    assert abs(truth.lateral_m) <= 0.03
    assert abs(truth.skew_deg) <= 10.0
    assert read(bbk.TWIST) == Twist(0.0, 0.0) and read(bbk.NAV_GOAL) is None
    assert read(bbk.REASON).startswith("DOCK: docked: lateral")
    assert isinstance(read(bbk.DOCK_SETPOINT), DockSetpoint)
    assert read(bbk.STATE) == "DOCK"


def test_fails_with_a_reason_when_the_tag_is_unseen_for_longer_than_the_detection_timeout():
    scene = Scene(robot=Pose2D(1.2, 0.1, 0.0), marker=TAG, marker_id=0)
    root = dock_tree(scene)
    for _ in range(8):
        scene.cycle(root)
    hidden_at = scene.clock
    scene.hidden = True  # someone stands in front of the dock
    run(scene, root)
    assert root.status == S.FAILURE
    assert 1.0 < scene.clock - hidden_at < 1.2
    reason = read(bbk.REASON)
    assert reason.startswith("DOCK: dock tag unseen for 1.1 s (> 1.0 s) at stand-off")
    assert read(bbk.TWIST) == Twist(0.0, 0.0)


def test_fails_at_timeout_with_where_it_got_to():
    scene = Scene(robot=Pose2D(1.2, 0.0, 0.0), marker=TAG, marker_id=0)
    root = dock_tree(scene, timeout_s=0.5)
    run(scene, root)
    assert root.status == S.FAILURE
    assert read(bbk.REASON).startswith("DOCK: not docked within 0.5 s at stand-off")


def test_the_tag_filter_ignores_a_pose_flip_but_follows_a_lasting_change():
    f = FloorTagFilter(alpha=0.5, gate_rad=math.radians(25), reset_after=3)
    f.update(marker_facing(2.0, 0.0, math.pi))
    assert not f.update(marker_facing(2.0, 0.0, math.pi - math.radians(35)))  # one flipped frame
    assert math.isclose(abs(f.heading), math.pi, abs_tol=1e-9)
    assert f.update(marker_facing(2.0, 0.0, math.pi - math.radians(4)))
    for _ in range(2):
        f.update(marker_facing(2.0, 0.0, math.pi / 2))
    assert f.update(marker_facing(2.0, 0.0, math.pi / 2))  # third in a row: the tag really is that way
    assert math.isclose(f.heading, math.pi / 2, abs_tol=1e-9)
