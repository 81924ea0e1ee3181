"""THE one conversion between ROS messages and the project's types (images, intrinsics, poses, sensors).

Reading works on rclpy messages and on ``rosbags`` messages alike (fields by name, arrays through the
buffer protocol). Building takes a :class:`mission.ros.messages.MessageFactory`, so the same code feeds
a publisher and a bag writer.

Images follow REP 118 / sensor_msgs conventions: ``step`` is the byte length of one row and may be
larger than ``width × bytes per pixel`` (row padding); ``16UC1`` depth is millimetres and ``32FC1`` is
metres, with 0 / NaN meaning "no return". ``sensor_msgs/CompressedImage`` is read as image_transport
writes it: ``compressed`` (JPEG or PNG, ``format`` like ``"bgr8; jpeg compressed bgr8"`` or just
``"jpeg"``) for camera images, ``compressedDepth`` (a 12-byte header, then a PNG of 16-bit millimetres or
of 32-bit depth quantised as inverse depth) for depth. ROS 1 messages (from ``.bag`` files, through
``rosbags``) spell CameraInfo's arrays ``D K R P``; both spellings are read. A message that cannot be
read raises :class:`BadMessage` with a one-line reason; callers drop it, count it and keep running.
"""

from __future__ import annotations

import math
import struct
import sys
from typing import Any

import cv2
import numpy as np

from mission.core import se3
from mission.core.types import CameraIntrinsics, LaserScan, OccupancyGrid, Pose2D, RobotState, Twist
from mission.ros.messages import MessageFactory, header_msg, stamp_to_sec

# encoding → (numpy dtype, channels)
ENCODINGS: dict[str, tuple[np.dtype, int]] = {
    "bgr8": (np.dtype(np.uint8), 3),
    "rgb8": (np.dtype(np.uint8), 3),
    "mono8": (np.dtype(np.uint8), 1),
    "16UC1": (np.dtype(np.uint16), 1),
    "32FC1": (np.dtype(np.float32), 1),
}
COLOUR_ENCODINGS = ("bgr8", "rgb8", "mono8")
DEPTH_ENCODINGS = ("16UC1", "32FC1")
_LITTLE_ENDIAN_HOST = sys.byteorder == "little"


class BadMessage(ValueError):
    """A message that cannot be used. `kind` names the counter it is dropped under."""

    def __init__(self, kind: str, detail: str) -> None:
        super().__init__(detail)
        self.kind = kind  # "encoding" | "size" | "empty" | "value"
        self.detail = detail


# --------------------------------------------------------------------------------------------------
# Images
# --------------------------------------------------------------------------------------------------


def image_to_array(msg: Any, allowed: tuple[str, ...] = tuple(ENCODINGS)) -> np.ndarray:
    """sensor_msgs/Image → numpy, honouring `step` padding and byte order.

    Colour images come back as H×W×3 uint8 **BGR** (rgb8 is converted), mono8 as H×W uint8, 16UC1 as
    H×W uint16 and 32FC1 as H×W float32. The result never aliases the message buffer.
    """
    encoding = str(msg.encoding)
    if encoding not in allowed:
        raise BadMessage("encoding", f"unsupported encoding {encoding!r}; expected one of {', '.join(allowed)}")
    dtype, channels = ENCODINGS[encoding]
    height, width, step = int(msg.height), int(msg.width), int(msg.step)
    data = np.frombuffer(msg.data, dtype=np.uint8)
    if height <= 0 or width <= 0 or data.size == 0:
        raise BadMessage("empty", f"empty image ({width}×{height}, {data.size} bytes)")
    row_bytes = width * channels * dtype.itemsize
    if step < row_bytes:
        raise BadMessage("size", f"step {step} < width×bytes per pixel = {row_bytes} ({encoding}, width {width})")
    if data.size < step * height:
        raise BadMessage(
            "size", f"data has {data.size} bytes, expected step×height = {step}×{height} = {step * height}"
        )
    rows = data[: step * height].reshape(height, step)[:, :row_bytes]
    big_endian = bool(msg.is_bigendian)
    host_order = "<" if _LITTLE_ENDIAN_HOST else ">"
    order = ">" if big_endian else "<"
    pixels = np.ascontiguousarray(rows).view(dtype.newbyteorder(order) if dtype.itemsize > 1 else dtype)
    if dtype.itemsize > 1 and order != host_order:
        pixels = pixels.astype(dtype.newbyteorder(host_order))
    shape = (height, width, channels) if channels > 1 else (height, width)
    out = pixels.reshape(shape)
    if encoding == "rgb8":
        out = cv2.cvtColor(out, cv2.COLOR_RGB2BGR)
    return out.copy() if out.base is not None and np.shares_memory(out, data) else out


