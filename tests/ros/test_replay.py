"""Recording the simulation as a rosbag2 and replaying it: `mission replay BAG` reproduces what the live node
saw. The live run is `mission tree` (the CLI verb, full mission tree) fed the same rendered frames over DDS."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore
from std_msgs.msg import Empty, String

from mission.core import blackboard as bbk
from mission.core.types import Frame, LaserScan, RobotState
from mission.ros.bag_record import BagRecorder
from mission.ros.bag_replay import replay
from mission.ros.conversions import array_to_image, intrinsics_to_camera_info
from mission.ros.messages import BagMessages, RclpyMessages
from mission.sim.scenario import load_scenario
from mission.sim.sim_adapter import SimAdapter
from tests.helpers.ros_env import (
    ROOT,
    FakeCamera,
    FakeOdometry,
    RosClient,
    clean_shm,
    installed_env,
    node_process,
    wait_for,
)

pytestmark = pytest.mark.ros

CONFIG = ROOT / "mission" / "configs" / "sim_aruco.yaml"  # the sim's tags: APRILTAG_36h11, target id 7, 0.20 m
MISSION = [str(ROOT / ".venv" / "bin" / "mission")]


def sim_recording(n_frames: int = 36) -> list[tuple[Frame, RobotState, LaserScan | None]]:
    """Rendered pybullet frames of `follow_open` while the target drives off (plus odometry and scans)."""
    adapter = SimAdapter(load_scenario("follow_open"), seed=2)
    adapter.setup()
    bb = bbk.writer("recorder-test")
    try:
        adapter.advance(2.8)  # the target starts moving at 3 s
        out, last_seq = [], 0
        while len(out) < n_frames:
            adapter.sense(bb)
            if bbk.get(bb, bbk.FRAME_SEQ, 0) != last_seq:
                last_seq = bbk.get(bb, bbk.FRAME_SEQ)
                out.append((bbk.get(bb, bbk.FRAME), bbk.get(bb, bbk.ROBOT_STATE), bbk.get(bb, bbk.SCAN)))
            adapter.advance(1.0 / 30.0)
        return out
    finally:
        adapter.close()


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    frames = sim_recording()
    bag = tmp_path_factory.mktemp("bags") / "follow_open"
    with BagRecorder(bag) as rec:
        for frame, state, scan in frames:
            rec.record(frame=frame, state=state, scan=scan)
    return frames, bag, rec.counts


def test_the_recorder_writes_camera_info_odom_and_scan_that_any_reader_can_read(recording):
    frames, bag, counts = recording
    assert counts["image"] == counts["camera_info"] == counts["odom"] == len(frames)
    assert 1 <= counts["scan"] < len(frames), "a scan is recorded once, not once per tick"
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        topics = {c.topic: c.msgtype for c in reader.connections}
        assert topics["/camera/image_raw"] == "sensor_msgs/msg/Image"
        assert topics["/odom"] == "nav_msgs/msg/Odometry" and topics["/scan"] == "sensor_msgs/msg/LaserScan"
        conn = next(c for c in reader.connections if c.topic == "/camera/image_raw")
        _, t, raw = next(reader.messages(connections=[conn]))
        img = reader.deserialize(raw, conn.msgtype)
        assert (img.encoding, img.width, img.height) == ("bgr8", frames[0][0].width, frames[0][0].height)
        assert t == round(frames[0][0].stamp * 1e9)


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_replay_counts_a_bad_image_in_the_bag_and_goes_on(tmp_path, storage):
    frame, state, _ = sim_recording(2)[1]
    bag = tmp_path / "bad"
    with BagRecorder(bag, storage=storage) as rec:
        rec.write_frame(frame)
        broken = array_to_image(BagMessages(rec.typestore), frame.image, "bgr8", frame.stamp + 0.1, frame.frame_id)
        broken.step = broken.step - 1
        rec._write("image", broken, frame.stamp + 0.1)
        rec.write_frame(Frame(frame.image, frame.stamp + 0.2, frame.frame_id, frame.intrinsics))
        rec.write_state(state)
    from mission.core.config import load_config

    result = replay(bag, load_config(CONFIG), config_file=CONFIG)
    assert [round(f.stamp - frame.stamp, 3) for f in result.frames] == [0.0, 0.2]
    assert result.stats["dropped"] == {"image:size": 1}
    assert all(f.detections and f.detections[0].marker_id == 7 for f in result.frames)


def test_replay_pairs_an_image_with_camera_info_logged_just_after_it(tmp_path):
    """On a robot the camera info is often logged a few ms after its image: replay still pairs them."""
    frame, _, _ = sim_recording(1)[0]
    bag = tmp_path / "late_info"
    with BagRecorder(bag) as rec:
        m = BagMessages(rec.typestore)
        rec._write("image", array_to_image(m, frame.image, "bgr8", frame.stamp, frame.frame_id), frame.stamp)
        info = intrinsics_to_camera_info(m, frame.intrinsics, frame.stamp, frame.frame_id)
        rec._write("camera_info", info, frame.stamp + 0.01)
    from mission.core.config import load_config

    result = replay(bag, load_config(CONFIG), config_file=CONFIG)
    assert result.stats["fallback_intrinsics"] == 0
    assert len(result.frames) == 1 and result.frames[0].detections[0].marker_id == 7


def test_replay_of_a_recorded_sim_bag_reproduces_the_live_detections(recording, tmp_path):
    frames, bag, _ = recording
    msgs = RclpyMessages()

    # live: `mission tree` (the full mission tree of the config) fed the same frames, one at a time
    cmd = [*MISSION, "tree", "--config", str(CONFIG), "--", "--ros-args", "-p", "tick_hz:=30"]
    live: dict[float, list] = {}
    with node_process(cmd, installed_env(), tmp_path / "node.log") as node:
        client = RosClient("replay_client")
        try:
            client.subscribe(String, "/aruco/debug")
            client.subscribe(String, "/mission/tree", qos=_latched())
            camera = FakeCamera(client, hz=1000.0)  # its timer is only used for the first frame; see below
            camera._timer.cancel()
            _odometry = FakeOdometry(client)  # the robot's pose: without it the tree waits and nothing moves
            camera.wait_for_subscriber()
            redetect = client.node.create_publisher(Empty, "/mission/redetect", 10)

            def observations() -> dict[float, list]:
                obs = [json.loads(m.data) for m in client.messages("/aruco/debug")]
                return {round(o["stamp"], 6): o["markers"] for o in obs if "markers" in o}

            def heartbeat() -> dict:
                beats = [json.loads(m.data) for m in client.messages("/aruco/debug")]
                return next((b for b in reversed(beats) if b.get("status") == "running"), {})

            # camera info is best effort, like the images: send it until the node has one, so the first
            # frame is not processed with the fallback intrinsics (replay has the info from the bag)
            first = frames[0][0]
            info = intrinsics_to_camera_info(msgs, first.intrinsics, first.stamp, first.frame_id)
            has_info = lambda: heartbeat().get("received", {}).get("camera_info", 0) > 0  # noqa: E731
            wait_for(lambda: camera.pub_info.publish(info) or has_info(), 10, "the node to receive camera info", 0.1)

            for frame, _, _ in frames:
                camera.pub_info.publish(intrinsics_to_camera_info(msgs, frame.intrinsics, frame.stamp, frame.frame_id))
                camera.pub_image.publish(array_to_image(msgs, frame.image, "bgr8", frame.stamp, frame.frame_id))
                wait_for(
                    lambda f=frame: round(f.stamp, 6) in observations(), 10, f"the observation of {frame.stamp:.3f} s"
                )
            live = observations()

            snapshot = json.loads(wait_for(lambda: client.messages("/mission/tree"), 5, "/mission/tree")[-1].data)
            assert snapshot["tree"]["children"] and snapshot["tree"]["status"] in ("RUNNING", "SUCCESS", "FAILURE")
            wait_for(lambda: redetect.get_subscription_count() > 0, 5, "the node to subscribe to /mission/redetect")
            redetect.publish(Empty())
            wait_for(lambda: "/mission/redetect: reset" in node.log(), 5, "the redetect request to be handled")
        except BaseException:
            print(node.log())
            raise
        finally:
            client.close()
    clean_shm()
    assert len(live) == len(frames)

    # replay: the bag through `mission replay --json`
    proc = subprocess.run(
        [*MISSION, "replay", str(bag), "--config", str(CONFIG), "--json"],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert proc.returncode == 0, proc.stderr
    replayed = {round(r["stamp"], 6): r["detections"] for r in map(json.loads, proc.stdout.splitlines())}
    assert f"{len(frames)} frames processed" in proc.stderr

    assert sorted(replayed) == sorted(live)
    for stamp, markers in live.items():
        got = replayed[stamp]
        assert [d["marker_id"] for d in got] == [m["id"] for m in markers]
        for d, m in zip(got, markers, strict=True):
            assert np.allclose(d["position"], m["tvec_m"], atol=2e-5), (stamp, d["position"], m["tvec_m"])


def _latched():
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def test_a_simulated_run_recorded_with_the_bag_observer_replays_frame_for_frame(tmp_path):
    """What `mission run --record-bag PATH` does: the observer records each tick's sensors from the runner."""
    from mission.app.sim_run import run_scenario
    from mission.core.config import load_config
    from mission.ros.bag_record import BagObserver

    observer = BagObserver(tmp_path / "run")
    run_scenario("follow_open", config_file=CONFIG, seed=1, max_duration=1.2, observers=[observer])
    counts = observer.recorder.counts
    assert counts["image"] >= 10 and counts["odom"] >= counts["image"] and counts["scan"] >= 1
    result = replay(tmp_path / "run", load_config(CONFIG), config_file=CONFIG)
    assert len(result.frames) == counts["image"]
    assert result.bag_s > 1.0  # the recording's span, also when the sim's clock starts at 0
    assert all(d.marker_id == 7 for f in result.frames for d in f.detections) and result.frames[-1].detections


