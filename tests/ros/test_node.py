"""The colcon-installed node (`install/mission/lib/mission/tree`, what `ros2 run mission tree` runs) over real
DDS between processes: shared-memory transport, private domain. A client in the test process plays the
camera (rendered marker views with known pose + camera info) and listens to what the node publishes."""

from __future__ import annotations

import json
import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from geometry_msgs.msg import PoseArray, PoseStamped
from std_msgs.msg import Bool, String

from mission.core import se3
from mission.ros.conversions import array_to_image, intrinsics_to_camera_info
from mission.ros.messages import RclpyMessages
from mission.ros.tf_support import load_tf_message
from tests.helpers.ros_env import (
    PROFILE,
    TREE_EXE,
    FakeCamera,
    RosClient,
    build_ros,
    clean_shm,
    inet_sockets,
    installed_env,
    node_process,
    wait_for,
)
from tools.synthetic_views import R_FRONTAL, default_intrinsics, render_marker_view

pytestmark = pytest.mark.ros

MARKER_ID = 7
MARKER_SIZE = 0.15
T_CAM_MARKER = se3.transform(R_FRONTAL @ se3.rot_y(0.3), (0.12, -0.06, 1.6))  # 1.6 m ahead, turned 17°
MSGS = RclpyMessages()
K = default_intrinsics()
FRAME = "camera_optical_frame"


def _views() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(5)
    marker = render_marker_view(T_CAM_MARKER, marker_id=MARKER_ID, marker_size_m=MARKER_SIZE, intrinsics=K, rng=rng)
    far = se3.transform(R_FRONTAL, (30.0, 0.0, 2.0))  # outside the field of view: background only
    empty = render_marker_view(far, marker_id=MARKER_ID, marker_size_m=MARKER_SIZE, intrinsics=K, rng=rng)
    return {"marker": marker.image, "empty": empty.image}


VIEWS = _views()
TRUE_DISTANCE = float(np.linalg.norm(T_CAM_MARKER[:3, 3]))


def scene(view: str, *, encoding: str = "bgr8", step_short: bool = False, fx: float | None = None):
    """A scene for the FakeCamera: the named view, optionally broken on purpose."""

    def make(stamp: float):
        img = array_to_image(MSGS, VIEWS[view], "bgr8", stamp, FRAME)
        if encoding != "bgr8":
            img.encoding = encoding
        if step_short:
            img.step = img.step - 3  # a row is 1920 bytes but step says 1917: a size/step mismatch
        info = intrinsics_to_camera_info(MSGS, K, stamp, FRAME)
        if fx is not None:
            k = np.asarray(info.k).copy()
            k[0] = fx
            info.k = k
        return img, info

    return make


@pytest.fixture(scope="module")
def ros(tmp_path_factory):
    """The installed node in perception-only mode + a client with a fake camera and subscriptions."""
    build_ros()
    log = tmp_path_factory.mktemp("node") / "node.log"
    cmd = [
        str(TREE_EXE),
        "--ros-args",
        "-p",
        "tree:=none",
        "-p",
        f"marker_size_m:={MARKER_SIZE}",
        "-p",
        f"target_marker_id:={MARKER_ID}",
        "-p",
        "tick_hz:=30",
    ]
    tf = load_tf_message()
    assert tf.message is not None, tf.detail
    with node_process(cmd, installed_env(), log) as node:
        client = RosClient()
        for topic, msg_type in (
            ("/marker_detected", Bool),
            ("/aruco/debug", String),
            ("/detected_aruco_pose", PoseStamped),
            ("/aruco_poses", PoseArray),
            ("/tf", tf.message),
        ):
            client.subscribe(msg_type, topic)
        camera = FakeCamera(client)
        try:
            camera.wait_for_subscriber()
            camera.scene = scene("empty")  # the camera runs; the node has its calibration before any marker
            wait_for(lambda: last_heartbeat(client).get("received", {}).get("camera_info", 0) > 0, 10, "camera info")
            yield node, client, camera
        except BaseException:
            print(node.log())
            raise
        finally:
            camera.scene = None
            client.close()
    clean_shm()


def debug_messages(client: RosClient) -> tuple[list[dict], list[tuple[float, dict]]]:
    """(/aruco/debug observations, timed heartbeats)."""
    obs, beats = [], []
    for t, msg in client.timed("/aruco/debug"):
        d = json.loads(msg.data)
        if d.get("status") == "running":
            beats.append((t, d))
        else:
            obs.append(d)
    return obs, beats


def last_heartbeat(client: RosClient) -> dict:
    beats = debug_messages(client)[1]
    return beats[-1][1] if beats else {}


def marker_flags(client: RosClient) -> list[bool]:
    return [m.data for m in client.messages("/marker_detected")]