def is_compressed(msg: Any) -> bool:
    """A sensor_msgs/CompressedImage (it has a ``format`` where an Image has an ``encoding``)."""
    return hasattr(msg, "format") and not hasattr(msg, "encoding")


def image_to_camera_array(msg: Any) -> np.ndarray:
    """A camera image for perception: bgr8 / rgb8 → H×W×3 BGR, mono8 → H×W; a CompressedImage (JPEG, PNG)
    the same way."""
    if is_compressed(msg):
        return compressed_to_camera_array(msg)
    return image_to_array(msg, COLOUR_ENCODINGS)


def _payload(msg: Any) -> np.ndarray:
    data = np.frombuffer(msg.data, dtype=np.uint8)
    if data.size == 0:
        raise BadMessage("empty", f"compressed image with no data (format {str(msg.format)!r})")
    return data


def _decode(data: np.ndarray, what: str) -> np.ndarray:
    try:
        img = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    except cv2.error:
        img = None
    if img is None:
        raise BadMessage("encoding", f"{what}: the data is not a decodable JPEG or PNG ({data.size} bytes)")
    return img


def compressed_to_camera_array(msg: Any) -> np.ndarray:
    """sensor_msgs/CompressedImage (image_transport ``compressed``: JPEG or PNG) → H×W×3 BGR or H×W mono uint8."""
    fmt = str(msg.format)
    if "compresseddepth" in fmt.lower():
        raise BadMessage("encoding", f"format {fmt!r} is a compressed depth image, not a camera image")
    img = _decode(_payload(msg), f"compressed image (format {fmt!r})")
    if img.dtype != np.uint8:  # a 16-bit colour PNG: 8 bits, as a camera driver would send them
        img = cv2.convertScaleAbs(img, alpha=255.0 / max(1.0, float(img.max())))
    if img.ndim == 3 and img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2BGR)
    if fmt.split(";")[0].strip() == "rgb8" and "compressed bgr8" not in fmt and img.ndim == 3:
        img = cv2.cvtColor(img, cv2.COLOR_RGB2BGR)  # an rgb8 image compressed as it was (no "compressed bgr8")
    return img


COMPRESSED_DEPTH_HEADER = struct.Struct("<iff")  # compressed_depth_image_transport ConfigHeader: format, A, B


