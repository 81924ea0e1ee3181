"""Recording the simulation's sensors as a rosbag2, so replay (and any ROS tool) has real input.

``mission run --record-bag PATH`` feeds a :class:`BagRecorder` once per tick::

    with BagRecorder("out/run.mcap") as rec:        # .mcap or a directory → mcap; ".db3"/storage="sqlite3" → sqlite3
        rec.record(frame=frame, state=robot_state, scan=scan)

Topics and types are the ones a robot publishes and the ROS node subscribes to: ``/camera/image_raw``
(sensor_msgs/Image bgr8), ``/camera/camera_info``, ``/camera/depth/image_raw`` (32FC1 metres, when the
frame has depth), ``/odom`` (nav_msgs/Odometry) and ``/scan`` (sensor_msgs/LaserScan). With
``compression="jpeg"`` (or ``"png"``) the camera goes where image_transport puts it, as most robots record
it: ``/camera/image_raw/compressed`` (sensor_msgs/CompressedImage) and, for depth,
``/camera/depth/image_raw/compressedDepth`` (16-bit PNG of millimetres). Each message is logged at its own
header stamp. Written with ``rosbags`` (no ROS install needed); ``ros2 bag play`` plays the result.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import TracebackType
from typing import Any

from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from mission.core.errors import MissionError
from mission.core.files import ensure_dir, unwritable
from mission.core.observers import RunObserver, Tick
from mission.core.types import Frame, LaserScan, RobotState
from mission.ros.conversions import (
    array_to_compressed_image,
    array_to_image,
    depth_to_compressed_depth,
    intrinsics_to_camera_info,
    scan_to_msg,
    state_to_odometry,
)
from mission.ros.messages import BagMessages

TYPESTORE = Stores.ROS2_JAZZY

DEFAULT_TOPICS = {
    "image": ("/camera/image_raw", "sensor_msgs/msg/Image"),
    "camera_info": ("/camera/camera_info", "sensor_msgs/msg/CameraInfo"),
    "depth": ("/camera/depth/image_raw", "sensor_msgs/msg/Image"),
    "odom": ("/odom", "nav_msgs/msg/Odometry"),
    "scan": ("/scan", "sensor_msgs/msg/LaserScan"),
}
COMPRESSED_TOPICS = {  # image_transport's names for the compressed camera
    "image": ("/camera/image_raw/compressed", "sensor_msgs/msg/CompressedImage"),
    "depth": ("/camera/depth/image_raw/compressedDepth", "sensor_msgs/msg/CompressedImage"),
}
COMPRESSIONS = ("jpeg", "png")


def storage_for(path: Path, storage: str | None) -> StoragePlugin:
    """mcap unless asked for sqlite3 (``storage="sqlite3"`` or a path ending in .db3)."""
    name = (storage or ("sqlite3" if path.suffix == ".db3" else "mcap")).lower()
    if name not in ("mcap", "sqlite3"):
        raise MissionError(f"{path}: unknown bag storage {storage!r}; expected mcap or sqlite3")
    return StoragePlugin.MCAP if name == "mcap" else StoragePlugin.SQLITE3


class BagRecorder:
    """Writes camera, camera info, depth, odometry and scan messages to a new rosbag2 directory."""

    def __init__(
        self,
        path: str | Path,
        *,
        storage: str | None = None,
        odom_frame: str = "odom",
        base_frame: str = "base_link",
        compression: str | None = None,
    ) -> None:
        p = Path(path)
        if compression is not None and compression not in COMPRESSIONS:
            expected = ", ".join(COMPRESSIONS)
            raise MissionError(f"{p}: unknown image compression {compression!r}; expected one of {expected}")
        self.compression = compression
        self.topics = {**DEFAULT_TOPICS, **(COMPRESSED_TOPICS if compression else {})}
        self.path = p.with_suffix("") if p.suffix in (".mcap", ".db3") else p  # rosbag2 bags are directories
        self.storage = storage_for(p, storage)
        self.odom_frame = odom_frame
        self.base_frame = base_frame
        self.typestore = get_typestore(TYPESTORE)
        self.msgs = BagMessages(self.typestore)
        self.counts: dict[str, int] = {k: 0 for k in DEFAULT_TOPICS}
        self._writer: Writer | None = None
        self._connections: dict[str, Any] = {}
        self._last_stamp: dict[str, float] = {}

    # -- lifecycle ---------------------------------------------------------------------------------
    @property
    def partial_path(self) -> Path:
        """Where the bag grows while recording (``<path>.partial/<name>``, so its data file already has its
        final name, which metadata.yaml records); moved to `path` when closed. A bag at `path` is therefore
        always complete: a killed run leaves ``<path>.partial`` without metadata.yaml, never a broken `path`."""
        return self.path.with_name(self.path.name + ".partial") / self.path.name

    def check(self) -> BagRecorder:
        """A MissionError now, when recording would fail later: a bag or an interrupted recording in the way,
        or a directory the bag cannot be made in (created here, as a report directory is)."""
        if self.path.exists():
            raise MissionError(f"{self.path}: exists already; a bag is never overwritten")
        if self.partial_path.parent.exists():
            raise MissionError(
                f"{self.partial_path.parent}: an interrupted recording to {self.path} is in the way "
                f"(`ros2 bag reindex {self.partial_path}` may recover it); move or delete it to record again"
            )
        try:
            ensure_dir(self.path.parent)
        except OSError as err:
            raise MissionError(f"{self.path}: {unwritable(err, self.path, directory=True)}") from None
        return self

    def open(self) -> BagRecorder:
        self.check()
        try:
            self.partial_path.parent.mkdir(parents=True)
            self._writer = Writer(self.partial_path, version=9, storage_plugin=self.storage)
            self._writer.open()
        except OSError as err:
            raise MissionError(f"{self.path}: cannot record a bag here ({err.strerror or err})") from err
        for key, (topic, msgtype) in self.topics.items():
            self._connections[key] = self._writer.add_connection(topic, msgtype, typestore=self.typestore)
        return self

    def note(self, key: str, value: str) -> None:
        """A line of the bag's metadata.yaml ``custom_data`` (rosbag2's own place for it): what made the bag."""
        if self._writer is not None:
            self._writer.set_custom_data(key, value)

    def close(self) -> None:
        if self._writer is not None:
            self._writer.close()  # writes metadata.yaml: from here on the bag is readable
            self._writer = None
            self.partial_path.rename(self.path)
            self.partial_path.parent.rmdir()

    def __enter__(self) -> BagRecorder:
        return self.open()

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    # -- writing -----------------------------------------------------------------------------------
    def _write(self, key: str, msg: Any, stamp: float) -> None:
        if self._writer is None:
            raise MissionError(f"{self.path}: the recorder is not open")
        msgtype = self.topics[key][1]
        data = self.typestore.serialize_cdr(msg, msgtype)
        self._writer.write(self._connections[key], max(0, round(stamp * 1e9)), data)
        self.counts[key] += 1

    def write_frame(self, frame: Frame) -> None:
        """The image (bgr8, or mono8 for a mono frame; or compressed), its camera info and its depth, at the
        frame's stamp."""
        encoding = "mono8" if frame.image.ndim == 2 else "bgr8"
        if frame.intrinsics is not None:  # before the image, as camera drivers publish them
            info = intrinsics_to_camera_info(self.msgs, frame.intrinsics, frame.stamp, frame.frame_id)
            self._write("camera_info", info, frame.stamp)
        if self.compression:
            image = array_to_compressed_image(self.msgs, frame.image, self.compression, frame.stamp, frame.frame_id)
        else:
            image = array_to_image(self.msgs, frame.image, encoding, frame.stamp, frame.frame_id)
        self._write("image", image, frame.stamp)
        if frame.depth is not None:
            if self.compression:
                depth = depth_to_compressed_depth(self.msgs, frame.depth, frame.stamp, frame.frame_id)
            else:
                depth = array_to_image(self.msgs, frame.depth, "32FC1", frame.stamp, frame.frame_id)
            self._write("depth", depth, frame.stamp)

    def write_state(self, state: RobotState) -> None:
        self._write("odom", state_to_odometry(self.msgs, state, self.odom_frame, self.base_frame), state.stamp)

    def write_scan(self, scan: LaserScan) -> None:
        self._write("scan", scan_to_msg(self.msgs, scan), scan.stamp)

    def record(
        self, *, frame: Frame | None = None, state: RobotState | None = None, scan: LaserScan | None = None
    ) -> None:
        """One tick's worth of sensors (any may be None). A message whose stamp is not newer than the last
        one recorded on its topic is skipped, so a runner may pass the blackboard's values every tick."""
        for key, item, write in (
            ("odom", state, self.write_state),
            ("scan", scan, self.write_scan),
            ("image", frame, self.write_frame),
        ):
            if item is not None and item.stamp > self._last_stamp.get(key, -math.inf):
                self._last_stamp[key] = item.stamp
                write(item)


