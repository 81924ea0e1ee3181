"""Running the tree on a recorded bag (ROS 1, or rosbag2 mcap / sqlite3), through the same code as the live node.

The bag's messages go into the ROS adapter's :class:`~mission.ros.sensor_cache.SensorCache` (same
conversions, same pairing by stamp, same drop counters) and the runner's one loop steps once per camera
image (the world's ``advance`` plays the bag up to the next image), so every recorded frame is
perceived exactly once, as fast as possible (``rate=0``) or paced to the recorded timing (``rate=1.0``
is real time). SIGINT/SIGTERM end the replay after the current frame with what was replayed so far.
The world does not answer the tree's commands — a bag is open loop — so replay is for perception and
decision logic, not for closing the loop. Needs only ``rosbags`` (no ROS install); incomplete and damaged
bags are read as far as they go (mission/ros/bag_source.py).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rosbags.typesys import Stores, get_typestore

from mission.core import blackboard as bbk
from mission.core.config import MissionConfig
from mission.core.errors import MissionError
from mission.core.observers import RunObserver
from mission.core.perception import Perceived
from mission.core.types import CameraIntrinsics, Detection
from mission.ros.bag_source import BagSource, open_bag
from mission.ros.messages import BagMessages
from mission.ros.world_io import CachedWorld, RosTopics

LOOKAHEAD_S = 0.05  # how long after an image its camera info / depth may have been logged


@dataclass
class FrameResult:
    """What perception found in one replayed frame."""

    stamp: float
    frame_id: str
    detections: list[Detection]

    def to_json(self) -> dict[str, Any]:
        return {"stamp": self.stamp, "frame_id": self.frame_id, "detections": [d.to_json() for d in self.detections]}


@dataclass
class ReplayResult:
    frames: list[FrameResult] = field(default_factory=list)
    ticks: int = 0
    commands: dict[str, int] = field(default_factory=dict)  # goal / target_goal / cmd_vel / dock → count
    mission_state: str = ""
    status: str = ""
    stats: dict[str, Any] = field(default_factory=dict)
    wall_s: float = 0.0
    bag_s: float = 0.0
    interrupted: bool = False  # SIGINT/SIGTERM ended the replay before the bag's end
    stop_signal: int | None = None  # which one
    read: dict[str, str] = field(default_factory=dict)  # input ("image", "camera_info", …) → the topic read
    kind: str = ""  # rosbag1 | rosbag2 (mcap) | rosbag2 (sqlite3)


TOPIC_KEYS = ("image_topic", "camera_info_topic", "depth_topic", "odom_topic", "scan_topic", "map_topic")
IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
CAMERA_INFO_TYPE = "sensor_msgs/msg/CameraInfo"


def replay_topics(config: MissionConfig, flags: dict[str, str | None] | None = None) -> tuple[RosTopics, set[str]]:
    """The topics to read: each ``--…-topic`` flag over the config's ``topics`` section over the node's
    defaults; and which were chosen (by a flag or the config) rather than defaulted."""
    chosen: dict[str, str] = {}
    for key in TOPIC_KEYS:
        value = (flags or {}).get(key) or getattr(config.topics, key)
        if value:
            chosen[key] = value
    return RosTopics(**chosen), set(chosen)


def _camera_topics(bag: BagSource, depth_topic: str) -> list[str]:
    """The bag's camera image topics, a raw topic and its ``/compressed`` twin counted once (the raw one),
    depth images left out."""
    found = set(bag.topics(IMAGE_TYPES))
    out = []
    for t in sorted(found):
        if t == depth_topic or t.startswith(depth_topic + "/") or t.endswith("/compressedDepth"):
            continue
        if t.endswith("/compressed") and t.removesuffix("/compressed") in found:
            continue
        out.append(t)
    return out


class BagWorld(CachedWorld):
    """A WorldAdapter that plays a bag: ``step()`` feeds messages up to and including the next image.

    Any bag :func:`mission.ros.bag_source.open_bag` reads; topics as :func:`replay_topics` chooses them,
    each also read from its image_transport twin (``<image>/compressed``, ``<depth>/compressedDepth``)
    when the bag has that instead. `explicit` names the topics a user chose: an unchosen camera topic that
    is not in the bag is replaced by the bag's only image topic (and the same for camera info), with a
    warning saying so. `calibration` replaces the bag's camera info for every frame."""

    def __init__(
        self,
        path: str | Path,
        topics: RosTopics | None = None,
        warn: Any = lambda message: None,
        *,
        explicit: set[str] | None = None,
        calibration: CameraIntrinsics | None = None,
    ) -> None:
        self.exhausted = False  # the bag has no image left: the loop ends
        super().__init__(topics or RosTopics(), BagMessages(get_typestore(Stores.ROS2_JAZZY)), warn=warn)
        self.cache.fixed_intrinsics = calibration
        self.warn = warn
        self.explicit = set(explicit or ())
        self.path = Path(path)
        self.bag: BagSource | None = None
        self._messages: Iterator[tuple[str, str, int, bytes]] | None = None
        self._pending: tuple[str, str, int, bytes] | None = None
        self.lookahead_ns = round(LOOKAHEAD_S * 1e9)
        self.commands: dict[str, int] = {}
        self.clock = 0.0
        self.first_stamp: float | None = None
        self.read: dict[str, str] = {}  # what each input was read from: "image" → topic
        self.undecodable = 0

    def _resolve(self, bag: BagSource) -> dict[str, Callable[[Any, str], bool]]:
        t, c = self.topics, self.cache
        present = set(bag.topics())

        def twin(topic: str, suffix: str) -> str | None:
            return topic if topic in present else topic + suffix if topic + suffix in present else None

        image = twin(t.image_topic, "/compressed")
        if image is None:
            cameras = _camera_topics(bag, t.depth_topic)
            if "image_topic" not in self.explicit and len(cameras) == 1:
                image = cameras[0]
                self.warn(
                    f"{self.path}: no {t.image_topic} in this bag; using {image}, its only image topic "
                    f"(--image-topic chooses another)"
                )
            else:
                listed = ", ".join(cameras) or "none"
                others = ", ".join(sorted(present - set(cameras))) or "none"
                choose = "choose one with --image-topic" if cameras else "the bag has no camera images"
                raise MissionError(
                    f"{self.path}: no image topic {t.image_topic} in this bag (image topics: {listed}; "
                    f"other topics: {others}); {choose}"
                )
        info = twin(t.camera_info_topic, "")
        infos = bag.topics((CAMERA_INFO_TYPE,))
        if info is None and "camera_info_topic" not in self.explicit and len(infos) == 1:
            info = infos[0]
            self.warn(f"{self.path}: no {t.camera_info_topic} in this bag; using {info}, its only camera info topic")
        if info is not None and self.cache.fixed_intrinsics is not None:
            self.warn(f"{self.path}: the calibration file replaces the camera info on {info}")
            info = None
        depth = twin(t.depth_topic, "/compressedDepth")
        handlers: dict[str, Callable[[Any, str], bool]] = {image: c.on_image}
        self.read["image"] = image
        for kind, topic, handler in (
            ("camera_info", info, c.on_camera_info),
            ("depth", depth, c.on_depth),
            ("odom", twin(t.odom_topic, ""), c.on_odometry),
            ("scan", twin(t.scan_topic, ""), c.on_scan),
            ("map", twin(t.map_topic, ""), c.on_map),
            ("amcl_pose", twin(t.amcl_topic, ""), c.on_amcl_pose),
        ):
            if topic is not None:
                handlers[topic] = handler
                self.read[kind] = topic
        return handlers

    def setup(self) -> None:
        self.bag = open_bag(self.path)
        for note in self.bag.notes:
            self.warn(note)
        self._handlers = self._resolve(self.bag)
        self._image = self.read["image"]
        self._messages = iter(self.bag.messages(set(self._handlers)))
        self.exhausted = not self.step()  # the first image and what came with it, for the first sense()

    def advance(self, dt: float) -> None:
        """Play the bag up to the next image (a bag's time moves by messages, not by `dt`)."""
        self.exhausted = not self.step()

    def _next(self) -> tuple[str, str, int, bytes] | None:
        item = self._pending if self._pending is not None else next(self._messages, None)  # type: ignore[arg-type]
        self._pending = None
        if item is None and self.bag is not None and self.bag.damage is not None:
            self.warn(self.bag.damage)
            self.bag.damage = None  # said once
        return item

    def step(self) -> bool:
        """Feed messages up to the next image, plus the non-image messages logged up to ``LOOKAHEAD_S``
        after it (a robot's camera info and depth are often logged just after their image); False at the
        end of the bag (or at the damage in a damaged one)."""
        assert self._messages is not None and self.bag is not None, "call setup() first"
        image_time: int | None = None
        while True:
            item = self._next()
            if item is None:
                return image_time is not None
            topic, msgtype, timestamp, raw = item
            late = timestamp > image_time + self.lookahead_ns if image_time is not None else False
            if image_time is not None and (late or topic == self._image):
                self._pending = item  # belongs to the next step
                return True
            self.clock = timestamp * 1e-9
            if self.first_stamp is None:
                self.first_stamp = self.clock
            try:
                msg = self.bag.deserialize(raw, msgtype)
            except Exception as err:  # bytes that do not decode as the bag's own type
                self.undecodable += 1
                self.cache.log(
                    f"undecodable:{topic}",
                    f"dropped a message on {topic} that does not decode as "
                    f"{msgtype} ({' '.join(str(err).split())[:120]})",
                )
                continue
            self._handlers[topic](msg, topic)
            if topic == self._image:
                image_time = timestamp

    def now(self) -> float:
        return self.clock

    def emit(self, kind: str, msg: Any) -> None:
        self.commands[kind] = self.commands.get(kind, 0) + 1

    def close(self) -> None:
        if self.bag is not None:
            self.bag.close()
            self.bag = None