def test_marker_detected_is_edge_triggered_and_the_pose_is_within_2_percent(ros):
    _node, client, camera = ros
    assert marker_flags(client) == []

    camera.scene = scene("marker")
    wait_for(lambda: len(debug_messages(client)[0]) >= 12, 20, "12 observations of the marker on /aruco/debug")
    assert marker_flags(client) == [True], "true exactly once while the marker stays in view"

    obs = debug_messages(client)[0][-1]
    assert obs["frame_id"] == FRAME and obs["ids"] == [MARKER_ID]
    assert np.allclose(obs["markers"][0]["tvec_m"], T_CAM_MARKER[:3, 3], atol=0.03)
    assert len(obs["markers"][0]["rvec_rad"]) == 3

    poses = client.messages("/detected_aruco_pose")
    assert len(poses) >= 10
    for p in poses:
        d = np.linalg.norm([p.pose.position.x, p.pose.position.y, p.pose.position.z])
        assert abs(d - TRUE_DISTANCE) / TRUE_DISTANCE < 0.02, f"distance {d:.4f} m vs true {TRUE_DISTANCE:.4f} m"
        assert p.header.frame_id == FRAME
    assert client.messages("/aruco_poses")[-1].header.frame_id == FRAME

    assert last_heartbeat(client)["fallback_intrinsics"] == 0, "the poses used the published camera info"

    tf_msgs = client.messages("/tf")
    frames = {(t.header.frame_id, t.child_frame_id) for m in tf_msgs for t in m.transforms}
    assert (FRAME, f"aruco_marker_{MARKER_ID}") in frames
    tr = tf_msgs[-1].transforms[0].transform.translation
    assert np.allclose([tr.x, tr.y, tr.z], T_CAM_MARKER[:3, 3], atol=0.03)

    camera.scene = scene("empty")
    wait_for(lambda: marker_flags(client) == [True, False], 10, "/marker_detected false after the marker left")
    processed_at_false = wait_for(lambda: last_heartbeat(client).get("frames_processed"), 5, "a heartbeat")
    wait_for(
        lambda: last_heartbeat(client).get("frames_processed", 0) >= processed_at_false + 15,
        10,
        "15 more frames without the marker",
    )
    assert marker_flags(client) == [True, False], "false exactly once while the marker stays away"


def test_heartbeat_every_second_with_counters(ros):
    _node, client, _camera = ros
    n0 = len(debug_messages(client)[1])
    wait_for(lambda: len(debug_messages(client)[1]) >= n0 + 3, 6, "three more heartbeats")
    beats = debug_messages(client)[1]
    gaps = np.diff([t for t, _ in beats])
    assert np.all((gaps > 0.7) & (gaps < 1.4)), f"heartbeat gaps {gaps.round(2).tolist()} s"
    hb = beats[-1][1]
    assert hb["status"] == "running" and hb["node"] == "mission_tree"
    assert {"frames_received", "frames_processed", "frames_dropped", "dropped"} <= set(hb)


@pytest.mark.parametrize(
    ("broken", "counter", "words"),
    [
        ({"encoding": "yuv422"}, "image:encoding", "unsupported encoding 'yuv422'"),
        ({"step_short": True}, "image:size", "step 1917 < width×bytes per pixel = 1920"),
    ],
)
def test_a_bad_image_is_dropped_and_counted_and_the_node_keeps_answering(ros, broken, counter, words):
    node, client, camera = ros
    camera.scene = scene("marker", **broken)
    dropped = lambda: last_heartbeat(client).get("dropped", {}).get(counter, 0)  # noqa: E731
    wait_for(lambda: dropped() >= 5, 10, f"5 drops counted as {counter}")
    assert node.alive()
    assert words in node.log() and "/camera/image_raw" in node.log()

    n_obs = len(debug_messages(client)[0])
    camera.scene = scene("marker")
    wait_for(lambda: len(debug_messages(client)[0]) >= n_obs + 3, 10, "observations again after good frames")
    camera.scene = scene("empty")
    wait_for(lambda: marker_flags(client)[-1] is False, 10, "/marker_detected back to false")


def test_invalid_camera_info_warns_and_uses_the_fallback_intrinsics(ros):
    node, client, camera = ros
    before = last_heartbeat(client).get("fallback_intrinsics", 0)
    n_obs = len(debug_messages(client)[0])
    camera.scene = scene("marker", fx=0.0)
    wait_for(lambda: last_heartbeat(client).get("fallback_intrinsics", 0) >= before + 5, 10, "fallback intrinsics")
    wait_for(lambda: len(debug_messages(client)[0]) > n_obs, 10, "detections with the fallback pinhole")
    assert "invalid camera info on /camera/camera_info" in node.log() and "fallback" in node.log()
    camera.scene = scene("empty")
    wait_for(lambda: marker_flags(client)[-1] is False, 10, "/marker_detected back to false")


def test_nothing_is_sent_beyond_loopback(ros):
    """Network rule: the profile has builtin transports off and one SHM transport; the node process holds
    not a single UDP/TCP socket (nothing can go out on any interface, not even loopback), and nothing in
    the client process is bound beyond loopback."""
    node, client, _camera = ros
    ns = {"d": "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"}
    root = ET.parse(PROFILE).getroot()
    participant = root.find("d:participant", ns)
    assert participant.get("is_default_profile") == "true"
    assert participant.findtext("d:rtps/d:useBuiltinTransports", namespaces=ns) == "false"
    used = [e.text for e in participant.findall("d:rtps/d:userTransports/d:transport_id", ns)]
    types = {
        d.findtext("d:transport_id", namespaces=ns): d.findtext("d:type", namespaces=ns)
        for d in root.findall("d:transport_descriptors/d:transport_descriptor", ns)
    }
    assert [types[t] for t in used] == ["SHM"]
    shm = root.find("d:transport_descriptors/d:transport_descriptor", ns)
    assert int(shm.findtext("d:segment_size", namespaces=ns)) >= 16 * 2**20 > 640 * 480 * 3

    assert last_heartbeat(client)["frames_received"] > 0, "DDS traffic did flow"
    assert inet_sockets(node.pid) == [], "the node process holds UDP/TCP sockets"
    # the test process may hold other loopback sockets (not DDS's): none may be bound beyond loopback
    client_sockets = inet_sockets(os.getpid())
    assert all(addr.startswith(("127.", "[::1]")) for _, addr in client_sockets), client_sockets