def compressed_depth_to_m(msg: Any) -> np.ndarray:
    """sensor_msgs/CompressedImage (image_transport ``compressedDepth``) → H×W float32 metres, NaN = no return.

    The data is a ConfigHeader (int32 format, float32 depthQuantA, depthQuantB) and a PNG: 16-bit
    millimetres for ``16UC1``; for ``32FC1``, inverse depth, ``depth = A / (value − B)`` (0 = no return).
    """
    fmt = str(msg.format)
    data = _payload(msg)
    if "rvl" in fmt.lower():
        raise BadMessage("encoding", f"format {fmt!r}: RVL-compressed depth is not supported (use png)")
    if data.size <= COMPRESSED_DEPTH_HEADER.size:
        raise BadMessage("size", f"compressedDepth data of {data.size} bytes is shorter than its header")
    _, quant_a, quant_b = COMPRESSED_DEPTH_HEADER.unpack(data[: COMPRESSED_DEPTH_HEADER.size].tobytes())
    img = _decode(data[COMPRESSED_DEPTH_HEADER.size :], f"compressed depth (format {fmt!r})")
    if img.dtype != np.uint16 or img.ndim != 2:
        raise BadMessage("encoding", f"compressed depth (format {fmt!r}) is not a 16-bit single-channel PNG")
    encoding = fmt.split(";")[0].strip()
    if encoding == "32FC1":
        with np.errstate(divide="ignore", invalid="ignore"):
            depth = (quant_a / (img.astype(np.float32) - np.float32(quant_b))).astype(np.float32)
        depth[(img == 0) | ~np.isfinite(depth) | (depth <= 0)] = np.nan
        return depth
    depth = img.astype(np.float32) / 1000.0  # 16UC1: millimetres
    depth[img == 0] = np.nan
    return depth


def image_to_depth_m(msg: Any) -> np.ndarray:
    """A depth image → H×W float32 metres, NaN where there is no return (16UC1 mm or 32FC1 m, or a
    ``compressedDepth`` CompressedImage)."""
    if is_compressed(msg):
        return compressed_depth_to_m(msg)
    arr = image_to_array(msg, DEPTH_ENCODINGS)
    if arr.dtype == np.uint16:
        depth = arr.astype(np.float32) / 1000.0
        depth[arr == 0] = np.nan
        return depth
    depth = arr.astype(np.float32, copy=True)
    depth[~np.isfinite(depth) | (depth <= 0)] = np.nan
    return depth


def array_to_image(
    factory: MessageFactory,
    arr: np.ndarray,
    encoding: str,
    stamp: float,
    frame_id: str,
    *,
    step: int | None = None,
) -> Any:
    """numpy → sensor_msgs/Image. Colour input is BGR (as OpenCV and Frame hold it); for ``rgb8`` it is
    converted. ``step`` larger than a row adds zero padding (what some drivers send)."""
    if encoding not in ENCODINGS:
        raise BadMessage("encoding", f"unsupported encoding {encoding!r}; expected one of {', '.join(ENCODINGS)}")
    dtype, channels = ENCODINGS[encoding]
    a = np.asarray(arr)
    if encoding == "16UC1" and a.dtype != np.uint16:  # metres → millimetres, NaN → 0 (no return)
        a = np.nan_to_num(np.asarray(a, np.float64) * 1000.0, nan=0.0, posinf=0.0, neginf=0.0)
        a = np.clip(np.round(a), 0, 65535)
    if encoding == "rgb8":
        a = cv2.cvtColor(np.ascontiguousarray(a, np.uint8), cv2.COLOR_BGR2RGB)
    a = np.ascontiguousarray(a, dtype=dtype.newbyteorder("<") if dtype.itemsize > 1 else dtype)
    if a.ndim != (3 if channels > 1 else 2) or (channels > 1 and a.shape[2] != channels):
        raise BadMessage("size", f"array of shape {a.shape} does not fit encoding {encoding}")
    height, width = a.shape[:2]
    row_bytes = width * channels * dtype.itemsize
    step = row_bytes if step is None else int(step)
    if step < row_bytes:
        raise BadMessage("size", f"step {step} < row size {row_bytes}")
    rows = a.view(np.uint8).reshape(height, row_bytes)
    if step > row_bytes:
        rows = np.concatenate([rows, np.zeros((height, step - row_bytes), np.uint8)], axis=1)
    return factory.new(
        "sensor_msgs/msg/Image",
        header=header_msg(factory, stamp, frame_id),
        height=height,
        width=width,
        encoding=encoding,
        is_bigendian=0,
        step=step,
        data=np.ascontiguousarray(rows).reshape(-1),
    )