class _Frames(RunObserver):
    """Collects what perception made of each replayed frame (and hands it to `on_frame` as it comes)."""

    def __init__(self, on_frame: Callable[[FrameResult], None] | None) -> None:
        self.frames: list[FrameResult] = []
        self.on_frame = on_frame

    def on_perception(self, run: Any, perceived: Perceived) -> None:
        if not perceived.processed or perceived.frame is None:
            return
        fr = FrameResult(float(perceived.frame.stamp), perceived.frame.frame_id, list(perceived.detections))
        self.frames.append(fr)
        if self.on_frame is not None:
            self.on_frame(fr)


def recorded_config(path: str | Path) -> dict[str, Any] | None:
    """The config a `mission run --record-bag` run recorded with its bag (metadata.yaml custom_data), or None:
    another tool's bag, a ROS 1 bag, or one made before configs were recorded."""
    import yaml

    from mission.ros.bag_record import RECORDED_CONFIG

    meta = Path(path) / "metadata.yaml"
    if not meta.is_file():
        return None
    try:
        info = (yaml.safe_load(meta.read_text(encoding="utf-8")) or {}).get("rosbag2_bagfile_information") or {}
        text = (info.get("custom_data") or {}).get(RECORDED_CONFIG)
        data = yaml.safe_load(text) if isinstance(text, str) else None
    except (OSError, yaml.YAMLError, AttributeError):
        return None
    return data if isinstance(data, dict) else None


