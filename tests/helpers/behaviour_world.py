"""A tiny scripted world for behaviour tests: geometry in, blackboard inputs out, twists integrated.

This is the edge of the system (what a world adapter and a perception plugin would provide), written
out plainly so each test can say "the target stands here, the robot there, a pillar in between" and tick
real py_trees behaviours against it. Nothing here mocks a behaviour.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import py_trees

from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.config import TargetSpec
from mission.core.types import (
    CameraIntrinsics,
    Detection,
    Frame,
    LaserScan,
    NavStatus,
    OccupancyGrid,
    Pose2D,
    RobotState,
    TargetTrack,
    Twist,
)
from mission.perception_plugins.pipeline import PerceptionStage

# Camera 15 cm ahead of the base centre, 30 cm up, looking forward.
EXTRINSICS = se3.transform(se3.R_BODY_OPTICAL, (0.15, 0.0, 0.30))
HALF_FOV = math.radians(35.0)
IMAGE = np.zeros((48, 64, 3), dtype=np.uint8)


def marker_facing(x: float, y: float, facing_yaw: float, z: float = 0.30) -> np.ndarray:
    """T_map_marker of an upright tag at (x, y, z) whose face (marker z) points along `facing_yaw`."""
    return se3.transform(se3.rot_z(facing_yaw) @ se3.rot_y(math.pi / 2) @ se3.rot_z(math.pi / 2), (x, y, z))


def camera_in_map(robot: Pose2D, extrinsics: np.ndarray = EXTRINSICS) -> np.ndarray:
    return se3.planar(robot.x, robot.y, robot.yaw) @ extrinsics


def detection_of(
    T_map_marker: np.ndarray,
    robot: Pose2D,
    *,
    marker_id: int = 7,
    stamp: float = 0.0,
    source: str = "aruco",
    extra: dict | None = None,
    extrinsics: np.ndarray = EXTRINSICS,
) -> Detection:
    """The detection a perfect camera on `robot` would report for the marker."""
    T_opt_marker = se3.invert(camera_in_map(robot, extrinsics)) @ T_map_marker
    pos, quat = se3.to_pos_quat(T_opt_marker)
    return Detection(
        source=source,
        marker_id=marker_id,
        label=None,
        corners=None,
        position=pos,
        orientation=quat,
        confidence=0.9,
        reprojection_error=0.2,
        stamp=stamp,
        frame_id="camera_optical_frame",
        extra=dict(extra or {}),
    )


def in_view(T_map_marker: np.ndarray, robot: Pose2D, max_range: float = 4.0) -> bool:
    """In front of the camera, inside its horizontal FOV and range, and facing it."""
    T = se3.invert(camera_in_map(robot)) @ T_map_marker
    x, z = T[0, 3], T[2, 3]
    facing = T[2, 2] < -0.2  # marker z points back toward the camera
    return bool(z > 0.05 and abs(math.atan2(x, z)) < HALF_FOV and math.hypot(x, z) < max_range and facing)


def tick(node: py_trees.behaviour.Behaviour, times: int = 1) -> py_trees.common.Status:
    for _ in range(times):
        node.tick_once()
    return node.status


def board() -> py_trees.blackboard.Client:
    return bbk.writer("test")


def read(key: bbk.Key, default: object = None) -> object:
    return bbk.get(board(), key, default)


def grid_with_boxes(
    boxes: list[tuple[float, float, float, float]], size_m: float = 10.0, resolution: float = 0.05
) -> OccupancyGrid:
    """A free square map from (-size/2, -size/2) with occupied axis-aligned boxes (x0, y0, x1, y1)."""
    n = round(size_m / resolution)
    data = np.zeros((n, n), dtype=np.int8)
    grid = OccupancyGrid(data=data, resolution=resolution, origin=Pose2D(-size_m / 2, -size_m / 2, 0.0))
    for x0, y0, x1, y1 in boxes:
        r0, c0 = grid.world_to_cell(x0, y0)
        r1, c1 = grid.world_to_cell(x1, y1)
        data[max(r0, 0) : r1 + 1, max(c0, 0) : c1 + 1] = 100
    return grid


WALL = (1.0, -4.0, 1.2, 1.0)  # a wall 20 cm thick from y = −4 to y = 1 at x ≈ 1.1; open north of y = 1


def lost_at(x: float, y: float, *, last_seen: float = 0.0, walking: tuple[float, float] | None = None) -> TargetTrack:
    """A target last seen at (x, y) at `last_seen`, walking at `walking` (m/s) for the second before."""
    track = TargetTrack("target", last_seen=last_seen, misses=9, pose_map=marker_facing(x, y, math.pi))
    if walking is not None:
        vx, vy = walking
        track.history = [
            (last_seen - 1.0 + 0.1 * i, x - vx * (1.0 - 0.1 * i), y - vy * (1.0 - 0.1 * i)) for i in range(11)
        ]
    bbk.set_(board(), bbk.TRACKS, {"target": track})
    return track


def turns(
    scene: Scene, node: py_trees.behaviour.Behaviour, ticks: int
) -> tuple[list[float], list[py_trees.common.Status]]:
    """Cycle the node; the yaw rate it commanded and its status, tick by tick."""
    rates, statuses = [], []
    for _ in range(ticks):
        statuses.append(scene.cycle(node))
        twist = read(bbk.TWIST)
        rates.append(twist.w if isinstance(twist, Twist) else 0.0)
        if statuses[-1] != py_trees.common.Status.RUNNING:
            break
    return rates, statuses


def legs(rates: list[float]) -> list[int]:
    """The directions turned, in order: +1 left, −1 right (consecutive ticks the same way are one leg)."""
    out: list[int] = []
    for w in rates:
        if abs(w) > 1e-9 and (not out or out[-1] != math.copysign(1, w)):
            out.append(int(math.copysign(1, w)))
    return out


def scan_with_wall(robot: Pose2D, bearing: float, distance: float, half_width: float = 0.1) -> LaserScan:
    """A 360° scan with no returns except an object `distance` away around `bearing` (base frame)."""
    angles = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    ranges = np.full(360, np.inf, dtype=np.float32)
    diff = np.abs(np.arctan2(np.sin(angles - bearing), np.cos(angles - bearing)))
    ranges[diff <= half_width] = distance
    return LaserScan(
        angle_min=-math.pi, angle_increment=2 * math.pi / 360, ranges=ranges, range_min=0.1, range_max=10.0, stamp=0.0
    )


class ScriptedSource:
    """A PerceptionSource whose detections are whatever the test's function returns for the frame."""

    description = "scripted test source"

    def __init__(self, name: str, script: Callable[[Frame], list[Detection]]) -> None:
        self.name = name
        self.script = script
        self.calls = 0

    def process(self, frame: Frame) -> list[Detection]:
        self.calls += 1
        return self.script(frame)

    def close(self) -> None:
        pass


