"""The data that flows through the system: frames in, detections out, robot state and commands.

Everything here is a plain dataclass so it can be built in a test, drawn, logged and sent
over any transport. Geometry conventions:

* camera optical frame: x right, y down, z forward (OpenCV / ROS ``*_optical_frame``);
* marker frame: z out of the tag face, x right, y up as seen when facing the tag (OpenCV ArUco);
* map frame: x, y on the floor, z up, yaw counter-clockwise (ROS REP 103);
* quaternions are (x, y, z, w), as in ROS messages.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

# Distortion vector lengths OpenCV accepts (none, plumb_bob 4/5, rational_polynomial 8, thin prism 12, tilted 14).
DISTORTION_LENGTHS = (0, 4, 5, 8, 12, 14)


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole model with optional distortion (OpenCV's plumb_bob / 5-coefficient order)."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    distortion: tuple[float, ...] = ()
    # True for the degraded guess of :meth:`fallback` (no usable calibration): an adapter that substitutes it
    # still lets the sources label their poses "fallback", not "calibrated".
    is_fallback: bool = False

    def is_valid(self) -> bool:
        """False when the calibration cannot be used for pose (zero/negative/NaN focal length, or a
        distortion vector OpenCV rejects: its pose solvers fail on every frame, losing every detection)."""
        return self.problem() is None

    def problem(self, width: int | None = None, height: int | None = None) -> str | None:
        """Why the calibration cannot be used for pose, in a few words (None when it can); with an image
        size, also when it was made for another size (0 × 0 means "not stated" and fits any image)."""
        stated = width is not None and height is not None and self.width and self.height
        if stated and (self.width, self.height) != (width, height):
            return f"calibrated for {self.width}×{self.height}, the image is {width}×{height}"
        vals = (self.fx, self.fy, self.cx, self.cy)
        if not (all(math.isfinite(v) for v in vals) and self.fx > 0 and self.fy > 0):
            return f"fx={self.fx:g}, fy={self.fy:g}, cx={self.cx:g}, cy={self.cy:g}; expected finite fx > 0 and fy > 0"
        if len(self.distortion) not in DISTORTION_LENGTHS:
            lengths = ", ".join(map(str, DISTORTION_LENGTHS))
            return f"distortion has {len(self.distortion)} coefficients; expected {lengths}"
        if not all(math.isfinite(v) for v in self.distortion):
            return "distortion has non-finite coefficients"
        return None

    @property
    def matrix(self) -> np.ndarray:
        """The 3×3 camera matrix K."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]], dtype=np.float64)

    @property
    def dist_coeffs(self) -> np.ndarray:
        """Distortion as OpenCV wants it; empty distortion means zeros (an ideal lens)."""
        if not self.distortion:
            return np.zeros(5, dtype=np.float64)
        return np.asarray(self.distortion, dtype=np.float64)

    @classmethod
    def fallback(cls, width: int, height: int) -> CameraIntrinsics:
        """The degraded-mode pinhole of the design notes: fx = fy = 0.9·W, principal point at the centre."""
        f = 0.9 * width
        return cls(fx=f, fy=f, cx=width / 2.0, cy=height / 2.0, width=width, height=height, is_fallback=True)

    @classmethod
    def from_vertical_fov(
        cls, width: int, height: int, vfov_deg: float, cx: float | None = None, cy: float | None = None
    ) -> CameraIntrinsics:
        """A square-pixel pinhole from a vertical field of view (how renderers specify cameras)."""
        f = (height / 2.0) / math.tan(math.radians(vfov_deg) / 2.0)
        return cls(
            fx=f,
            fy=f,
            cx=width / 2.0 if cx is None else cx,
            cy=height / 2.0 if cy is None else cy,
            width=width,
            height=height,
        )

    def project(self, points_cam: np.ndarray) -> np.ndarray:
        """Project N×3 optical-frame points to N×2 pixels (no distortion)."""
        p = np.asarray(points_cam, dtype=np.float64).reshape(-1, 3)
        return np.stack([self.fx * p[:, 0] / p[:, 2] + self.cx, self.fy * p[:, 1] / p[:, 2] + self.cy], axis=1)

    def rays(self, us: np.ndarray, vs: np.ndarray) -> np.ndarray:
        """N×3 rays (x/z, y/z, 1) of pixels through this lens: undistorted when there is distortion."""
        us, vs = np.asarray(us, dtype=np.float64).ravel(), np.asarray(vs, dtype=np.float64).ravel()
        if any(c != 0.0 for c in self.distortion):
            import cv2  # only a distorted lens needs it

            pts = np.column_stack([us, vs]).reshape(-1, 1, 2)
            xy = cv2.undistortPoints(pts, self.matrix, self.dist_coeffs).reshape(-1, 2)
        else:
            xy = np.column_stack([(us - self.cx) / self.fx, (vs - self.cy) / self.fy])
        return np.column_stack([xy, np.ones(len(xy))])

    def back_project(self, u: float, v: float, depth: float) -> np.ndarray:
        """The optical-frame point at pixel (u, v) and depth z (metres), through the lens."""
        return self.rays(np.array([u]), np.array([v]))[0] * depth

    def to_dict(self) -> dict[str, Any]:
        return {
            "fx": self.fx,
            "fy": self.fy,
            "cx": self.cx,
            "cy": self.cy,
            "width": self.width,
            "height": self.height,
            "distortion": list(self.distortion),
        }


