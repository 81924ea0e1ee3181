"""The live node takes a camera that publishes only image_transport's `compressed` topic (JPEG on
`<image_topic>/compressed`, as most robot cameras are recorded and bridged), over real DDS."""

from __future__ import annotations

import json

import numpy as np
import pytest
from sensor_msgs.msg import CameraInfo, CompressedImage
from std_msgs.msg import String

from mission.core import se3
from mission.ros.conversions import array_to_compressed_image, intrinsics_to_camera_info
from mission.ros.messages import RclpyMessages
from tests.helpers.ros_env import TREE_EXE, RosClient, build_ros, clean_shm, installed_env, node_process, wait_for
from tools.synthetic_views import R_FRONTAL, default_intrinsics, render_marker_view

pytestmark = pytest.mark.ros

MSGS = RclpyMessages()
K = default_intrinsics()
T_CAM_MARKER = se3.transform(R_FRONTAL, (0.05, 0.02, 1.2))


def test_a_camera_publishing_only_jpeg_on_the_compressed_topic_is_seen(tmp_path):
    build_ros()
    view = render_marker_view(T_CAM_MARKER, marker_id=7, marker_size_m=0.15, intrinsics=K, rng=np.random.default_rng(2))
    cmd = [str(TREE_EXE), "--ros-args", "-p", "tree:=none", "-p", "marker_size_m:=0.15", "-p", "tick_hz:=30"]
    with node_process(cmd, installed_env(), tmp_path / "node.log") as node:
        client = RosClient("compressed_camera")
        try:
            client.subscribe(String, "/aruco/debug")
            pub = client.node.create_publisher(CompressedImage, "/camera/image_raw/compressed", 10)
            info_pub = client.node.create_publisher(CameraInfo, "/camera/camera_info", 10)
            wait_for(lambda: pub.get_subscription_count() > 0, 30, "the node to subscribe to the compressed topic")

            def observed() -> list[dict]:
                out = [json.loads(m.data) for m in client.messages("/aruco/debug")]
                return [o for o in out if o.get("markers")]

            stamp = 500.0

            def send() -> list[dict]:
                nonlocal stamp
                stamp += 1 / 15
                info_pub.publish(intrinsics_to_camera_info(MSGS, K, stamp, "camera_optical_frame"))
                pub.publish(array_to_compressed_image(MSGS, view.image, "jpeg", stamp, "camera_optical_frame"))
                return observed()

            (first, *_) = wait_for(send, 20, "an observation of the marker from a JPEG frame", 0.07)
            marker = first["markers"][0]
            assert marker["id"] == 7
            assert np.linalg.norm(np.asarray(marker["tvec_m"]) - T_CAM_MARKER[:3, 3]) < 0.02
        except BaseException:
            print(node.log())
            raise
        finally:
            client.close()
    clean_shm()
