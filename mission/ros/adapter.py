"""The ROS 2 world adapter: live topics in, Nav2-style commands out (rclpy).

Subscriptions only cache (the :class:`~mission.ros.sensor_cache.SensorCache` converts, counts and
pairs); ``sense()`` and ``act()`` are :class:`~mission.ros.world_io.CachedWorld`'s, shared with replay,
so a bag and a robot reach the tree through the same code.

QoS: camera, depth, camera info, odometry and scan use the sensor-data profile (best effort, as
drivers publish; it also accepts reliable publishers); ``/map`` is reliable and transient-local (the
map server latches it); commands are reliable.

Images are also taken from ``<image_topic>/compressed`` (sensor_msgs/CompressedImage), where
image_transport's ``compressed`` plugin publishes them; a camera that publishes both gives one frame per
stamp (the cache skips the second copy).
"""

from __future__ import annotations

from typing import Any

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

from mission.ros.messages import RclpyMessages
from mission.ros.world_io import CachedWorld, RosTopics

RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


class RosAdapter(CachedWorld):
    """WorldAdapter over rclpy topics. Construct with a node (light); ``setup()`` creates the endpoints."""

    def __init__(self, node: Node, topics: RosTopics | None = None) -> None:
        self.msgs: RclpyMessages
        super().__init__(topics or RosTopics(), RclpyMessages(), warn=node.get_logger().warning)
        self.node = node
        self._subs: list[Any] = []
        self.publishers: dict[str, Any] = {}

    def setup(self) -> None:
        t, n, m, c = self.topics, self.node, self.msgs, self.cache
        sensor = qos_profile_sensor_data
        image, pose = m.cls("sensor_msgs/msg/Image"), m.cls("geometry_msgs/msg/PoseStamped")
        compressed, compressed_topic = m.cls("sensor_msgs/msg/CompressedImage"), f"{t.image_topic}/compressed"
        self._subs = [
            n.create_subscription(image, t.image_topic, lambda msg: c.on_image(msg, t.image_topic), sensor),
            n.create_subscription(compressed, compressed_topic, lambda msg: c.on_image(msg, compressed_topic), sensor),
            n.create_subscription(image, t.depth_topic, lambda msg: c.on_depth(msg, t.depth_topic), sensor),
            n.create_subscription(m.cls("sensor_msgs/msg/CameraInfo"), t.camera_info_topic,
                                  lambda msg: c.on_camera_info(msg, t.camera_info_topic), sensor),
            n.create_subscription(m.cls("nav_msgs/msg/Odometry"), t.odom_topic,
                                  lambda msg: c.on_odometry(msg, t.odom_topic), sensor),
            n.create_subscription(m.cls("sensor_msgs/msg/LaserScan"), t.scan_topic,
                                  lambda msg: c.on_scan(msg, t.scan_topic), sensor),
            n.create_subscription(m.cls("nav_msgs/msg/OccupancyGrid"), t.map_topic,
                                  lambda msg: c.on_map(msg, t.map_topic), LATCHED),
            n.create_subscription(m.cls("geometry_msgs/msg/PoseWithCovarianceStamped"), t.amcl_topic,
                                  lambda msg: c.on_amcl_pose(msg, t.amcl_topic), RELIABLE),
        ]  # fmt: skip
        self.publishers = {
            "goal": n.create_publisher(pose, t.goal_topic, RELIABLE),
            "target_goal": n.create_publisher(pose, t.target_goal_topic, RELIABLE),
            "cmd_vel": n.create_publisher(m.cls("geometry_msgs/msg/Twist"), t.cmd_vel_topic, RELIABLE),
            "dock": n.create_publisher(pose, t.dock_pose_topic, RELIABLE),
        }

    def now(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9

    def emit(self, kind: str, msg: Any) -> None:
        self.publishers[kind].publish(msg)

    def close(self) -> None:
        for s in self._subs:
            self.node.destroy_subscription(s)
        for p in self.publishers.values():
            self.node.destroy_publisher(p)
        self._subs, self.publishers = [], {}