@dataclass(frozen=True)
class Sighting:
    """A pose of a target that something other than our perception reported — a person detector on a topic,
    another robot's TF frame — placed in the anchor frame of the camera frame it arrived with."""

    stamp: float  # when it was seen (the pose's own stamp)
    T_anchor_object: np.ndarray  # 4×4, anchor ← object (TF convention), in the frame's ``anchor_frame``
    origin: str  # where it came from: the topic or the TF frame


@dataclass
class Frame:
    """One camera image as it arrives from a world adapter."""

    image: np.ndarray  # H×W×3 uint8 BGR or H×W mono
    stamp: float  # seconds (sim time or ROS time)
    frame_id: str = "camera_optical_frame"
    intrinsics: CameraIntrinsics | None = None
    depth: np.ndarray | None = None  # H×W float32 metres; NaN/0 = no return
    # Where the camera was when this image was taken: T_anchor_camera (4×4, anchor ← camera optical frame,
    # TF convention of mission.core.se3) at `stamp`, in the frame named `anchor_frame` (odom or map).
    # Optional: an adapter fills it when it knows the robot pose, so a source that reasons across frames
    # (the VLM latch) can hold a world-fixed pose while the robot moves. None = not known for this frame.
    T_anchor_camera: np.ndarray | None = None
    anchor_frame: str = "map"
    # Poses of targets reported by others since the previous frame (the external_pose source reads them):
    # they ride on camera frames, so they are perceived at the camera's rate with what the camera saw.
    sightings: tuple[Sighting, ...] = ()
    # How long the shutter was open for this image (s), as the driver is set: a camera turning at ω smears the
    # image over ω × exposure × fx pixels. None = not known; 0 = an instant (the ideal simulation).
    exposure_s: float | None = None

    def turn_rate_for_smear(self, px: float) -> float:
        """The turn rate (rad/s) at which this frame's exposure smears the image by `px` pixels: the fastest a
        leaf that looks for markers may turn and still read them. Infinite when the exposure is 0 or not
        known, or the intrinsics are (no cap is better than a guessed one)."""
        k = self.intrinsics
        if not self.exposure_s or self.exposure_s <= 0 or k is None or not k.fx > 0:
            return math.inf
        return px / (self.exposure_s * k.fx)

    @property
    def width(self) -> int:
        return int(self.image.shape[1])

    @property
    def height(self) -> int:
        return int(self.image.shape[0])