def test_replay_rejects_a_path_that_is_not_a_bag(tmp_path):
    (tmp_path / "notabag").mkdir()
    proc = subprocess.run(
        [sys.executable, "-m", "mission", "replay", str(tmp_path / "notabag")],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
    )
    assert proc.returncode == 2
    assert proc.stderr.startswith("mission: error: ") and "not a readable rosbag2" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_replay_of_a_file_that_is_no_bag_is_one_error_naming_it_not_the_bag_beside_it(recording, tmp_path):
    """`mission replay notes.txt` where notes.txt sits in a bag's directory replayed that bag, said it had
    replayed notes.txt and exited 0 (issue 36)."""
    import shutil

    bag = tmp_path / "run"
    shutil.copytree(recording[1], bag)
    notes = bag / "notes.txt"
    notes.write_text("the robot was fine today\n")
    proc = subprocess.run(
        [sys.executable, "-m", "mission", "replay", str(notes)], capture_output=True, text=True, timeout=120, cwd=ROOT
    )
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stdout == ""
    [line] = proc.stderr.strip().splitlines()
    assert line.startswith(f"mission: error: {notes}: not a bag: expected a ROS 1 .bag file, a rosbag2 directory")


def test_a_sim_bag_replayed_without_a_config_uses_the_config_recorded_with_it(tmp_path, capsys):
    """Issue 36: `mission replay BAG` of a `mission run --record-bag` bag found nothing and said nothing (the
    built-in config reads DICT_4X4_250; the sim's markers are AprilTag 36h11). The run's config goes with its
    bag now, and replay says it uses it."""
    from mission.cli import main

    bag = tmp_path / "run_bag"
    assert main(["run", "--scenario", "explore_dock", "--max-duration", "14", "--record-bag", str(bag)]) == 1
    capsys.readouterr()
    assert main(["replay", str(bag)]) == 0
    out = capsys.readouterr()
    assert f"using the config recorded with {bag} (`mission run --record-bag`)" in out.err
    processed = re.search(r"(\d+) frames processed \((\d+) with detections, marker ids \[0\]\)", out.out)
    assert processed and int(processed.group(2)) > 10, out.out
