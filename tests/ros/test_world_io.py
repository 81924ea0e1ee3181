"""The ROS world's shared half against a real blackboard: messages in → blackboard, tree intent → messages.

What the live adapter and replay have in common (mission/ros/world_io.py, sensor_cache.py), plus the
node's marker outputs and transport guard, exercised without DDS: a world whose `emit` keeps what it sent.
"""

from __future__ import annotations

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.types import (
    CameraIntrinsics,
    Detection,
    DockSetpoint,
    NavGoal,
    NavStatus,
    Pose2D,
    RobotState,
    TargetTrack,
    Twist,
)
from mission.ros import dds
from mission.ros.conversions import array_to_image, intrinsics_to_camera_info, state_to_odometry
from mission.ros.marker_outputs import (
    VisibilityEdge,
    current_detection,
    heartbeat_json,
    observation_json,
    tf_child_frames,
)
from mission.ros.messages import BagMessages, stamp_to_sec
from mission.ros.world_io import CachedWorld, RosTopics

pytestmark = pytest.mark.ros

MSGS = BagMessages(get_typestore(Stores.ROS2_JAZZY))
K = CameraIntrinsics(fx=400.0, fy=400.0, cx=160.0, cy=120.0, width=320, height=240)


class RecordingWorld(CachedWorld):
    """CachedWorld with a settable clock whose commands are kept, not published."""

    def __init__(self, **topics) -> None:
        self.warnings: list[str] = []
        super().__init__(RosTopics(**topics), MSGS, warn=self.warnings.append)
        self.clock = 0.0
        self.sent: list[tuple[str, object]] = []

    def setup(self) -> None: ...

    def close(self) -> None: ...

    def now(self) -> float:
        return self.clock

    def emit(self, kind: str, msg: object) -> None:
        self.sent.append((kind, msg))

    def kinds(self) -> list[str]:
        return [k for k, _ in self.sent]


@pytest.fixture
def world():
    return RecordingWorld()


@pytest.fixture
def bb():
    return bbk.writer("test")


def image(stamp: float, frame_id: str = "cam", h: int = 240, w: int = 320):
    return array_to_image(MSGS, np.full((h, w, 3), 128, np.uint8), "bgr8", stamp, frame_id)


def test_a_new_image_becomes_a_frame_once_with_the_camera_info_of_its_stamp(world, bb):
    other = CameraIntrinsics(fx=999.0, fy=999.0, cx=160.0, cy=120.0, width=320, height=240)
    world.cache.on_camera_info(intrinsics_to_camera_info(MSGS, other, 1.0, "cam"))
    world.cache.on_image(image(2.0))
    world.cache.on_camera_info(intrinsics_to_camera_info(MSGS, K, 2.0, "cam"))  # arrives after its image
    world.sense(bb)
    frame = bbk.get(bb, bbk.FRAME)
    assert np.array_equal(frame.intrinsics.matrix, K.matrix) and frame.stamp == 2.0 and frame.frame_id == "cam"
    assert bbk.get(bb, bbk.FRAME_SEQ) == 1
    world.sense(bb)
    assert bbk.get(bb, bbk.FRAME_SEQ) == 1, "no new image, no new frame"


def test_an_image_without_a_frame_id_gets_the_camera_frame(bb):
    world = RecordingWorld(camera_frame="front_camera_optical")
    world.cache.on_image(image(1.0, frame_id=""))
    world.sense(bb)
    assert bbk.get(bb, bbk.FRAME).frame_id == "front_camera_optical"


def test_invalid_camera_info_gives_the_fallback_pinhole_with_a_warning(world, bb):
    info = intrinsics_to_camera_info(MSGS, K, 1.0, "cam")
    info.k[0] = 0.0
    world.cache.on_camera_info(info)
    world.cache.on_image(image(1.0))
    world.sense(bb)
    assert bbk.get(bb, bbk.FRAME).intrinsics == CameraIntrinsics.fallback(320, 240)
    assert world.cache.stats.fallback_intrinsics == 1 and world.cache.stats.dropped == {"camera_info:value": 1}
    assert any("fx=0" in w and "fallback" in w for w in world.warnings)


def test_camera_info_for_another_resolution_is_not_used(world, bb):
    world.cache.on_camera_info(intrinsics_to_camera_info(MSGS, K, 1.0, "cam"))
    world.cache.on_image(image(1.0, h=480, w=640))
    world.sense(bb)
    assert bbk.get(bb, bbk.FRAME).intrinsics == CameraIntrinsics.fallback(640, 480)
    assert (
        "camera info on camera_info: calibrated for 320×240, the image is 640×480; using the fallback"
        in (world.warnings[-1])
    )