def replay(
    path: str | Path,
    config: MissionConfig,
    *,
    config_file: str | Path | None = None,
    tree: str | None = None,
    rate: float = 0.0,
    on_frame: Callable[[FrameResult], None] | None = None,
    warn: Callable[[str], None] = lambda message: None,
    topics: dict[str, str | None] | None = None,
    calibration: CameraIntrinsics | None = None,
) -> ReplayResult:
    """Step the runner once per recorded image; report each processed frame's detections. `topics`: the
    ``--…-topic`` flags (key → topic, None = not given); `calibration`: a camera model for every frame."""
    from mission.app.runner import TreeRunner, WallClockPacer

    ros_topics, explicit = replay_topics(config, topics)
    world = BagWorld(path, ros_topics, warn=warn, explicit=explicit, calibration=calibration)
    frames = _Frames(on_frame)
    runner = TreeRunner(config, world, tree, config_file=config_file, observers=[frames])
    result = ReplayResult()
    start = time.monotonic()
    try:
        runner.setup()
        if not world.exhausted:
            pacer = WallClockPacer(rate, runner.stop_requested) if rate > 0 else None
            result.status = runner.run(pacer=pacer).name
        result.frames = frames.frames
        result.ticks = runner.ticks
        result.mission_state = str(runner.get(bbk.STATE, "") or "")
        result.stats = {**dict(runner.get(bbk.PERCEPTION_STATS, {}) or {}), **world.cache.stats.to_json()}
        result.commands = dict(world.commands)
        result.bag_s = 0.0 if world.first_stamp is None else world.clock - world.first_stamp
        result.read = dict(world.read)
        result.kind = world.bag.kind if world.bag is not None else ""
        result.interrupted = runner.stop_signal is not None
        result.stop_signal = runner.stop_signal
        runner.finish(result)
    finally:
        runner.close()
    result.wall_s = time.monotonic() - start
    return result