def array_to_compressed_image(
    factory: MessageFactory, arr: np.ndarray, fmt: str, stamp: float, frame_id: str, *, quality: int = 90
) -> Any:
    """BGR / mono uint8 → sensor_msgs/CompressedImage as image_transport's ``compressed`` publishes it
    (`fmt` ``jpeg`` or ``png``; ``format`` ``"bgr8; jpeg compressed bgr8"``)."""
    if fmt not in ("jpeg", "png"):
        raise BadMessage("encoding", f"unsupported compression {fmt!r}; expected jpeg or png")
    a = np.ascontiguousarray(arr, dtype=np.uint8)
    encoding = "mono8" if a.ndim == 2 else "bgr8"
    params = [cv2.IMWRITE_JPEG_QUALITY, int(quality)] if fmt == "jpeg" else [cv2.IMWRITE_PNG_COMPRESSION, 3]
    ok, buf = cv2.imencode(".jpg" if fmt == "jpeg" else ".png", a, params)
    if not ok:
        raise BadMessage("encoding", f"OpenCV could not encode a {a.shape} image as {fmt}")
    return factory.new(
        "sensor_msgs/msg/CompressedImage",
        header=header_msg(factory, stamp, frame_id),
        format=f"{encoding}; {fmt} compressed {encoding}",
        data=buf.reshape(-1),
    )


def depth_to_compressed_depth(factory: MessageFactory, depth_m: np.ndarray, stamp: float, frame_id: str) -> Any:
    """H×W metres (NaN = no return) → sensor_msgs/CompressedImage as image_transport's ``compressedDepth``
    publishes a 16UC1 image: the ConfigHeader, then a PNG of millimetres."""
    mm = np.nan_to_num(np.asarray(depth_m, np.float64) * 1000.0, nan=0.0, posinf=0.0, neginf=0.0)
    mm = np.clip(np.round(mm), 0, 65535).astype(np.uint16)
    ok, buf = cv2.imencode(".png", mm)
    if not ok:
        raise BadMessage("encoding", f"OpenCV could not encode a {mm.shape} depth image as PNG")
    data = np.concatenate([np.frombuffer(COMPRESSED_DEPTH_HEADER.pack(0, 0.0, 0.0), np.uint8), buf.reshape(-1)])
    return factory.new(
        "sensor_msgs/msg/CompressedImage",
        header=header_msg(factory, stamp, frame_id),
        format="16UC1; compressedDepth png",
        data=data,
    )


# --------------------------------------------------------------------------------------------------
# Camera calibration
# --------------------------------------------------------------------------------------------------


def camera_info_to_intrinsics(msg: Any) -> CameraIntrinsics:
    """sensor_msgs/CameraInfo (ROS 2 ``k d``, or ROS 1 ``K D``) → CameraIntrinsics; raises BadMessage("value")
    when K is unusable.

    Width/height of 0 are kept (some drivers leave them unset); the caller fills them from the image.
    """
    k = np.asarray(msg.k if hasattr(msg, "k") else msg.K, dtype=np.float64).reshape(-1)
    if k.size != 9:
        raise BadMessage("value", f"camera_info k has {k.size} values, expected 9")
    fx, fy, cx, cy = float(k[0]), float(k[4]), float(k[2]), float(k[5])
    if not all(math.isfinite(v) for v in (fx, fy, cx, cy)) or fx <= 0 or fy <= 0:
        raise BadMessage("value", f"camera_info has fx={fx:g}, fy={fy:g}; expected finite fx > 0 and fy > 0")
    d = np.asarray(msg.d if hasattr(msg, "d") else msg.D, dtype=np.float64).reshape(-1)
    if not np.all(np.isfinite(d)):
        raise BadMessage("value", "camera_info distortion d has non-finite values")
    intr = CameraIntrinsics(
        fx=fx,
        fy=fy,
        cx=cx,
        cy=cy,
        width=int(msg.width),
        height=int(msg.height),
        distortion=tuple(float(v) for v in d),
    )
    problem = intr.problem()
    if problem is not None:  # e.g. a d of the wrong length: OpenCV would reject it on every frame
        raise BadMessage("value", f"camera_info {problem} (distortion_model {str(msg.distortion_model)!r})")
    return intr