def test_bad_images_are_counted_by_reason_and_warned_about_throttled(world):
    for i in range(5):
        bad = image(float(i))
        bad.encoding = "bayer_rggb8"
        assert world.cache.on_image(bad, "/camera/image_raw") is False
    assert world.cache.stats.dropped == {"image:encoding": 5}
    assert len(world.warnings) == 1 and "/camera/image_raw" in world.warnings[0]


def test_depth_is_paired_with_its_image_by_stamp(world, bb):
    depth = np.full((240, 320), 1.5, np.float32)
    world.cache.on_depth(array_to_image(MSGS, depth, "16UC1", 3.0, "cam"))
    world.cache.on_image(image(3.02))
    world.sense(bb)
    assert bbk.get(bb, bbk.FRAME).depth[0, 0] == pytest.approx(1.5)
    world.cache.on_image(image(5.0))
    world.sense(bb)
    assert bbk.get(bb, bbk.FRAME).depth is None, "no depth within the tolerance"


def test_amcl_pose_corrects_odometry_into_the_map_frame(world, bb):
    world.cache.on_odometry(
        state_to_odometry(MSGS, RobotState(Pose2D(1.0, 0.0, 0.0), Twist(0.2, 0.0), 1.0), "odom", "base_link")
    )
    world.sense(bb)
    assert bbk.get(bb, bbk.ROBOT_STATE).pose == Pose2D(1.0, 0.0, 0.0)
    amcl = MSGS.new(
        "geometry_msgs/msg/PoseWithCovarianceStamped",
        header=MSGS.new(
            "std_msgs/msg/Header", stamp=MSGS.new("builtin_interfaces/msg/Time", sec=1, nanosec=0), frame_id="map"
        ),
        pose=MSGS.new(
            "geometry_msgs/msg/PoseWithCovariance",
            pose=MSGS.new(
                "geometry_msgs/msg/Pose",
                position=MSGS.new("geometry_msgs/msg/Point", x=5.0, y=5.0, z=0.0),
                orientation=MSGS.new(
                    "geometry_msgs/msg/Quaternion", x=0.0, y=0.0, z=np.sin(np.pi / 4), w=np.cos(np.pi / 4)
                ),
            ),
            covariance=np.zeros(36),
        ),
    )
    world.cache.on_amcl_pose(amcl)
    # the robot drives 1 m forward in odom; in the map (turned 90°) that is +y
    world.cache.on_odometry(
        state_to_odometry(MSGS, RobotState(Pose2D(2.0, 0.0, 0.0), Twist(0.2, 0.0), 2.0), "odom", "base_link")
    )
    world.sense(bb)
    pose = bbk.get(bb, bbk.ROBOT_STATE).pose
    assert (pose.x, pose.y, pose.yaw) == pytest.approx((5.0, 6.0, np.pi / 2))


def test_each_new_goal_goes_to_goal_pose_once_and_the_current_one_at_10_hz(world, bb):
    bbk.set_(bb, bbk.NAV_GOAL, NavGoal(Pose2D(3.0, 1.0, 0.5), stamp=0.0, seq=1))
    for i in range(30):  # 1 s of ticks at 30 Hz
        world.clock = i / 30.0
        world.act(bb)
    assert world.kinds().count("goal") == 1
    assert 9 <= world.kinds().count("target_goal") <= 11
    goal_msg = next(m for k, m in world.sent if k == "goal")
    assert goal_msg.header.frame_id == "map" and goal_msg.pose.position.x == 3.0
    bbk.set_(bb, bbk.NAV_GOAL, NavGoal(Pose2D(4.0, 1.0, 0.5), stamp=1.0, seq=2))
    world.act(bb)
    assert world.kinds().count("goal") == 2


def test_nav_status_is_running_until_the_robot_is_within_tolerance_of_the_goal(world, bb):
    bbk.set_(bb, bbk.NAV_GOAL, NavGoal(Pose2D(2.0, 0.0, 0.0), stamp=0.0, seq=1))
    world.act(bb)
    for x, expected in ((0.0, NavStatus.RUNNING), (1.9, NavStatus.SUCCEEDED)):
        world.cache.on_odometry(state_to_odometry(MSGS, RobotState(Pose2D(x, 0.0, 0.0), Twist(), 1.0), "odom", "b"))
        world.sense(bb)
        assert bbk.get(bb, bbk.NAV_STATUS) == expected


