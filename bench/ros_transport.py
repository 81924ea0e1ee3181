"""Benchmark: image → ``/detected_aruco_pose`` latency of the ROS node over shared-memory DDS at 30 Hz.

The node under test is the installed executable (``install/mission/lib/mission/tree``, built by
scripts/build_ros; what ``ros2 run mission tree`` starts) in perception-only mode (``tree:=none``,
``tick_hz:=30``) in its own process, on the repo's shared-memory-only FastDDS profile and a private
ROS_DOMAIN_ID (bench/ros_feed.py; nothing leaves the machine). This process publishes rendered 640×480
bgr8 frames of one 15 cm DICT_4X4_250 marker (8 poses, 1.2–2 m, up to 35° off axis) with their CameraInfo
at 30 Hz and times publish → the PoseStamped with the frame's stamp.

Baselines, measured in the same run on the same frames, in interleaved time slots (node, streamer,
echo, detector, node, …; one fed at a time) so all four see the same machine load:

* **streamer** — a hand-written rclpy node (this file, ``--serve streamer``): in the image callback,
  image → numpy, the raw OpenCV call (``ArucoDetector.detectMarkers`` + ``solvePnP(IPPE_SQUARE)``, the
  perception benchmark's baseline) and a PoseStamped with the image's header. The minimal aruco_pose_streamer.
* **echo** — a bare rclpy node (``--serve echo``) answering each Image with a PoseStamped of its header:
  the DDS round trip of a 0.9 MB image and a small answer, with no work in between (the transport floor).
* **detector alone** — our ``aruco`` source's ``process()`` on the same frames in this process, no ROS.

Full runs add a diagnostic slot: the same node at ``tick_hz:=120`` on its own topics, against the node at 30 Hz —
since the node perceives in the image callback, the tick rate should no longer matter (ratio ≈ 1).

What separates the node from the streamer: both work in the image callback; the node's perception stage adds
the frame's placement (TF lookup at the image stamp), the sub-pixel refinement and the temporal choice
between the two IPPE poses, target matching and the track update, then publishes /detected_aruco_pose first
and /aruco/debug, /aruco_poses and /tf after it. Target (issue 14): p50 ≤ 1.1× and p99 ≤ 1.3× the streamer.

    python -m bench.ros_transport [--quick]          # the benchmark alone (JSON on stdout)
    python -m bench.ros_transport --serve echo|streamer --image-topic T --info-topic T --answer-topic T
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench.common import Figure, load_average, pct, plot_cdf, progress, ratio
from bench.ros_feed import Feeder, Subject, Subprocess, build_ros, node_command, ros_env
from mission.core import se3
from mission.core.types import CameraIntrinsics, Frame

MARKER_ID = 7
MARKER_SIZE_M = 0.15
HZ = 30.0
N_VIEWS = 8
STARTUP_TIMEOUT_S = 60.0

NODE = Subject("node")  # the node's default topics
# Diagnostic (full runs): the same node ticking at 120 Hz — how much of its latency is waiting for a tick.
NODE_FAST = Subject("node_tick120", "/bench/node120/image_raw", "/bench/node120/camera_info", "/bench/node120/pose")
FAST_TICK_HZ = 120.0
STREAMER = Subject("streamer", "/bench/streamer/image_raw", "/bench/streamer/camera_info", "/bench/streamer/pose")
ECHO = Subject("echo", "/bench/echo/image_raw", "/bench/echo/camera_info", "/bench/echo/pose")
DETECTOR = "detector"  # the in-process slot (no ROS)
SLOTS = (NODE.name, STREAMER.name, ECHO.name, DETECTOR)
FULL_SLOTS = (*SLOTS, NODE_FAST.name)


def render_views(n: int = N_VIEWS, seed: int = 11) -> tuple[list[np.ndarray], CameraIntrinsics]:
    """`n` rendered 640×480 frames of the marker at varied poses (each one is found by the detector)."""
    from tools.synthetic_views import default_intrinsics, pose_facing_camera, render_marker_view

    k = default_intrinsics()
    rng = np.random.default_rng(seed)
    views = []
    for i in range(n):
        pos = np.array([rng.uniform(-0.3, 0.3), rng.uniform(-0.15, 0.15), 1.2 + 0.8 * i / max(1, n - 1)])
        tilt = math.radians(rng.uniform(5, 35))
        t = pose_facing_camera(pos, rng.uniform(0, 2 * math.pi), tilt, rng.uniform(-0.5, 0.5))
        views.append(
            render_marker_view(t, marker_id=MARKER_ID, marker_size_m=MARKER_SIZE_M, intrinsics=k, rng=rng).image
        )
    return views, k


# --------------------------------------------------------------------------------------------------
# the baseline nodes (run in their own process: python -m bench.ros_transport --serve …)
# --------------------------------------------------------------------------------------------------


def serve(mode: str, image_topic: str, info_topic: str, answer_topic: str) -> int:
    """A baseline node: `echo` answers each image with its header; `streamer` detects the marker first."""
    import cv2
    import rclpy
    from geometry_msgs.msg import PoseStamped
    from rclpy.executors import ExternalShutdownException
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import CameraInfo, Image

    from bench.perception_bench import raw_aruco_poses
    from mission.ros.conversions import camera_info_to_intrinsics, image_to_array, matrix_to_pose
    from mission.ros.messages import RclpyMessages
    from mission.ros.ros_adapter import RELIABLE

    rclpy.init()
    node = rclpy.create_node(f"bench_{mode}")
    pub = node.create_publisher(PoseStamped, answer_topic, RELIABLE)
    msgs = RclpyMessages()
    detect = raw_aruco_poses(cv2.aruco.DICT_4X4_250, MARKER_SIZE_M)
    camera: dict[str, Any] = {}

    def on_info(msg: Any) -> None:
        camera["k"] = camera_info_to_intrinsics(msg)

    def on_image(msg: Any) -> None:
        if mode == "echo":
            pub.publish(PoseStamped(header=msg.header))
            return
        k = camera.get("k")
        if k is None:
            return
        for marker_id, rvec, tvec in detect(image_to_array(msg), k.matrix, k.dist_coeffs):
            if marker_id == MARKER_ID:
                t = se3.transform(se3.rvec_to_matrix(rvec.reshape(3)), tvec.reshape(3))
                pub.publish(PoseStamped(header=msg.header, pose=matrix_to_pose(msgs, t)))

    node.create_subscription(CameraInfo, info_topic, on_info, 10)
    node.create_subscription(Image, image_topic, on_image, qos_profile_sensor_data)  # as the node subscribes
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0


def _serve_command(mode: str, subject: Subject) -> list[str]:
    return [
        sys.executable,
        "-m",
        "bench.ros_transport",
        "--serve",
        mode,
        "--image-topic",
        subject.image_topic,
        "--info-topic",
        subject.info_topic,
        "--answer-topic",
        subject.answer_topic,
    ]


# --------------------------------------------------------------------------------------------------
# the benchmark
# --------------------------------------------------------------------------------------------------


def cpu_seconds(pid: int) -> float:
    """User + system CPU seconds a live process has used (from /proc; the nodes tick even when not fed)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return round((int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK"), 2)


def _detector_slot(views: list[np.ndarray], k: CameraIntrinsics, seconds: float, source: Any, n0: int) -> list[float]:
    """Our aruco source's process() on the frames, paced at HZ for `seconds` (ms per call)."""
    times = []
    period = 1.0 / HZ
    end = time.monotonic() + seconds
    n = n0
    next_t = time.monotonic()
    while time.monotonic() < end:
        frame = Frame(views[n % len(views)], stamp=1000.0 + n / HZ, intrinsics=k)
        t0 = time.perf_counter()
        source.process(frame)
        times.append((time.perf_counter() - t0) * 1e3)
        n += 1
        next_t += period
        time.sleep(max(0.0, next_t - time.monotonic()))
    return times


def measure(quick: bool, log_dir: Path) -> dict[str, Any]:
    """Start the node and the two baseline nodes, feed them in interleaved slots, return the samples."""
    from mission.perception_plugins.aruco import ArucoSource

    slot_s, rounds = (1.0, 2) if quick else (4.0, 15)
    build_ros()
    env = ros_env()
    views, k = render_views()
    slots = SLOTS if quick else FULL_SLOTS
    procs = {
        NODE.name: Subprocess(node_command(MARKER_ID, MARKER_SIZE_M, HZ), env, log_dir / ".ros_transport_node.log"),
        STREAMER.name: Subprocess(_serve_command("streamer", STREAMER), env, log_dir / ".ros_transport_streamer.log"),
        ECHO.name: Subprocess(_serve_command("echo", ECHO), env, log_dir / ".ros_transport_echo.log"),
    }
    if not quick:
        procs[NODE_FAST.name] = Subprocess(
            node_command(MARKER_ID, MARKER_SIZE_M, FAST_TICK_HZ, NODE_FAST),
            env,
            log_dir / ".ros_transport_node_tick120.log",
        )
    feeder = Feeder([NODE, STREAMER, ECHO, NODE_FAST], views, k, hz=HZ)
    source = ArucoSource({"marker_size_m": MARKER_SIZE_M})
    samples: dict[str, list[float]] = {s: [] for s in slots}
    fed: dict[str, int] = dict.fromkeys(slots, 0)
    t_start = time.monotonic()
    try:
        for name, proc in procs.items():  # warm-up: each answers once before anything is timed
            if not feeder.feed_until_answer(name, STARTUP_TIMEOUT_S, proc.alive):
                why = "exited" if not proc.alive() else f"gave no answer within {STARTUP_TIMEOUT_S:.0f} s"
                raise RuntimeError(f"ros: {name} process {why}; log {proc.log_path}: {proc.log_tail()}")
        startup_s = time.monotonic() - t_start
        progress(f"ros: node and baselines answering after {startup_s:.1f} s; {rounds} rounds of {slot_s:g} s slots")
        time.sleep(0.3)  # late answers to the warm-up frames
        for name in procs:
            feeder.take(name)
        n = 0
        phases = np.random.default_rng(3)
        for _ in range(rounds):
            for name in slots:
                if name == DETECTOR:
                    samples[DETECTOR] += _detector_slot(views, k, slot_s, source, n)
                    fed[DETECTOR] = len(samples[DETECTOR])
                    n += int(slot_s * HZ)
                    continue
                before = feeder.published[name]
                feeder.rephase(float(phases.uniform(0.0, 1.0 / HZ)))  # a new camera/tick phase per slot
                feeder.active = name
                time.sleep(slot_s)
                feeder.active = None
                time.sleep(0.25)  # let the slot's last answers arrive before the next subject starts
                fed[name] += feeder.published[name] - before
                samples[name] += feeder.take(name)
        for name, proc in procs.items():
            if not proc.alive():
                raise RuntimeError(f"ros: {name} process died during the run; log {proc.log_path}: {proc.log_tail()}")
        cpu_s = {name: cpu_seconds(proc.pid) for name, proc in procs.items()}
        wall_s = time.monotonic() - t_start
    finally:
        feeder.close()
        source.close()
        for proc in procs.values():
            proc.interrupt()
        for proc in procs.values():
            proc.stop()
    return {
        "samples": samples,
        "fed": fed,
        "slot_s": slot_s,
        "rounds": rounds,
        "startup_s": round(startup_s, 1),
        "slots": slots,
        "process_cpu_s": cpu_s,
        "wall_s": round(wall_s, 1),
    }


def figures(m: dict[str, Any]) -> list[Figure]:
    s, fed = m["samples"], m["fed"]
    node, streamer, echo, det = s[NODE.name], s[STREAMER.name], s[ECHO.name], s[DETECTOR]
    streamer_desc = (
        "hand-written rclpy streamer (image callback → raw cv2 detectMarkers + solvePnP → PoseStamped), "
        "same DDS profile, same frames, interleaved"
    )
    figs = []
    for q, limit in ((50, 1.1), (99, 1.3)):
        a, b = pct(node, q, 2), pct(streamer, q, 2)
        r = ratio(a, b, 2)
        figs.append(
            Figure(
                f"node: image → /detected_aruco_pose, p{q}",
                a,
                "ms",
                baseline=streamer_desc,
                baseline_value=b,
                ratio=r,
                target=f"ratio ≤ {limit:g}",
                meets_target=None if r is None else r <= limit,
            )
        )
    e50, d50 = pct(echo, 50, 2), pct(det, 50, 2)
    figs.append(
        Figure(
            "DDS round trip alone (bare rclpy echo of the Image as a PoseStamped), p50",
            e50,
            "ms",
            baseline="our aruco source's process() alone on the same frames, p50",
            baseline_value=d50,
            ratio=ratio(e50, d50, 2),
        )
    )
    figs.append(
        Figure(
            "echo p99",
            pct(echo, 99, 2),
            "ms",
            baseline="detector alone p99",
            baseline_value=pct(det, 99, 2),
            ratio=ratio(pct(echo, 99, 2), pct(det, 99, 2), 2),
        )
    )
    an, ast = len(node) / max(1, fed[NODE.name]), len(streamer) / max(1, fed[STREAMER.name])
    figs.append(
        Figure(
            "frames answered by the node",
            round(an, 3),
            "fraction of frames fed",
            baseline="same fraction for the hand-written streamer",
            baseline_value=round(ast, 3),
            ratio=ratio(an, ast, 3),
        )
    )
    if NODE_FAST.name in s:
        fast = s[NODE_FAST.name]
        for q in (50, 99):
            a, b = pct(fast, q, 2), pct(node, q, 2)
            figs.append(
                Figure(
                    f"diagnostic: the same node at tick_hz {FAST_TICK_HZ:g}, p{q}",
                    a,
                    "ms",
                    baseline="the node at tick_hz 30 above (same frames, interleaved)",
                    baseline_value=b,
                    ratio=ratio(a, b, 2),
                )
            )
    return figs


def run(quick: bool, out: Path) -> dict[str, Any]:
    m = measure(quick, out)
    s = m["samples"]
    for name in m["slots"]:
        progress(f"ros: {name}: {len(s[name])} samples, p50 {pct(s[name], 50, 2)} ms, p99 {pct(s[name], 99, 2)} ms")
    plot = _plot(s, out)
    return {
        "title": "ROS transport: image → /detected_aruco_pose over shared-memory DDS at 30 Hz",
        "figures": [f.to_json() for f in figures(m)],
        "details": {
            "node": "install/mission/lib/mission/tree, tree:=none, tick_hz:=30, target_marker_id:=7",
            "frames": f"640x480 bgr8, {N_VIEWS} rendered views of a {MARKER_SIZE_M} m DICT_4X4_250 marker, "
            f"{HZ:g} Hz, with CameraInfo",
            "transport": "mission/ros/fastdds_shm.xml (shared memory only), private ROS_DOMAIN_ID",
            "slots": f"{m['rounds']} rounds × ({', '.join(m['slots'])}) × {m['slot_s']:g} s, one fed at a time",
            "startup_s": m["startup_s"],
            "frames_fed": m["fed"],
            "camera_phase": "re-drawn at random before every slot (the node's tick wait depends on it)",
            "process_cpu_s": m["process_cpu_s"],
            "wall_s": m["wall_s"],
            "answers": {k: len(v) for k, v in s.items()},
            "p50_p90_p99_ms": {k: [pct(v, q, 2) for q in (50, 90, 99)] for k, v in s.items()},
            "load_average": load_average(),
        },
        "plots": [plot],
    }


def _plot(samples: dict[str, list[float]], out: Path) -> str:
    labels = {
        NODE.name: "node (install/…/tree, tree:=none, 30 Hz tick)",
        STREAMER.name: "hand-written rclpy streamer (raw OpenCV in the callback)",
        ECHO.name: "bare rclpy echo (DDS round trip only)",
        DETECTOR: "our aruco source alone (no ROS)",
        NODE_FAST.name: f"diagnostic: the node at tick_hz {FAST_TICK_HZ:g}",
    }
    title = "Image → /detected_aruco_pose latency, 30 Hz, SHM DDS"
    return plot_cdf({labels[name]: v for name, v in samples.items()}, title, out / "ros_transport_cdf.png", 7)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.ros_transport", description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--serve", choices=("echo", "streamer"), help="run a baseline node (used by the benchmark)")
    ap.add_argument("--image-topic", default=STREAMER.image_topic)
    ap.add_argument("--info-topic", default=STREAMER.info_topic)
    ap.add_argument("--answer-topic", default=STREAMER.answer_topic)
    args = ap.parse_args(argv)
    if args.serve:
        return serve(args.serve, args.image_topic, args.info_topic, args.answer_topic)
    print(json.dumps(run(args.quick, Path(tempfile.gettempdir())), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