def intrinsics_to_camera_info(factory: MessageFactory, intr: CameraIntrinsics, stamp: float, frame_id: str) -> Any:
    """CameraIntrinsics → sensor_msgs/CameraInfo (plumb_bob up to 5 coefficients, rational_polynomial for 8)."""
    d = np.asarray(intr.distortion if intr.distortion else (0.0,) * 5, dtype=np.float64)
    k = intr.matrix.reshape(-1)
    p = np.array([intr.fx, 0.0, intr.cx, 0.0, 0.0, intr.fy, intr.cy, 0.0, 0.0, 0.0, 1.0, 0.0])
    roi = factory.new("sensor_msgs/msg/RegionOfInterest", x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
    return factory.new(
        "sensor_msgs/msg/CameraInfo",
        header=header_msg(factory, stamp, frame_id),
        height=int(intr.height),
        width=int(intr.width),
        distortion_model="rational_polynomial" if d.size >= 8 else "plumb_bob",
        d=d,
        k=k,
        r=np.eye(3).reshape(-1),
        p=p,
        binning_x=0,
        binning_y=0,
        roi=roi,
    )


# --------------------------------------------------------------------------------------------------
# Poses and transforms (4×4 matrices of mission.core.se3)
# --------------------------------------------------------------------------------------------------


def pose_to_matrix(pose: Any) -> np.ndarray:
    """geometry_msgs/Pose → 4×4. Raises BadMessage for a non-finite position or a zero / non-finite
    quaternion (a NaN pose would carry on into the map, the target's place and the goals sent to Nav2)."""
    p, q = pose.position, pose.orientation
    xyz = (float(p.x), float(p.y), float(p.z))
    if not all(math.isfinite(v) for v in xyz):
        raise BadMessage("value", f"pose has a non-finite position ({', '.join(f'{v:g}' for v in xyz)})")
    try:
        return se3.from_pos_quat((p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
    except ValueError as err:
        raise BadMessage("value", f"pose has an invalid orientation: {err}") from None


def matrix_to_pose(factory: MessageFactory, t: np.ndarray) -> Any:
    pos, q = se3.to_pos_quat(t)
    return factory.new(
        "geometry_msgs/msg/Pose",
        position=factory.new("geometry_msgs/msg/Point", x=float(pos[0]), y=float(pos[1]), z=float(pos[2])),
        orientation=factory.new(
            "geometry_msgs/msg/Quaternion", x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])
        ),
    )


def pose_stamped(factory: MessageFactory, t: np.ndarray, stamp: float, frame_id: str) -> Any:
    return factory.new(
        "geometry_msgs/msg/PoseStamped", header=header_msg(factory, stamp, frame_id), pose=matrix_to_pose(factory, t)
    )


def pose_stamped_to_matrix(msg: Any) -> tuple[np.ndarray, float, str]:
    """PoseStamped → (4×4, stamp seconds, frame_id)."""
    return pose_to_matrix(msg.pose), stamp_to_sec(msg.header.stamp), str(msg.header.frame_id)


def pose2d_stamped(factory: MessageFactory, pose: Pose2D, stamp: float, frame_id: str) -> Any:
    return pose_stamped(factory, se3.planar(pose.x, pose.y, pose.yaw), stamp, frame_id)


def transform_stamped(factory: MessageFactory, t: np.ndarray, stamp: float, parent: str, child: str) -> Any:
    """4×4 T_parent_child → geometry_msgs/TransformStamped (what /tf carries)."""
    pos, q = se3.to_pos_quat(t)
    return factory.new(
        "geometry_msgs/msg/TransformStamped",
        header=header_msg(factory, stamp, parent),
        child_frame_id=child,
        transform=factory.new(
            "geometry_msgs/msg/Transform",
            translation=factory.new("geometry_msgs/msg/Vector3", x=float(pos[0]), y=float(pos[1]), z=float(pos[2])),
            rotation=factory.new(
                "geometry_msgs/msg/Quaternion", x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])
            ),
        ),
    )