def test_a_twist_is_sent_every_tick_and_one_stop_when_the_tree_lets_go(world, bb):
    bbk.set_(bb, bbk.TWIST, Twist(0.0, 0.4))
    world.act(bb)
    world.act(bb)
    bbk.set_(bb, bbk.TWIST, None)
    world.act(bb)
    world.act(bb)
    sent = [(m.linear.x, m.angular.z) for k, m in world.sent if k == "cmd_vel"]
    assert sent == [(0.0, 0.4), (0.0, 0.4), (0.0, 0.0)]


def test_a_dock_setpoint_is_sent_once_per_new_stamp_in_the_camera_frame(world, bb):
    sp = DockSetpoint(pose_camera=((0.1, 0.0, 0.8), (1.0, 0.0, 0.0, 0.0)), stamp=4.0)
    bbk.set_(bb, bbk.DOCK_SETPOINT, sp)
    world.act(bb)
    world.act(bb)
    docks = [m for k, m in world.sent if k == "dock"]
    assert len(docks) == 1 and docks[0].header.frame_id == "camera_optical_frame"
    assert docks[0].pose.position.z == 0.8 and stamp_to_sec(docks[0].header.stamp) == 4.0


# -- what the node says about markers -----------------------------------------------------------------


def det(marker_id: int | None, label: str | None = None, z: float = 1.0) -> Detection:
    q = se3.matrix_to_quat(se3.rot_x(np.pi))
    return Detection("aruco", marker_id, label, None, np.array([0.0, 0.0, z]), q, 0.9, 0.1, 1.0, "cam")


def test_visibility_is_reported_on_transitions_only():
    edge = VisibilityEdge()
    assert [edge.update(v) for v in (False, True, True, True, False, False, True)] == [
        None, True, None, None, False, None, True,
    ]  # fmt: skip


def test_tf_children_are_the_marker_id_and_the_attributed_name():
    assert tf_child_frames(det(21)) == ["aruco_marker_21"]
    assert tf_child_frames(det(3, "Charging Dock #2")) == ["aruco_marker_3", "charging_dock_2"]
    assert tf_child_frames(det(None, "red cube")) == ["red_cube"]


def test_the_debug_observation_has_ids_tvec_and_rvec():
    obs = observation_json("cam", 1.5, [det(7, z=2.0)])
    assert obs["frame_id"] == "cam" and obs["ids"] == [7]
    m = obs["markers"][0]
    assert m["tvec_m"] == [0.0, 0.0, 2.0] and np.allclose(np.abs(m["rvec_rad"]), [np.pi, 0, 0], atol=1e-4)
    assert heartbeat_json("mission_tree", {"frames_dropped": 2}) == {
        "status": "running",
        "node": "mission_tree",
        "frames_dropped": 2,
    }


def test_the_target_pose_is_the_target_tracks_detection_in_this_frame_only():
    d = det(7)
    tracks = {"target": TargetTrack("target", visible=True, last_seen=1.0, misses=0, detection=d)}
    assert current_detection(tracks, "target", 1.0) is d
    assert current_detection(tracks, "target", 2.0) is None
    assert current_detection(tracks, "dock", 1.0) is None


# -- the transport guard ------------------------------------------------------------------------------


def test_without_a_profile_the_node_uses_shared_memory_only():
    env: dict[str, str] = {}
    notes = dds.configure_transport(env)
    assert env["FASTRTPS_DEFAULT_PROFILES_FILE"] == str(dds.PACKAGE_PROFILE) and "shared memory only" in notes[0]


def test_localhost_discovery_range_is_replaced_because_it_adds_udp_on_every_interface():
    env = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    notes = dds.configure_transport(env)
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SYSTEM_DEFAULT" and "UDP" in notes[-1]


def test_an_operators_own_profile_and_rmw_are_left_alone(tmp_path):
    own = tmp_path / "robot.xml"
    own.write_text("<profiles/>")
    env = {"FASTRTPS_DEFAULT_PROFILES_FILE": str(own), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    assert dds.configure_transport(env) == [] and env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    env = {"RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp"}
    dds.configure_transport(env)
    assert "FASTRTPS_DEFAULT_PROFILES_FILE" not in env
