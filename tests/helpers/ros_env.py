"""Real ROS 2 for the tests: the shared-memory DDS profile, a private domain, a client node, the node process.

Importing this module sets the environment **before** any rclpy context exists (rclpy reads it at init):

* ``FASTRTPS_DEFAULT_PROFILES_FILE`` = mission/ros/fastdds_shm.xml and ``RMW_IMPLEMENTATION=rmw_fastrtps_cpp``:
  shared memory only — nothing is sent on any network interface, loopback included;
* ``ROS_DOMAIN_ID`` private to this test run (other runs on the machine use others): 1 + pid % 100, or under
  pytest-xdist one per worker of the run (:func:`_domain_id`);
* ``ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT``. Not LOCALHOST: in Jazzy's rmw_fastrtps, LOCALHOST
  *adds* a UDPv4 transport to the profile and binds UDP sockets on every interface (measured; see
  mission/ros/dds.py). ``test_ros_node`` checks that the processes hold no inet socket at all.

The node under test runs as a subprocess, as ``ros2 run`` would start it: the colcon-installed
``install/mission/lib/mission/tree`` with the environment of ``install/setup.bash``.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from bench.ros_feed import Subprocess as NodeProcess
from mission.ros import dds

ROOT = Path(__file__).resolve().parents[2]
INSTALL = ROOT / "install"
TREE_EXE = INSTALL / "mission" / "lib" / "mission" / "tree"
PROFILE = dds.shm_profile_path()  # the repo's mission/ros/fastdds_shm.xml


def _domain_id() -> int:
    """This process's ROS_DOMAIN_ID. Under pytest-xdist (scripts/test) the run's workers take consecutive ones
    from a base drawn from the run's controller process, so two workers of one run never share a domain (by
    pid alone they would, 1 in 100 for two); 1 … 200, FastDDS allows up to 232."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")  # "gw0", "gw1", …
    count = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "0") or 0)
    if worker.startswith("gw") and worker[2:].isdigit() and 0 < count <= 200:
        return 1 + (os.getppid() % (200 // count)) * count + int(worker[2:])
    return 1 + os.getpid() % 100


DOMAIN_ID = _domain_id()

ROS_ENV = dds.private_env(DOMAIN_ID)
os.environ.update(ROS_ENV)


def wait_for(condition: Callable[[], Any], timeout: float, what: str, poll: float = 0.01) -> Any:
    """Poll `condition` until it returns something truthy; fail with `what` after `timeout` seconds."""
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout:.1f} s waiting for {what}")
        time.sleep(poll)


def build_ros() -> None:
    """colcon-build tf2_msgs and the mission package (cached: ~1 s when nothing changed)."""
    proc = subprocess.run([str(ROOT / "scripts" / "build_ros")], capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise AssertionError(f"scripts/build_ros failed:\n{proc.stdout}\n{proc.stderr}")


def installed_env() -> dict[str, str]:
    """The environment `ros2 run` gives a package executable: ours plus install/setup.bash."""
    return dds.package_env(INSTALL / "setup.bash", ROS_ENV, ROOT / ".venv" / "bin")


class RosClient:
    """A client node in the test process, spun in a background thread, recording what it receives."""

    def __init__(self, name: str = "test_client") -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        self.rclpy = rclpy
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.received: dict[str, list[tuple[float, Any]]] = {}
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        with contextlib.suppress(Exception):
            while self.context.ok():
                self.executor.spin_once(timeout_sec=0.05)

    def subscribe(self, msg_type: type, topic: str, qos: Any = 10) -> None:
        self.received.setdefault(topic, [])

        def store(msg: Any) -> None:
            with self._lock:
                self.received[topic].append((time.monotonic(), msg))

        self.node.create_subscription(msg_type, topic, store, qos)

    def messages(self, topic: str) -> list[Any]:
        with self._lock:
            return [m for _, m in self.received.get(topic, [])]

    def timed(self, topic: str) -> list[tuple[float, Any]]:
        with self._lock:
            return list(self.received.get(topic, []))

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        with contextlib.suppress(Exception):
            self.rclpy.shutdown(context=self.context)
        self._thread.join(timeout=2.0)


def inet_sockets(pid: int) -> list[tuple[str, str]]:
    """(protocol, local address) of every UDP/TCP socket process `pid` holds (from /proc)."""
    inodes = set()
    fd_dir = Path(f"/proc/{pid}/fd")
    for fd in fd_dir.iterdir():
        with contextlib.suppress(OSError):
            target = os.readlink(fd)
            if target.startswith("socket:["):
                inodes.add(target[8:-1])
    found = []
    for proto in ("udp", "udp6", "tcp", "tcp6"):
        table = Path(f"/proc/{pid}/net/{proto}")
        if not table.exists():
            continue
        for line in table.read_text().splitlines()[1:]:
            fields = line.split()
            if len(fields) > 9 and fields[9] in inodes:
                found.append((proto, _decode_address(fields[1], proto.endswith("6"))))
    return found


def _decode_address(hex_addr: str, v6: bool) -> str:
    host, port = hex_addr.split(":")
    raw = bytes.fromhex(host)
    if v6:
        words = [raw[i : i + 4][::-1] for i in range(0, 16, 4)]
        import ipaddress

        return f"[{ipaddress.IPv6Address(b''.join(words))}]:{int(port, 16)}"
    return f"{'.'.join(str(b) for b in raw[::-1])}:{int(port, 16)}"


def clean_shm() -> None:
    """Remove shared-memory segments left by killed DDS participants (only those no process holds)."""
    tool = ROOT / ".venv" / "tools" / "fastdds" / "fastdds.py"
    if tool.exists():
        subprocess.run([sys.executable, str(tool), "shm", "clean"], capture_output=True, check=False, timeout=30)


@contextlib.contextmanager
def node_process(cmd: list[str], env: dict[str, str], log_path: Path) -> Iterator[NodeProcess]:
    proc = NodeProcess(cmd, env, log_path)
    try:
        yield proc
    finally:
        proc.stop()


class FakeCamera:
    """A camera driver in the client: publishes the current scene's image + camera info at `hz`.

    ``scene`` is a callable stamp → (Image message, CameraInfo message or None), swapped by the test
    (marker in view, marker gone, a broken image…). Runs on the client's executor thread.
    """

    def __init__(
        self,
        client: RosClient,
        hz: float = 15.0,
        image_topic: str = "/camera/image_raw",
        info_topic: str = "/camera/camera_info",
    ) -> None:
        from sensor_msgs.msg import CameraInfo, Image

        self.client = client
        self.pub_image = client.node.create_publisher(Image, image_topic, 10)
        self.pub_info = client.node.create_publisher(CameraInfo, info_topic, 10)
        self.scene: Callable[[float], tuple[Any, Any]] | None = None
        self.published = 0
        self._t0 = 1000.0
        self._timer = client.node.create_timer(1.0 / hz, self._tick)

    def _tick(self) -> None:
        scene = self.scene
        if scene is None:
            return
        stamp = self._t0 + self.published / 15.0
        image, info = scene(stamp)
        if info is not None:
            self.pub_info.publish(info)
        self.pub_image.publish(image)
        self.published += 1

    def wait_for_subscriber(self, timeout: float = 30.0) -> None:
        wait_for(lambda: self.pub_image.get_subscription_count() > 0, timeout, "the node to subscribe to the camera")


class FakeOdometry:
    """A base driver in the client: the robot standing still at the odom origin, /odom at `hz`, stamped now."""

    def __init__(self, client: RosClient, hz: float = 20.0, topic: str = "/odom") -> None:
        from nav_msgs.msg import Odometry

        self.client = client
        self.pub = client.node.create_publisher(Odometry, topic, 10)
        self._msg = Odometry()
        self._msg.header.frame_id, self._msg.child_frame_id = "odom", "base_link"
        self._msg.pose.pose.orientation.w = 1.0
        self._timer = client.node.create_timer(1.0 / hz, self._tick)

    def _tick(self) -> None:
        self._msg.header.stamp = self.client.node.get_clock().now().to_msg()
        self.pub.publish(self._msg)


def blank_image(stamp: float, width: int = 640, height: int = 480) -> Any:
    """A grey bgr8 sensor_msgs/Image: a camera that sees nothing to detect. (Not grey 128: an image of nothing
    but 0x80 bytes published from the test process arrives as "sequence size exceeds remaining buffer" on this
    machine's shared-memory transport; 100 and 255 arrive. Noted, not understood.)"""
    import numpy as np

    from mission.ros.conversions import array_to_image
    from mission.ros.messages import RclpyMessages

    grey = np.full((height, width, 3), 100, np.uint8)
    return array_to_image(RclpyMessages(), grey, "bgr8", stamp, "camera_optical_frame")