def transform_to_matrix(tf: Any) -> np.ndarray:
    """geometry_msgs/Transform → 4×4."""
    t, q = tf.translation, tf.rotation
    return se3.from_pos_quat((t.x, t.y, t.z), (q.x, q.y, q.z, q.w))


# --------------------------------------------------------------------------------------------------
# Robot state, scans, maps, commands
# --------------------------------------------------------------------------------------------------


def _pose2d_of(pose: Any) -> Pose2D:
    t = pose_to_matrix(pose)
    return Pose2D(float(t[0, 3]), float(t[1, 3]), se3.yaw_of(t))


def odometry_to_state(msg: Any) -> RobotState:
    """nav_msgs/Odometry → RobotState (planar pose in the odometry's frame, body-frame twist)."""
    tw = msg.twist.twist
    v, w = float(tw.linear.x), float(tw.angular.z)
    if not (math.isfinite(v) and math.isfinite(w)):
        raise BadMessage("value", f"odometry twist is not finite (v={v:g}, w={w:g})")
    return RobotState(
        pose=_pose2d_of(msg.pose.pose),
        twist=Twist(v=v, w=w),
        stamp=stamp_to_sec(msg.header.stamp),
    )


def pose_with_covariance_to_pose2d(msg: Any) -> tuple[Pose2D, float, str]:
    """geometry_msgs/PoseWithCovarianceStamped (AMCL's /amcl_pose) → (Pose2D, stamp, frame_id)."""
    return _pose2d_of(msg.pose.pose), stamp_to_sec(msg.header.stamp), str(msg.header.frame_id)


def pose2d_to_pose_with_covariance(
    factory: MessageFactory, pose: Pose2D, stamp: float, frame_id: str, sigma_m: float, sigma_rad: float
) -> Any:
    """Pose2D → geometry_msgs/PoseWithCovarianceStamped, as AMCL publishes /amcl_pose (x, y, yaw variances)."""
    cov = np.zeros(36)
    cov[0] = cov[7] = sigma_m**2
    cov[35] = sigma_rad**2
    return factory.new(
        "geometry_msgs/msg/PoseWithCovarianceStamped",
        header=header_msg(factory, stamp, frame_id),
        pose=factory.new(
            "geometry_msgs/msg/PoseWithCovariance",
            pose=matrix_to_pose(factory, se3.planar(pose.x, pose.y, pose.yaw)),
            covariance=cov,
        ),
    )


def state_to_odometry(factory: MessageFactory, state: RobotState, frame_id: str, child_frame_id: str) -> Any:
    """RobotState → nav_msgs/Odometry (covariances zero: the sim's ground truth)."""
    t = se3.planar(state.pose.x, state.pose.y, state.pose.yaw)
    vec = lambda x=0.0, y=0.0, z=0.0: factory.new("geometry_msgs/msg/Vector3", x=x, y=y, z=z)  # noqa: E731
    twist = factory.new(
        "geometry_msgs/msg/Twist", linear=vec(x=float(state.twist.v)), angular=vec(z=float(state.twist.w))
    )
    return factory.new(
        "nav_msgs/msg/Odometry",
        header=header_msg(factory, state.stamp, frame_id),
        child_frame_id=child_frame_id,
        pose=factory.new(
            "geometry_msgs/msg/PoseWithCovariance", pose=matrix_to_pose(factory, t), covariance=np.zeros(36)
        ),
        twist=factory.new("geometry_msgs/msg/TwistWithCovariance", twist=twist, covariance=np.zeros(36)),
    )


