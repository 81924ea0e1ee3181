"""A followed object's poses from someone else (a FollowObject goal's pose_topic or tracked_frame): placed in
the map by TF at their own stamps, handed to perception on the next camera frame, and made detections by the
external_pose source that land where the poses said. Without DDS: the ROS world's shared half, fed messages."""

from __future__ import annotations

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.types import CameraIntrinsics, Pose2D, RobotState, Twist
from mission.perception_plugins.external_pose import ExternalPoseSource
from mission.ros.conversions import array_to_image, intrinsics_to_camera_info, pose_stamped, state_to_odometry
from mission.ros.external_poses import ExternalPoses
from mission.ros.messages import BagMessages
from mission.ros.world_io import CachedWorld, RosTopics

pytestmark = pytest.mark.ros

MSGS = BagMessages(get_typestore(Stores.ROS2_JAZZY))
K = CameraIntrinsics(fx=400.0, fy=400.0, cx=160.0, cy=120.0, width=320, height=240)


class World(CachedWorld):
    def __init__(self) -> None:
        super().__init__(RosTopics(), MSGS)
        self.clock = 2.0

    def now(self) -> float:
        return self.clock

    def emit(self, kind: str, msg: object) -> None: ...


@pytest.fixture
def world():
    w = World()
    w.external = ExternalPoses(node=None, pose_type=object, qos=None)
    w.external.origin = "/person_pose"
    # the robot at (1, 0) facing +y, from odometry (no map → odom: odometry is the map)
    w.cache.on_odometry(
        state_to_odometry(MSGS, RobotState(Pose2D(1.0, 0.0, np.pi / 2), Twist(), 2.0), "odom", "base_link")
    )
    w._feed_odometry()
    return w


def camera_frame(world: World, bb, stamp: float = 2.0):
    world.cache.on_camera_info(intrinsics_to_camera_info(MSGS, K, stamp, "cam"), "/camera/camera_info")
    world.cache.on_image(array_to_image(MSGS, np.zeros((240, 320, 3), np.uint8), "bgr8", stamp, "cam"), "/camera")
    world.sense(bb)
    return bbk.get(bb, bbk.FRAME)


def test_poses_in_any_tf_frame_reach_the_next_camera_frame_in_the_map(world):
    ext = world.external
    ext._on_pose(pose_stamped(MSGS, se3.planar(3.0, 1.0, 0.0), 2.0, "odom"))
    ext._on_pose(pose_stamped(MSGS, se3.planar(2.0, 0.0, 0.0), 2.0, "base_link"))  # 2 m ahead of the robot
    frame = camera_frame(world, bbk.writer("test"))
    placed = [tuple(np.round(s.T_anchor_object[:2, 3], 6)) for s in frame.sightings]
    assert placed == [(3.0, 1.0), (1.0, 2.0)]
    assert {s.origin for s in frame.sightings} == {"/person_pose"}
    assert camera_frame(world, bbk.writer("test"), 2.1).sightings == ()  # each pose is handed over once


def test_a_pose_tf_cannot_place_is_dropped_and_the_reason_kept(world):
    world.external._on_pose(pose_stamped(MSGS, se3.planar(1.0, 1.0, 0.0), 2.0, "lidar_9"))
    frame = camera_frame(world, bbk.writer("test"))
    assert frame.sightings == ()
    assert "cannot place the pose from /person_pose (frame 'lidar_9')" in world.external.error
    assert world.external.last_placed is None


def test_the_external_pose_source_makes_detections_that_land_where_the_poses_said(world):
    world.external._on_pose(pose_stamped(MSGS, se3.planar(3.0, 1.0, 0.0), 2.0, "odom"))
    frame = camera_frame(world, bbk.writer("test"))
    source = ExternalPoseSource({"label": "person"})
    (det,) = source.process(frame)
    assert det.label == "person" and det.marker_id is None and det.extra["origin"] == "/person_pose"
    back = np.asarray(frame.T_anchor_camera) @ np.append(det.position, 1.0)
    assert back[:2] == pytest.approx([3.0, 1.0])


def test_a_frame_that_does_not_know_where_the_camera_was_cannot_place_them():
    from mission.core.types import Frame, Sighting

    frame = Frame(np.zeros((4, 4, 3), np.uint8), 1.0, sightings=(Sighting(1.0, np.eye(4), "/p"),))
    source = ExternalPoseSource({})
    assert source.process(frame) == [] and source.unplaced == 1
