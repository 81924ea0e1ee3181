"""The ROS 2 world adapter: live topics in, Nav2-style commands out (rclpy).

Subscriptions only cache (the :class:`~mission.ros.sensor_cache.SensorCache` converts, counts and
pairs); ``sense()`` and ``act()`` are :class:`~mission.ros.world_io.CachedWorld`'s, shared with replay,
so a bag and a robot reach the tree through the same code.

QoS: camera, depth, camera info, odometry and scan use the sensor-data profile (best effort, as
drivers publish; it also accepts reliable publishers); ``/map`` is reliable and transient-local (the
map server latches it); ``/tf`` is reliable (depth 100) and ``/tf_static`` transient-local, as tf2's
listeners; commands are reliable.

``/tf`` and ``/tf_static`` feed the TF buffer (mission/ros/frames.py); ``navigator`` chooses how goals
leave: ``action`` (Nav2's navigate_to_pose, mission/ros/nav_client.py) or ``topic`` (/goal_pose).
``on_image`` (set by the node) is called after each usable image is cached: perception on arrival.

Images are also taken from ``<image_topic>/compressed`` (sensor_msgs/CompressedImage), where
image_transport's ``compressed`` plugin publishes them; a camera that publishes both gives one frame per
stamp (the cache skips the second copy).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

from mission.ros.conversions import BadMessage, transform_to_matrix
from mission.ros.messages import RclpyMessages, stamp_to_sec
from mission.ros.world_io import CachedWorld, RosTopics

RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
TF_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
TF_STATIC_QOS = QoSProfile(
    depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)


class RosAdapter(CachedWorld):
    """WorldAdapter over rclpy topics. Construct with a node (light); ``setup()`` creates the endpoints."""

    def __init__(
        self,
        node: Node,
        topics: RosTopics | None = None,
        *,
        tf_message: type | None = None,
        navigation: Callable[[], Any] | None = None,
    ) -> None:
        self.msgs: RclpyMessages
        log = node.get_logger()
        super().__init__(topics or RosTopics(), RclpyMessages(), warn=log.warning, say=log.info)
        self.node = node
        self.tf_message = tf_message
        self._make_navigation = navigation  # None: /goal_pose (TopicNavigation)
        self._subs: list[Any] = []
        self.publishers: dict[str, Any] = {}
        self.on_image: Callable[[], None] | None = None
        self.last_input: dict[str, float] = {}  # kind → monotonic time of the last message (the watchdog)
        self._inputs_alive = False  # a camera image and the robot's pose have arrived (waiting_for)
        self.say = log.info

    def _image(self, msg: Any, topic: str) -> None:
        self.last_input["image"] = time.monotonic()
        if self.cache.on_image(msg, topic) and self.on_image is not None:
            self.on_image()

    def _odometry(self, msg: Any) -> None:
        self.last_input["odom"] = time.monotonic()
        if self.cache.on_odometry(msg, self.topics.odom_topic):
            self._feed_odometry()

    def _tf(self, msg: Any, static: bool) -> None:
        for tr in msg.transforms:
            try:
                t = transform_to_matrix(tr.transform)
            except (ValueError, BadMessage):
                what = f"{tr.header.frame_id} → {tr.child_frame_id}"
                self.cache.log("tf", f"dropped a transform {what} on /tf: not a rigid transform")
                continue
            self.frames.on_tf(
                str(tr.header.frame_id), str(tr.child_frame_id), stamp_to_sec(tr.header.stamp), t, static=static
            )

    def setup(self) -> None:
        t, n, m, c = self.topics, self.node, self.msgs, self.cache
        sensor = qos_profile_sensor_data
        image, pose = m.cls("sensor_msgs/msg/Image"), m.cls("geometry_msgs/msg/PoseStamped")
        if self._make_navigation is not None:
            self.navigation = self._make_navigation()
        compressed, compressed_topic = m.cls("sensor_msgs/msg/CompressedImage"), f"{t.image_topic}/compressed"
        self._subs = [
            n.create_subscription(image, t.image_topic, lambda msg: self._image(msg, t.image_topic), sensor),
            n.create_subscription(compressed, compressed_topic, lambda msg: self._image(msg, compressed_topic), sensor),
            n.create_subscription(image, t.depth_topic, lambda msg: c.on_depth(msg, t.depth_topic), sensor),
            n.create_subscription(
                m.cls("sensor_msgs/msg/CameraInfo"),
                t.camera_info_topic,
                lambda msg: c.on_camera_info(msg, t.camera_info_topic),
                sensor,
            ),
            n.create_subscription(m.cls("nav_msgs/msg/Odometry"), t.odom_topic, self._odometry, sensor),
            n.create_subscription(
                m.cls("sensor_msgs/msg/LaserScan"), t.scan_topic, lambda msg: c.on_scan(msg, t.scan_topic), sensor
            ),
            n.create_subscription(
                m.cls("nav_msgs/msg/OccupancyGrid"), t.map_topic, lambda msg: c.on_map(msg, t.map_topic), LATCHED
            ),
            n.create_subscription(
                m.cls("geometry_msgs/msg/PoseWithCovarianceStamped"),
                t.amcl_topic,
                lambda msg: c.on_amcl_pose(msg, t.amcl_topic),
                RELIABLE,
            ),
        ]
        if self.tf_message is not None:
            self._subs += [
                n.create_subscription(self.tf_message, "/tf", lambda msg: self._tf(msg, False), TF_QOS),
                n.create_subscription(self.tf_message, "/tf_static", lambda msg: self._tf(msg, True), TF_STATIC_QOS),
            ]
        self.publishers = {
            "goal": n.create_publisher(pose, t.goal_topic, RELIABLE),
            "target_goal": n.create_publisher(pose, t.target_goal_topic, RELIABLE),
            "cmd_vel": n.create_publisher(m.cls("geometry_msgs/msg/Twist"), t.cmd_vel_topic, RELIABLE),
            "dock": n.create_publisher(pose, t.dock_pose_topic, RELIABLE),
        }

    def waiting_for(self) -> str:
        """What the robot waits for before the tree may run: a camera image and its own pose ('' once both have
        arrived; they are not waited for again — a camera or clock that goes silent later is the watchdog's
        fault). A node started before its drivers must not drive blind (issue 36)."""
        if self._inputs_alive:
            return ""
        missing = []
        if not self.cache.stats.received.get("image"):
            missing.append(f"camera images on {self.topics.image_topic}")
        if self.state is None:
            t = self.topics
            missing.append(f"the robot's pose ({t.odom_topic}, or TF {t.odom_frame} → {t.base_frame})")
        if missing:
            return "waiting for " + " and ".join(missing) + "; the robot does not move until they arrive"
        self._inputs_alive = True
        self.say("inputs alive: the tree starts")
        return ""

    def fault(self, now: float) -> str:
        return "; ".join(p for p in (self.waiting_for(), super().fault(now)) if p)

    def now(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9

    def emit(self, kind: str, msg: Any) -> None:
        self.publishers[kind].publish(msg)

    def close(self) -> None:
        close = getattr(self.navigation, "close", None)
        if callable(close):
            close()
        for s in self._subs:
            self.node.destroy_subscription(s)
        for p in self.publishers.values():
            self.node.destroy_publisher(p)
        self._subs, self.publishers = [], {}