RECORDED_CONFIG = "mission.config"  # metadata.yaml custom_data key: the recording run's config, as YAML


class BagObserver(RunObserver):
    """A run observer (mission.core.observers.RunObserver) that records the sensors the tree saw each tick.

    ``mission run --record-bag PATH``: ``observers.append(BagObserver(PATH))``. It reads the newest
    frame, robot state and scan from the runner's blackboard after every tick (the values the adapter
    wrote in ``sense()``), so it works with any world adapter.
    """

    def __init__(self, path: str | Path, *, storage: str | None = None) -> None:
        self.recorder = BagRecorder(path, storage=storage).check()  # before the simulation starts, not after

    def on_start(self, runner: Any) -> None:
        import yaml

        self.recorder.open()
        # the run's config goes with its bag: `mission replay BAG` perceives what the run perceived
        config = runner.config.model_dump(mode="json", exclude_defaults=True)
        self.recorder.note(RECORDED_CONFIG, yaml.safe_dump(config, sort_keys=False))

    def on_tick(self, runner: Any, tick: Tick) -> None:
        from mission.core import blackboard as bbk

        self.recorder.record(frame=runner.get(bbk.FRAME), state=runner.get(bbk.ROBOT_STATE), scan=runner.get(bbk.SCAN))

    def on_end(self, runner: Any, outcome: Any) -> None:
        self.recorder.close()