@dataclass
class ScriptedNavigator:
    """A navigator stand-in: takes the newest NAV_GOAL, "drives" for a few ticks, then arrives (or fails)."""

    ticks_to_arrive: int = 3
    unreachable: tuple[tuple[float, float], ...] = ()
    seq: int | None = None
    ticks: int = 0
    goals: list = field(default_factory=list)

    def act(self, scene: Scene) -> None:
        goal = read(bbk.NAV_GOAL)
        if goal is None:
            return
        if goal.seq != self.seq:
            self.seq, self.ticks = goal.seq, 0
            self.goals.append(goal)
            scene.nav_status = NavStatus.RUNNING
            return
        self.ticks += 1
        if self.ticks == self.ticks_to_arrive:
            if any(math.hypot(goal.pose.x - x, goal.pose.y - y) < 1e-6 for x, y in self.unreachable):
                scene.nav_status = NavStatus.FAILED
            else:
                scene.robot = goal.pose
                scene.nav_status = NavStatus.SUCCEEDED


@dataclass
class Scene:
    """Robot + marker geometry with a clock; `sense()` writes what a world adapter would write."""

    robot: Pose2D = field(default_factory=lambda: Pose2D(0.0, 0.0, 0.0))
    marker: np.ndarray | None = None  # T_map_marker
    marker_id: int = 7
    clock: float = 0.0
    dt: float = 1.0 / 15.0
    seq: int = 0
    hidden: bool = False  # scripted occlusion: the camera sees nothing
    noise_m: float = 0.0  # s.d. of position noise (camera frame, per axis)
    noise_rad: float = 0.0  # s.d. of rotation noise (per axis)
    grid: OccupancyGrid | None = None
    scan: LaserScan | None = None
    rng: np.random.Generator = field(default_factory=lambda: np.random.default_rng(0))
    nav_status: str = NavStatus.IDLE
    navigator: ScriptedNavigator | None = None
    occluders: list[tuple[float, float, float, float]] = field(default_factory=list)  # boxes x0, y0, x1, y1
    perception: PerceptionStage | None = None  # the runner's perception stage, when the test wants tracks
    camera: CameraIntrinsics | None = None  # what the frames say of the lens (None: nothing, as before)
    exposure_s: float | None = None  # … and of the shutter

    def perceive_targets(self, targets: dict[str, TargetSpec], policy: str = "hybrid") -> PerceptionStage:
        """Perceive with this scene's camera (a scripted source) before every tick, as the runner does."""
        self.perception = PerceptionStage([self.source()], targets, policy)
        return self.perception

    def occluded(self) -> bool:
        """Does the camera → marker segment pass through an occluder box? (sampled every centimetre)"""
        if self.marker is None:
            return False
        a = camera_in_map(self.robot)[:2, 3]
        b = self.marker[:2, 3]
        for t in np.linspace(0.0, 1.0, max(2, int(np.linalg.norm(b - a) / 0.01))):
            x, y = a + t * (b - a)
            if any(x0 <= x <= x1 and y0 <= y <= y1 for x0, y0, x1, y1 in self.occluders):
                return True
        return False

    def source(self, name: str = "aruco") -> ScriptedSource:
        return ScriptedSource(name, self.detections)

    def detections(self, frame: Frame) -> list[Detection]:
        if self.hidden or self.marker is None or not in_view(self.marker, self.robot) or self.occluded():
            return []
        det = detection_of(self.marker, self.robot, marker_id=self.marker_id, stamp=frame.stamp)
        if self.noise_m or self.noise_rad:
            T = se3.from_pos_quat(det.position, det.orientation)
            R = se3.rvec_to_matrix(self.rng.normal(0.0, self.noise_rad, 3)) @ T[:3, :3]
            det.position = T[:3, 3] + self.rng.normal(0.0, self.noise_m, 3)
            det.orientation = se3.matrix_to_quat(R)
        return [det]

    def sense(self) -> None:
        bb = board()
        self.seq += 1
        bbk.set_(bb, bbk.CLOCK, self.clock)
        bbk.set_(bb, bbk.ROBOT_STATE, RobotState(pose=self.robot, twist=Twist(), stamp=self.clock))
        bbk.set_(bb, bbk.CAMERA_EXTRINSICS, EXTRINSICS)
        bbk.set_(
            bb, bbk.FRAME, Frame(image=IMAGE, stamp=self.clock, intrinsics=self.camera, exposure_s=self.exposure_s)
        )
        bbk.set_(bb, bbk.FRAME_SEQ, self.seq)
        bbk.set_(bb, bbk.NAV_STATUS, self.nav_status)
        if self.grid is not None:
            bbk.set_(bb, bbk.MAP, self.grid)
        if self.scan is not None:
            bbk.set_(bb, bbk.SCAN, self.scan)

    def act(self) -> None:
        """Integrate the commanded TWIST over one step (a unicycle), then advance the clock."""
        if self.navigator is not None:
            self.navigator.act(self)
        twist = read(bbk.TWIST)
        if isinstance(twist, Twist):
            p = self.robot
            yaw = p.yaw + twist.w * self.dt
            mid = p.yaw + 0.5 * twist.w * self.dt
            self.robot = Pose2D(
                p.x + twist.v * self.dt * math.cos(mid), p.y + twist.v * self.dt * math.sin(mid), se3.wrap_angle(yaw)
            )
        self.clock += self.dt

    def perceive(self) -> None:
        """The perception stage on the frame sense() wrote (nothing when the test set no targets)."""
        if self.perception is not None:
            self.perception.update(board())

    def cycle(self, root: py_trees.behaviour.Behaviour) -> py_trees.common.Status:
        """One runner cycle: sense → perceive → tick → act."""
        self.sense()
        self.perceive()
        root.tick_once()
        self.act()
        return root.status