def scan_from_msg(msg: Any) -> LaserScan:
    """sensor_msgs/LaserScan → LaserScan; NaN and out-of-range returns become inf (no return)."""
    ranges = np.asarray(msg.ranges, dtype=np.float32).copy()
    if ranges.size == 0:
        raise BadMessage("empty", "scan has no ranges")
    rmin, rmax = float(msg.range_min), float(msg.range_max)
    a0, da = float(msg.angle_min), float(msg.angle_increment)
    if not (math.isfinite(a0) and math.isfinite(da) and da != 0.0):
        raise BadMessage("value", f"scan has angle_min={a0:g}, angle_increment={da:g}; expected finite, increment ≠ 0")
    ranges[~np.isfinite(ranges) | (ranges < rmin) | (ranges > rmax)] = np.inf
    return LaserScan(
        angle_min=a0,
        angle_increment=da,
        ranges=ranges,
        range_min=rmin,
        range_max=rmax,
        stamp=stamp_to_sec(msg.header.stamp),
        frame_id=str(msg.header.frame_id),
    )


def scan_to_msg(factory: MessageFactory, scan: LaserScan) -> Any:
    n = len(scan.ranges)
    return factory.new(
        "sensor_msgs/msg/LaserScan",
        header=header_msg(factory, scan.stamp, scan.frame_id),
        angle_min=float(scan.angle_min),
        angle_max=float(scan.angle_min + scan.angle_increment * max(n - 1, 0)),
        angle_increment=float(scan.angle_increment),
        time_increment=0.0,
        scan_time=0.0,
        range_min=float(scan.range_min),
        range_max=float(scan.range_max),
        ranges=np.asarray(scan.ranges, dtype=np.float32),
        intensities=np.zeros(0, dtype=np.float32),
    )


def grid_from_msg(msg: Any) -> OccupancyGrid:
    """nav_msgs/OccupancyGrid → OccupancyGrid (row = y, as the message lays it out)."""
    info = msg.info
    h, w = int(info.height), int(info.width)
    data = np.asarray(msg.data, dtype=np.int8)
    if h <= 0 or w <= 0 or data.size != h * w:
        raise BadMessage("size", f"map has {data.size} cells, expected width×height = {w}×{h}")
    res = float(info.resolution)
    if not (math.isfinite(res) and res > 0):
        raise BadMessage("value", f"map resolution is {res:g}; expected a cell size > 0 (m)")
    return OccupancyGrid(
        data=data.reshape(h, w).copy(),
        resolution=res,
        origin=_pose2d_of(info.origin),
        frame_id=str(msg.header.frame_id) or "map",
    )


def twist_msg(factory: MessageFactory, twist: Twist) -> Any:
    vec = lambda x=0.0, y=0.0, z=0.0: factory.new("geometry_msgs/msg/Vector3", x=x, y=y, z=z)  # noqa: E731
    return factory.new("geometry_msgs/msg/Twist", linear=vec(x=float(twist.v)), angular=vec(z=float(twist.w)))


def grid_to_msg(factory: MessageFactory, grid: OccupancyGrid, stamp: float) -> Any:
    """OccupancyGrid → nav_msgs/OccupancyGrid (what a map server latches on /map)."""
    h, w = grid.data.shape
    o = grid.origin
    info = factory.new(
        "nav_msgs/msg/MapMetaData",
        map_load_time=factory.new("builtin_interfaces/msg/Time", sec=0, nanosec=0),
        resolution=float(grid.resolution),
        width=int(w),
        height=int(h),
        origin=matrix_to_pose(factory, se3.planar(o.x, o.y, o.yaw)),
    )
    return factory.new(
        "nav_msgs/msg/OccupancyGrid",
        header=header_msg(factory, stamp, grid.frame_id or "map"),
        info=info,
        data=np.ascontiguousarray(grid.data, dtype=np.int8).reshape(-1),
    )