@dataclass
class Detection:
    """One thing a perception source saw in one frame (see docs/architecture.md, "Contracts")."""

    source: str
    marker_id: int | None
    label: str | None
    corners: np.ndarray | None  # 4×2 px, TL TR BR BL
    position: np.ndarray  # (3,) metres, camera optical frame
    orientation: np.ndarray  # (4,) quaternion x y z w, marker z out of the face
    confidence: float
    reprojection_error: float
    stamp: float
    frame_id: str
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def distance(self) -> float:
        """Range to the camera (m). math.hypot on Python floats: a fifth of np.linalg.norm's cost on a
        3-vector, and leaves read it every tick."""
        p = self.position
        return math.hypot(*(p.tolist() if isinstance(p, np.ndarray) else p))

    def to_json(self) -> dict[str, Any]:
        """A JSON-serialisable dict (lists, floats, None) for `mission detect --json`, logs and ROS debug."""
        return {
            "source": self.source,
            "marker_id": self.marker_id,
            "label": self.label,
            "corners": None if self.corners is None else np.asarray(self.corners, float).round(3).tolist(),
            "position": [round(float(v), 6) for v in self.position],
            "orientation": [round(float(v), 6) for v in self.orientation],
            "confidence": round(float(self.confidence), 4),
            "reprojection_error": round(float(self.reprojection_error), 4),
            "stamp": float(self.stamp),
            "frame_id": self.frame_id,
            "extra": self.extra,
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Detection:
        return cls(
            source=d["source"],
            marker_id=d.get("marker_id"),
            label=d.get("label"),
            corners=None if d.get("corners") is None else np.asarray(d["corners"], dtype=np.float64),
            position=np.asarray(d["position"], dtype=np.float64),
            orientation=np.asarray(d["orientation"], dtype=np.float64),
            confidence=float(d["confidence"]),
            reprojection_error=float(d.get("reprojection_error", 0.0)),
            stamp=float(d["stamp"]),
            frame_id=d.get("frame_id", ""),
            extra=dict(d.get("extra") or {}),
        )


@dataclass(frozen=True)
class Pose2D:
    """A pose on the floor in the map frame."""

    x: float
    y: float
    yaw: float

    def distance_to(self, other: Pose2D) -> float:
        return math.hypot(other.x - self.x, other.y - self.y)


@dataclass(frozen=True)
class Twist:
    """A base velocity command: forward speed (m/s) and yaw rate (rad/s, CCW positive)."""

    v: float = 0.0
    w: float = 0.0


@dataclass
class LaserScan:
    """A planar scan, as sensor_msgs/LaserScan: ranges[i] at angle_min + i·angle_increment (base frame)."""

    angle_min: float
    angle_increment: float
    ranges: np.ndarray  # float32 metres; inf = no return within range_max
    range_min: float
    range_max: float
    stamp: float
    frame_id: str = "base_scan"

    @property
    def angles(self) -> np.ndarray:
        return self.angle_min + self.angle_increment * np.arange(len(self.ranges))


@dataclass
class OccupancyGrid:
    """A 2D map as nav_msgs/OccupancyGrid: data[row, col], row = y, values 0 free, 100 occupied, -1 unknown."""

    data: np.ndarray  # int8 H×W
    resolution: float  # metres per cell
    origin: Pose2D  # map pose of cell (0, 0)'s corner
    frame_id: str = "map"

    def world_to_grid(self, x: float, y: float) -> tuple[float, float]:
        """Continuous (row, col) of map point (x, y) in cell units (cell (r, c) spans [r, r+1) × [c, c+1)).

        Raytracers need the sub-cell position, not just the cell index (see :meth:`world_to_cell`).
        """
        c = math.cos(-self.origin.yaw)
        s = math.sin(-self.origin.yaw)
        dx, dy = x - self.origin.x, y - self.origin.y
        lx, ly = c * dx - s * dy, s * dx + c * dy
        return ly / self.resolution, lx / self.resolution

    def world_to_cells(self, xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) of the cells containing map points (xs, ys), any shape; may be outside the grid."""
        c = math.cos(-self.origin.yaw)
        s = math.sin(-self.origin.yaw)
        dx, dy = np.asarray(xs) - self.origin.x, np.asarray(ys) - self.origin.y
        cols = np.floor((c * dx - s * dy) / self.resolution).astype(np.int64)
        rows = np.floor((s * dx + c * dy) / self.resolution).astype(np.int64)
        return rows, cols

    def world_to_cell(self, x: float, y: float) -> tuple[int, int]:
        """(row, col) of the cell containing map point (x, y); may be outside the grid."""
        c = math.cos(-self.origin.yaw)
        s = math.sin(-self.origin.yaw)
        dx, dy = x - self.origin.x, y - self.origin.y
        lx, ly = c * dx - s * dy, s * dx + c * dy
        return math.floor(ly / self.resolution), math.floor(lx / self.resolution)

    def cell_to_world(self, row: int, col: int) -> tuple[float, float]:
        """Map coordinates of the centre of cell (row, col)."""
        lx, ly = (col + 0.5) * self.resolution, (row + 0.5) * self.resolution
        c, s = math.cos(self.origin.yaw), math.sin(self.origin.yaw)
        return self.origin.x + c * lx - s * ly, self.origin.y + s * lx + c * ly

    def in_bounds(self, row: int, col: int) -> bool:
        return 0 <= row < self.data.shape[0] and 0 <= col < self.data.shape[1]


@dataclass(frozen=True)
class RobotState:
    """Where the robot is and how it moves, in the map frame, at `stamp`."""

    pose: Pose2D
    twist: Twist
    stamp: float


class NavStatus:
    """What the navigator says about the current goal (strings, so they log and serialise as they read)."""

    IDLE = "idle"
    RUNNING = "running"
    SUCCEEDED = "succeeded"
    FAILED = "failed"


@dataclass(frozen=True)
class NavGoal:
    """A goal for the navigator (Nav2's /goal_pose in ROS, the planner stand-in in the sim).

    `seq` increases on every new goal so an adapter can tell a new goal from the same one re-sent.
    """

    pose: Pose2D
    stamp: float
    seq: int
    frame_id: str = "map"


@dataclass(frozen=True)
class DockSetpoint:
    """The dock approach target for a docking server (Nav2 opennav_docking's detected_dock_pose)."""

    pose_camera: tuple[tuple[float, ...], tuple[float, ...]]  # (position xyz, quaternion xyzw), optical frame
    stamp: float


@dataclass
class TargetTrack:
    """What perception knows about one named target (``target``, ``dock``…), kept across frames.

    `visible` changes only on transitions (edge-triggered, like ``/marker_detected``): it turns True on
    the first frame with a matching detection and False on the first frame without one.
    """

    name: str
    visible: bool = False
    last_seen: float | None = None  # stamp of the last frame with a detection
    misses: int = 0  # consecutive processed frames without a detection
    detection: Detection | None = None  # the last matching detection (camera frame)
    pose_map: np.ndarray | None = None  # 4×4 map←target at the last detection
    robot_at_last_seen: Pose2D | None = None
    transitions: int = 0  # how many times `visible` flipped
    # Recent map positions (stamp, x, y) of the target, oldest first, at most a couple of seconds: the
    # goal generator averages them and the line-of-sight check extrapolates a constant velocity from them.
    history: list[tuple[float, float, float]] = field(default_factory=list)
    # … and of its centre, body_depth_m behind the marker (perception.targets): what its velocity is fitted
    # from. A target turning on the spot swings a marker on its face round its centre, and a fit over the
    # marker's placings says it walked off. Empty when body_depth_m is 0 (the centre is the marker) or the
    # track was written by hand: the velocity is fitted from `history` then.
    centres: list[tuple[float, float, float]] = field(default_factory=list)
