"""Feeding ROS processes camera frames at a fixed rate and timing their answers (the ROS benchmarks' harness).

Shared by bench/ros_transport.py (latency against baselines) and bench/soak.py (the node fed for 10
minutes), so both talk to the node the same way:

* :func:`ros_env` — the environment ``ros2 run`` gives the installed node (``install/setup.bash``) plus the
  repo's shared-memory-only FastDDS profile (mission/ros/dds.py) and a private ROS_DOMAIN_ID (101–200, apart
  from the tests' 1–100): nothing is sent on any network interface, and no other run on the machine hears us.
  It also sets those variables in ``os.environ``, because the in-process rclpy reads them at ``init``.
* :class:`Subprocess` — a ROS process under test (the installed node, or a baseline node) with its log.
* :class:`Feeder` — an rclpy node in this process publishing Image + CameraInfo at ``hz`` to whichever
  :class:`Subject` is active and timing, per subject, publish → answer (matched by the header stamp).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mission.core.errors import MissionError
from mission.core.types import CameraIntrinsics
from mission.ros import dds

ROOT = Path(__file__).resolve().parents[1]
INSTALL = ROOT / "install"
TREE_EXE = INSTALL / "mission" / "lib" / "mission" / "tree"
CAMERA_FRAME = "camera_optical_frame"
PENDING_MAX = 300  # unanswered stamps kept (frames without a marker get no answer)


def build_ros() -> None:
    """scripts/build_ros (cached, ~1 s when nothing changed); a MissionError with its output on failure."""
    proc = subprocess.run([str(ROOT / "scripts" / "build_ros")], capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["no output"]
        raise MissionError(f"scripts/build_ros failed ({tail[0]}); see build/colcon-build.log")


def ros_env(domain_id: int | None = None) -> dict[str, str]:
    """The environment of a ``ros2 run`` of our package on the shared-memory profile and a private domain.

    Also applied to ``os.environ`` (this process's rclpy must use the same profile and domain).
    """
    dds_env = dds.private_env(domain_id if domain_id is not None else 101 + os.getpid() % 100)
    os.environ.update(dds_env)
    setup = INSTALL / "setup.bash"
    if not setup.is_file():
        raise MissionError(f"{setup} does not exist; run scripts/build_ros first")
    return dds.package_env(setup, dds_env, ROOT / ".venv" / "bin")


def node_command(
    marker_id: int, marker_size_m: float, tick_hz: float = 30.0, subject: Subject | None = None
) -> list[str]:
    """The installed node in perception-only mode (the design notes' aruco_pose_streamer) for one marker;
    with `subject`, on that subject's topics (params for the inputs, a remap for /detected_aruco_pose)."""
    cmd = [
        str(TREE_EXE),
        "--ros-args",
        "-p",
        "tree:=none",
        "-p",
        f"marker_size_m:={marker_size_m}",
        "-p",
        f"target_marker_id:={marker_id}",
        "-p",
        f"tick_hz:={tick_hz:g}",
    ]
    if subject is not None:
        default = Subject(subject.name)
        if subject.image_topic != default.image_topic:
            cmd += ["-p", f"image_topic:={subject.image_topic}"]
        if subject.info_topic != default.info_topic:
            cmd += ["-p", f"camera_info_topic:={subject.info_topic}"]
        if subject.answer_topic != default.answer_topic:
            cmd += ["-r", f"{default.answer_topic}:={subject.answer_topic}"]
    return cmd


def rss_mb(pid: int | None = None) -> float:
    """Resident set size of a process (this one by default) in MB, from /proc."""
    for line in Path(f"/proc/{pid or 'self'}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


class Subprocess:
    """A ROS process under test; stdout and stderr go to `log_path` (quoted when it dies).

    The tests' node processes are these too (tests/helpers/ros_env.py), so a node is started and stopped one way.
    """

    def __init__(self, cmd: list[str], env: dict[str, str], log_path: Path, cwd: Path = ROOT) -> None:
        self.log_path = log_path
        log_path.parent.mkdir(parents=True, exist_ok=True)
        self._log = log_path.open("wb")
        self.proc = subprocess.Popen(cmd, env=env, stdout=self._log, stderr=subprocess.STDOUT, cwd=cwd)
        self._interrupted = False

    @property
    def pid(self) -> int:
        return self.proc.pid

    def alive(self) -> bool:
        return self.proc.poll() is None

    def log(self) -> str:
        """Everything the process printed so far (also after it was stopped)."""
        if not self._log.closed:
            self._log.flush()
        return self.log_path.read_text(errors="replace")

    def log_tail(self, lines: int = 3) -> str:
        text = self.log().strip().splitlines()
        return " | ".join(text[-lines:]) if text else "(empty log)"

    def interrupt(self) -> None:
        """SIGINT (what Ctrl-C and ros2 launch send) without waiting: stop several processes at once."""
        if self.proc.poll() is None and not self._interrupted:
            self.proc.send_signal(signal.SIGINT)
            self._interrupted = True

    def stop(self, timeout: float = 10.0) -> bool:
        """SIGINT unless already sent, SIGKILL if it does not exit in `timeout`; True if it was alive."""
        alive = self.proc.poll() is None
        if alive:
            self.interrupt()
            try:
                self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._log.close()
        return alive


@dataclass(frozen=True)
class Subject:
    """Where a process under test reads frames and where it answers with a PoseStamped of the same stamp."""

    name: str
    image_topic: str = "/camera/image_raw"
    info_topic: str = "/camera/camera_info"
    answer_topic: str = "/detected_aruco_pose"


def stamp_key(sec: int, nanosec: int) -> float:
    """The key a stamp is matched by (µs: float stamps round-trip through header messages within 1 ns)."""
    return round(sec + nanosec * 1e-9, 6)


class Feeder:
    """Publishes frames at `hz` to the active subject and times each answer (publish → callback, ms).

    Frame `n` is ``views[(n // frames_per_view) % len(views)]`` with stamp ``1000 + n / hz``. The image
    messages are built once per view (only the header changes), so the feeder's own cost per frame is
    the publish. A camera thread publishes on schedule (:meth:`rephase` shifts it) and an executor
    thread receives the answers; :meth:`close` stops both.
    """

    def __init__(
        self,
        subjects: list[Subject],
        views: list[np.ndarray],
        intrinsics: CameraIntrinsics,
        hz: float = 30.0,
        frames_per_view: int = 1,
        heartbeat_topic: str | None = None,
        name: str = "bench_feeder",
    ) -> None:
        import rclpy
        from geometry_msgs.msg import PoseStamped
        from rclpy.executors import SingleThreadedExecutor
        from sensor_msgs.msg import CameraInfo, Image
        from std_msgs.msg import String

        from mission.ros.conversions import array_to_image, intrinsics_to_camera_info
        from mission.ros.messages import RclpyMessages

        self.hz = hz
        self.frames_per_view = frames_per_view
        self.active: str | None = None  # the subject fed now; None: paused
        self.published: dict[str, int] = {s.name: 0 for s in subjects}
        self.latencies: dict[str, list[float]] = {s.name: [] for s in subjects}
        self.heartbeat: dict[str, Any] = {}
        self._lock = threading.Lock()
        self._sent: dict[float, tuple[str, float]] = {}  # stamp → (subject, monotonic publish time)
        self._n = 0
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        msgs = RclpyMessages()
        self._images = [array_to_image(msgs, v, "bgr8", 0.0, CAMERA_FRAME) for v in views]
        self._info = intrinsics_to_camera_info(msgs, intrinsics, 0.0, CAMERA_FRAME)
        self._pubs: dict[str, tuple[Any, Any]] = {}
        for s in subjects:
            self._pubs[s.name] = (
                self.node.create_publisher(Image, s.image_topic, 10),
                self.node.create_publisher(CameraInfo, s.info_topic, 10),
            )
            self.node.create_subscription(PoseStamped, s.answer_topic, self._on_answer, 10)
        if heartbeat_topic:
            self.node.create_subscription(String, heartbeat_topic, self._on_heartbeat, 10)
        self._stop = threading.Event()
        self._next_t = time.monotonic()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()
        self._clock = threading.Thread(target=self._camera, daemon=True)
        self._clock.start()

    # -- executor thread ---------------------------------------------------------------------------
    def _spin(self) -> None:
        while not self._stop.is_set() and self.context.ok():
            self.executor.spin_once(timeout_sec=0.02)

    def _camera(self) -> None:
        """The camera's clock: a frame every 1/hz s (publishing from this thread; answers arrive on the
        executor's). A late wake-up does not send a burst: the schedule restarts from now."""
        period = 1.0 / self.hz
        while not self._stop.is_set():
            now = time.monotonic()
            if now < self._next_t:
                time.sleep(min(self._next_t - now, 0.05))
                continue
            self._next_t = self._next_t + period if self._next_t + period > now else now + period
            self._publish()

    def rephase(self, delay_s: float) -> None:
        """Shift the camera's clock: the next frame goes out `delay_s` from now (then every 1/hz s).

        A camera and a node that both run at 30 Hz keep their relative phase, and a node that works on a
        timer makes each frame wait for its next tick — so a figure measured at one phase says little.
        Re-phasing at random before each slot samples the phases.
        """
        self._next_t = time.monotonic() + delay_s

    def _publish(self) -> None:
        subject = self.active
        if subject is None:
            return
        n = self._n
        self._n += 1
        stamp = 1000.0 + n / self.hz
        sec = int(stamp)
        nanosec = round((stamp - sec) * 1e9)
        if nanosec >= 1_000_000_000:
            sec, nanosec = sec + 1, nanosec - 1_000_000_000
        image = self._images[(n // self.frames_per_view) % len(self._images)]
        for msg in (image, self._info):
            msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
        pub_image, pub_info = self._pubs[subject]
        pub_info.publish(self._info)
        with self._lock:
            self._sent[stamp_key(sec, nanosec)] = (subject, time.monotonic())
            if len(self._sent) > PENDING_MAX:
                for k in sorted(self._sent)[:-PENDING_MAX]:
                    del self._sent[k]
        pub_image.publish(image)
        self.published[subject] += 1

    def _on_answer(self, msg: Any) -> None:
        now = time.monotonic()
        key = stamp_key(msg.header.stamp.sec, msg.header.stamp.nanosec)
        with self._lock:
            sent = self._sent.pop(key, None)
            if sent is not None:
                self.latencies[sent[0]].append((now - sent[1]) * 1e3)

    def _on_heartbeat(self, msg: Any) -> None:
        d = json.loads(msg.data)
        if d.get("status") == "running":
            with self._lock:
                self.heartbeat = {"t": time.monotonic(), **d}

    # -- caller's thread ---------------------------------------------------------------------------
    def take(self, subject: str) -> list[float]:
        """The latencies (ms) recorded for `subject` since the last take, and forget them."""
        with self._lock:
            out, self.latencies[subject] = self.latencies[subject], []
        return out

    def newest_heartbeat(self) -> dict[str, Any]:
        with self._lock:
            return dict(self.heartbeat)

    def feed_until_answer(self, subject: str, timeout: float, alive: Callable[[], bool] = lambda: True) -> bool:
        """Feed `subject` until its first answer (it has subscribed and warmed up); False on timeout/death."""
        self.active = subject
        deadline = time.monotonic() + timeout
        try:
            while time.monotonic() < deadline and alive():
                with self._lock:
                    if self.latencies[subject]:
                        return True
                time.sleep(0.05)
            return False
        finally:
            self.active = None

    def close(self) -> None:
        self.active = None
        self._stop.set()
        self._clock.join(timeout=2.0)
        self._thread.join(timeout=2.0)
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        import rclpy

        rclpy.shutdown(context=self.context)
