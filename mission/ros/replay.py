"""Running the tree on a recorded rosbag2 (mcap or sqlite3), through the same code as the live node.

The bag's messages go into the ROS adapter's :class:`~mission.ros.sensor_cache.SensorCache` (same
conversions, same pairing by stamp, same drop counters) and the runner's one loop steps once per camera
image (the world's ``advance`` plays the bag up to the next image), so every recorded frame is
perceived exactly once, as fast as possible (``rate=0``) or paced to the recorded timing (``rate=1.0``
is real time). SIGINT/SIGTERM end the replay after the current frame with what was replayed so far.
The world does not answer the tree's commands — a bag is open loop — so replay is for perception and
decision logic, not for closing the loop. Needs only ``rosbags`` (no ROS install).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from mission.app.observers import RunObserver
from mission.core import blackboard as bbk
from mission.core.config import MissionConfig
from mission.core.errors import MissionError
from mission.core.types import Detection
from mission.perception_plugins.pipeline import Perceived
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


def _open_reader(path: Path) -> AnyReader:
    if not path.exists():
        raise MissionError(f"{path}: bag not found")
    bag = path.parent if path.is_file() and path.suffix in (".mcap", ".db3", ".yaml") else path
    if bag.is_dir() and not (bag / "metadata.yaml").exists() and any(bag.glob("*.mcap")) | any(bag.glob("*.db3")):
        raise MissionError(
            f"{path}: no metadata.yaml next to the data: the recording was cut off before it was closed "
            f"(`ros2 bag reindex {path}` may recover it)"
        )
    try:
        reader = AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_JAZZY))
        reader.open()
    except Exception as err:  # rosbags raises several unrelated types for unreadable bags
        why = " ".join(str(err).split())
        raise MissionError(f"{path}: not a readable rosbag2 (mcap or sqlite3): {why}") from None
    return reader


class BagWorld(CachedWorld):
    """A WorldAdapter that plays a bag: ``step()`` feeds messages up to and including the next image."""

    def __init__(self, path: str | Path, topics: RosTopics | None = None, warn: Any = lambda message: None) -> None:
        self.exhausted = False  # the bag has no image left: the loop ends
        super().__init__(topics or RosTopics(), BagMessages(get_typestore(Stores.ROS2_JAZZY)), warn=warn)
        self.path = Path(path)
        self.reader: AnyReader | None = None
        self._messages: Iterator[tuple[Any, int, bytes]] | None = None
        self._pending: tuple[Any, int, bytes] | None = None
        self.lookahead_ns = round(LOOKAHEAD_S * 1e9)
        self.commands: dict[str, int] = {}
        self.clock = 0.0
        self.first_stamp: float | None = None

    def setup(self) -> None:
        self.reader = _open_reader(self.path)
        t = self.topics
        handlers: dict[str, Callable[[Any, str], bool]] = {
            t.image_topic: self.cache.on_image,
            t.depth_topic: self.cache.on_depth,
            t.camera_info_topic: self.cache.on_camera_info,
            t.odom_topic: self.cache.on_odometry,
            t.scan_topic: self.cache.on_scan,
            t.map_topic: self.cache.on_map,
            t.amcl_topic: self.cache.on_amcl_pose,
        }
        self._handlers = handlers
        conns = [c for c in self.reader.connections if c.topic in handlers]
        if not any(c.topic == t.image_topic for c in conns):
            topics = ", ".join(sorted({c.topic for c in self.reader.connections})) or "none"
            raise MissionError(f"{self.path}: no {t.image_topic} in this bag (topics: {topics})")
        self._messages = iter(self.reader.messages(connections=conns))
        self.exhausted = not self.step()  # the first image and what came with it, for the first sense()

    def advance(self, dt: float) -> None:
        """Play the bag up to the next image (a bag's time moves by messages, not by `dt`)."""
        self.exhausted = not self.step()

    def step(self) -> bool:
        """Feed messages up to the next image, plus the non-image messages logged up to ``LOOKAHEAD_S``
        after it (a robot's camera info and depth are often logged just after their image); False at the
        end of the bag."""
        assert self._messages is not None and self.reader is not None, "call setup() first"
        image_time: int | None = None
        while True:
            item = self._pending if self._pending is not None else next(self._messages, None)
            self._pending = None
            if item is None:
                return image_time is not None
            conn, timestamp, raw = item
            late = timestamp > image_time + self.lookahead_ns if image_time is not None else False
            if image_time is not None and (late or conn.topic == self.topics.image_topic):
                self._pending = item  # belongs to the next step
                return True
            self.clock = timestamp * 1e-9
            if self.first_stamp is None:
                self.first_stamp = self.clock
            self._handlers[conn.topic](self.reader.deserialize(raw, conn.msgtype), conn.topic)
            if conn.topic == self.topics.image_topic:
                image_time = timestamp

    def now(self) -> float:
        return self.clock

    def emit(self, kind: str, msg: Any) -> None:
        self.commands[kind] = self.commands.get(kind, 0) + 1

    def close(self) -> None:
        if self.reader is not None:
            self.reader.close()
            self.reader = None


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


def replay(
    path: str | Path,
    config: MissionConfig,
    *,
    config_file: str | Path | None = None,
    tree: str | None = None,
    rate: float = 0.0,
    on_frame: Callable[[FrameResult], None] | None = None,
    warn: Callable[[str], None] = lambda message: None,
) -> ReplayResult:
    """Step the runner once per recorded image; report each processed frame's detections."""
    from mission.app.runner import TreeRunner, WallClockPacer

    world = BagWorld(path, warn=warn)
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
        result.interrupted = runner.stop_signal is not None
        result.stop_signal = runner.stop_signal
        runner.finish(result)
    finally:
        runner.close()
    result.wall_s = time.monotonic() - start
    return result
