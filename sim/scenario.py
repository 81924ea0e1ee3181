"""Scenario files: the room, what is in it, what moves, and how the robot senses it.

A scenario is YAML under ``sim/scenarios/`` validated by the models below (unknown keys are errors,
every error is one line naming the file and the dotted key). Geometry that cannot be simulated — a
robot starting inside a pillar, a waypoint outside the room — is rejected at load time with the key
that is wrong, because a run that starts from an impossible state only produces confusing metrics.

Frames: the room's south-west inner corner is the map origin, x east, y north, z up; yaw in degrees
counter-clockwise from +x. The sim's world frame *is* the map frame.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import ClassVar, Literal

from pydantic import Field, model_validator

from mission.core.config import Renamed, StrictModel, load_model, validate_model
from mission.core.errors import ConfigError
from mission.core.perception import TARGET_LABEL
from mission.sim.geometry import Footprint
from mission.sim.markers import dictionary_size, quad_side

SCENARIO_DIR = Path(__file__).resolve().parent / "scenarios"

Vec2 = tuple[float, float]
Vec3 = tuple[float, float, float]
RGB = tuple[float, float, float]


class Room(StrictModel):
    size: Vec2 = (8.0, 8.0)  # inner size x, y (m); the room spans [0, sx] × [0, sy]
    wall_height: float = Field(1.0, gt=0)  # m
    wall_thickness: float = Field(0.1, gt=0)  # m
    wall_color: RGB = (0.82, 0.80, 0.74)  # RGB 0–1
    floor_color: RGB = (0.55, 0.55, 0.57)  # RGB 0–1

    @model_validator(mode="after")
    def _positive(self) -> Room:
        if min(self.size) <= 0.5:
            raise ValueError(f"room size must be > 0.5 m per side, got {list(self.size)}")
        return self


class Obstacle(StrictModel):
    """A box or an upright cylinder standing on the floor."""

    shape: Literal["box", "cylinder"] = "box"  # box or cylinder
    x: float  # centre in the map frame (m)
    y: float  # centre in the map frame (m)
    yaw_deg: float = 0.0  # boxes only
    size: Vec3 = (0.5, 0.5, 1.0)  # box: full extents x, y, z (m)
    radius: float = Field(0.15, gt=0)  # cylinder
    height: float = Field(1.0, gt=0)  # cylinder
    color: RGB = (0.45, 0.47, 0.52)  # RGB 0–1
    name: str | None = None  # for messages and reports

    @property
    def top(self) -> float:
        return self.size[2] if self.shape == "box" else self.height


class Jitter(StrictModel):
    xy_m: float = Field(0.0, ge=0)
    yaw_deg: float = Field(0.0, ge=0)


class RobotSpec(StrictModel):
    x: float = 1.0  # start position in the map frame (m)
    y: float = 1.0  # start position in the map frame (m)
    yaw_deg: float = 0.0  # start heading (°, 0 = +x)
    radius: float = Field(0.22, gt=0.05, le=1.0)  # round base: the collision footprint
    height: float = Field(0.28, gt=0)  # m
    max_v: float = Field(0.6, gt=0)  # m/s
    max_w: float = Field(2.0, gt=0)  # rad/s
    acc_v: float = Field(2.5, gt=0)  # m/s², Nav2 DWB's acc_lim_x
    acc_w: float = Field(3.2, gt=0)  # rad/s², Nav2 DWB's acc_lim_theta
    color: RGB = (0.15, 0.15, 0.17)  # RGB 0–1


class Marker(StrictModel):
    renamed_keys: ClassVar[dict[str, Renamed]] = {"size_m": "marker_size_m"}  # before one word for it (issue 31)

    face: Literal["front", "back", "left", "right"] = "back"  # box faces: front = +x of the target body
    dictionary: str = "DICT_APRILTAG_36h11"  # an OpenCV dictionary name (DICT_APRILTAG_36h11 is tag36h11)
    id: int = Field(7, ge=0)  # marker id in that dictionary
    marker_size_m: float = Field(0.20, gt=0)  # side of the black square (a detector's marker_size_m)
    quiet_cells: int = Field(1, ge=1, le=4)  # white border around the black square, in code cells
    printed_scale: float = Field(1.0, gt=0.5, lt=1.5)  # as printed ÷ marker_size_m: 0.98 is 2 % small (issue 33)
    height_m: float | None = None  # centre height above the floor; default: camera height, capped by the box

    @property
    def printed_size_m(self) -> float:
        """The black square's side as printed: what the camera sees (the config says marker_size_m)."""
        return self.marker_size_m * self.printed_scale


class Waypoint(StrictModel):
    x: float  # map frame (m)
    y: float  # map frame (m)
    pause_s: float = Field(0.0, ge=0)  # wait here before going on
    speed_mps: float | None = Field(None, gt=0)  # speed on the leg towards this waypoint (default: target's)


_FACES = ("back", "left", "right")  # a target's default marked faces


class TargetSpec(StrictModel):
    """A box carrying markers that drives along waypoints (a person-sized stand-in for the followed thing)."""

    x: float = 3.0  # start position in the map frame (m)
    y: float = 1.0  # start position in the map frame (m)
    yaw_deg: float = 0.0  # start heading (°)
    size: Vec3 = (0.40, 0.40, 0.70)  # box extents x, y, z (m)
    color: RGB = (0.85, 0.08, 0.08)  # red: the VLM stub looks for a "red box"
    label: str = TARGET_LABEL  # what it is called: the VLM source's label finds it
    markers: list[Marker] = Field(default_factory=lambda: [Marker(face=f) for f in _FACES])  # its tags
    waypoints: list[Waypoint] = Field(default_factory=list)  # the path the target walks, in order
    speed_mps: float = Field(0.35, gt=0)  # walking speed (m/s)
    turn_rate_dps: float = Field(120.0, gt=0)  # turning speed at waypoints (°/s)
    start_delay_s: float = Field(2.0, ge=0)  # standing still before it starts walking
    loop: bool = False  # after the last waypoint drive back to the first and around again
    leave_at_end: bool = False  # after its last waypoint (and pause) it leaves the map: gone from the world

    @model_validator(mode="after")
    def _leaves_or_loops(self) -> TargetSpec:
        if self.leave_at_end and self.loop:
            raise ValueError("leave_at_end and loop cannot both be set: a looping target never reaches its end")
        return self


class MovingObstacle(Obstacle):
    """An obstacle the map does not know that drives along waypoints (a cart, a person crossing): the lidar
    and the camera see it; it waits while the robot stands in its way."""

    waypoints: list[Waypoint] = Field(default_factory=list)  # its path, in order
    speed_mps: float = Field(0.4, gt=0)  # driving speed (m/s)
    turn_rate_dps: float = Field(90.0, gt=0)  # turning speed at waypoints (°/s)
    start_delay_s: float = Field(0.0, ge=0)  # standing still before it starts
    loop: bool = False  # after the last waypoint drive back to the first and around again


class DockSpec(StrictModel):
    """A wall-mounted tag; the approach axis is the tag's normal (yaw_deg: the direction it faces)."""

    renamed_keys: ClassVar[dict[str, Renamed]] = {"size_m": "marker_size_m"}  # before one word for it (issue 31)

    x: float  # tag centre in the map frame (m)
    y: float  # tag centre in the map frame (m)
    yaw_deg: float  # direction the tag face points, i.e. the robot approaches along yaw_deg + 180°
    z: float | None = None  # tag centre height; default: camera height
    dictionary: str = "DICT_APRILTAG_36h11"  # an OpenCV dictionary name
    id: int = Field(0, ge=0)  # tag id
    marker_size_m: float = Field(0.15, gt=0)  # side of the black square (m)
    quiet_cells: int = Field(1, ge=1, le=4)  # white border around the black square, in code cells
    printed_scale: float = Field(1.0, gt=0.5, lt=1.5)  # as printed ÷ marker_size_m: 0.98 is 2 % small (issue 33)

    @property
    def printed_size_m(self) -> float:
        """The black square's side as printed: what the camera sees (the config says marker_size_m)."""
        return self.marker_size_m * self.printed_scale


class Lighting(StrictModel):
    direction: Vec3 = (0.4, -0.3, 1.0)  # towards the light
    ambient: float = Field(0.6, ge=0, le=1)  # pybullet ambient coefficient
    diffuse: float = Field(0.4, ge=0, le=1)  # pybullet diffuse coefficient
    specular: float = Field(0.05, ge=0, le=1)  # pybullet specular coefficient
    image_noise_sigma: float = Field(2.0, ge=0)  # Gaussian noise (grey levels) added to every image
    gloss: float = Field(0.0, ge=0, le=1)  # printed markers mirror the light: glare up to this × 255 (issue 33)


class Mount(StrictModel):
    """Camera optical centre in the base frame (x forward, y left, z up); pitch down positive."""

    x: float = 0.17  # forward of the robot base (m)
    y: float = 0.0  # left of the robot base (m)
    z: float = 0.35  # above the floor (m)
    pitch_deg: float = 0.0  # down is positive


class CameraSpec(StrictModel):
    width: int = Field(640, ge=16, le=4096)  # px
    height: int = Field(480, ge=16, le=4096)  # px
    vfov_deg: float = Field(60.0, gt=5, lt=170)  # vertical field of view (°); fx = fy from it
    rate_hz: float = Field(15.0, gt=0, le=120)  # frames per simulated second
    renderer: Literal["tiny", "egl"] = "tiny"  # tiny: TinyRenderer (CPU); egl: the EGL plugin where available
    depth: bool = False  # also render a depth image in metres
    near_m: float = Field(0.05, gt=0)  # clipping plane (m)
    far_m: float = Field(20.0, gt=0)  # clipping plane (m)
    max_range_m: float = Field(6.0, gt=0)  # ground truth "in FOV" also needs the marker within this range
    mount: Mount = Field(default_factory=Mount)
    # a real camera (sim/camera_model.py); all off: the ideal pinhole
    distortion: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)  # the lens: k1 k2 p1 p2 k3
    lens_calibrated: bool = True  # the detector is told the lens's distortion; false: told none (uncorrected)
    exposure_s: float = Field(0.0, ge=0, le=0.2)  # motion blur over this exposure (s); 0: rendered at an instant
    calibration_focal_pct: float = Field(0.0, ge=0, le=20)  # σ of the told focal length's error (%)
    calibration_center_px: float = Field(0.0, ge=0, le=50)  # σ of the told principal point's error (px)
    calibration_k1: float = Field(0.0, ge=0, le=1)  # σ of the told k1's error
    latency_s: float = Field(0.0, ge=0, le=1)  # frames arrive this long after their exposure (stamped at it)
    latency_jitter_s: float = Field(0.0, ge=0, le=1)  # plus up to this much more, uniform, seeded
    depth_noise_pct_at_2m: float = Field(0.0, ge=0, le=20)  # stereo depth σ at 2 m (% of range), ∝ distance²
    depth_edge_holes_m: float = Field(0.0, ge=0)  # no depth where neighbours differ by more than this; 0: off
    scene_brightness: float = Field(1.0, gt=0, le=2)  # the light: 1 well lit; 0.3 dim (gain up, noise with it)
    light_variation: float = Field(0.0, ge=0, lt=1)  # brighter facing the light, darker away: ± this fraction
    auto_exposure_s: float = Field(0.0, ge=0, le=10)  # the gain follows the light with this time constant; 0: at once
    jpeg_quality: int = Field(0, ge=0, le=100)  # images as a compressed topic delivers them (1–100); 0: raw


class LidarSpec(StrictModel):
    beams: int = Field(360, ge=8, le=4096)  # rays per scan over 360°
    range_min_m: float = Field(0.12, ge=0)  # m
    range_max_m: float = Field(8.0, gt=0)  # m; beyond reads as inf
    rate_hz: float = Field(10.0, gt=0, le=100)  # scans per simulated second
    height_m: float = Field(0.20, gt=0)  # scan plane above the floor
    noise_sigma_m: float = Field(0.005, ge=0)  # Gaussian range noise (m)


class MapSpec(StrictModel):
    resolution: float = Field(0.05, gt=0.005, le=0.5)  # occupancy grid cell size (m)


class NavSpec(StrictModel):
    """The Nav2 stand-in (sim/navigator.py)."""

    inflation_m: float = Field(0.08, ge=0)  # clearance added to the robot radius when planning
    goal_tolerance_m: float = Field(0.15, gt=0)  # succeeded within this distance of the goal
    yaw_tolerance_rad: float = Field(0.2, gt=0)  # and within this heading
    max_v: float = Field(0.5, gt=0)  # path following speed limit (m/s)
    max_w: float = Field(1.5, gt=0)  # turn rate limit (rad/s)
    lookahead_m: float = Field(0.45, gt=0)  # pure-pursuit look-ahead distance
    replan_period_s: float = Field(2.0, gt=0)  # replan on the grid + lidar obstacles this often
    stuck_timeout_s: float = Field(8.0, gt=0)  # no progress for this long → failed


class RandomSpec(StrictModel):
    """Per-seed variation (seed N of `mission run --seed N`)."""

    start_xy_m: float = Field(0.10, ge=0)  # robot start jitter, uniform ± (m)
    start_yaw_deg: float = Field(5.0, ge=0)  # robot start heading jitter, uniform ± (°)
    timing_frac: float = Field(0.15, ge=0, lt=1)  # target speed, pauses and start delay scaled by 1 ± this
    marker_shift_m: float = Field(0.005, ge=0)  # marker mounted off-centre on its face by up to this
    marker_tilt_deg: float = Field(1.0, ge=0)  # and rotated in its plane by up to this


class Success(StrictModel):
    """What the runner checks at the end: follow, dock, mission (both), give_up (the search ends, with a reason).

    give_up is for a target that leaves the map (target.leave_at_end): the run succeeds when the tree fails
    with the search's reason within give_up_within_s of the target leaving — it never searches for ever."""

    kind: Literal["follow", "dock", "mission", "give_up", "tree"] = "tree"  # …, or tree: the tree's SUCCESS
    standoff_m: float = Field(0.30, gt=0)  # docking: camera-to-tag distance the dock means
    min_tracking_fraction: float = Field(0.7, ge=0, le=1)  # follow: time in FOLLOW seeing it / the follow phase
    give_up_within_s: float = Field(120.0, gt=0)  # give_up: the search must end with a reason this soon after


class Blackout(StrictModel):
    at_s: float = Field(ge=0)  # sim time it starts
    frames: int = Field(ge=1)  # camera periods without any frame


class Dropout(StrictModel):
    at_s: float = Field(ge=0)  # sim time it starts
    duration_s: float = Field(gt=0)  # how long


class Teleport(StrictModel):
    at_s: float = Field(ge=0)  # sim time of the jump
    skip_s: float = Field(gt=0)  # the target jumps this much of its path's time ahead


class Kick(StrictModel):
    at_s: float = Field(ge=0)  # sim time of the bump
    dx: float = 0.0  # map frame (m)
    dy: float = 0.0
    dyaw_deg: float = 0.0


class VlmFault(StrictModel):
    mode: Literal["timeout", "garbage"]  # raise TimeoutError, or answer NaN / out-of-image / non-list
    every: int = Field(1, ge=1)  # every k-th model call fails
    delay_s: float = Field(0.0, ge=0, le=30)  # timeout: how long the call hangs before it raises


class Faults(StrictModel):
    """Injected faults (sim/faults.py): what the field gets wrong, on purpose and repeatably per seed."""

    camera_blackout: list[Blackout] = Field(default_factory=list)  # [{at_s, frames}]: no frames for N periods
    frame_drop_prob: float = Field(0.0, ge=0, le=1)  # each frame lost with this probability
    frame_duplicate_prob: float = Field(0.0, ge=0, le=1)  # each frame delivered twice (same image and stamp)
    late_frame_prob: float = Field(0.0, ge=0, le=1)  # held back late_by_s, delivered with its old stamp
    late_by_s: float = Field(0.3, gt=0, le=10)  # how late a late frame arrives
    lidar_dropout: list[Dropout] = Field(default_factory=list)  # [{at_s, duration_s}]: no scans
    target_teleport: list[Teleport] = Field(default_factory=list)  # [{at_s, skip_s}]: jumps ahead on its path
    robot_kick: list[Kick] = Field(default_factory=list)  # [{at_s, dx, dy, dyaw_deg}]: bumped off its path
    plugin_raise_every: int = Field(0, ge=0)  # 0: off; k: the source raises on every k-th frame
    plugin_raise_source: str | None = None  # only this source (by name); None: every source
    vlm: VlmFault | None = None  # {mode: timeout|garbage, every, delay_s}: the VLM client misbehaves

    @model_validator(mode="after")
    def _probabilities(self) -> Faults:
        total = self.frame_drop_prob + self.frame_duplicate_prob + self.late_frame_prob
        if total > 1.0 + 1e-9:
            raise ValueError(f"frame_drop_prob + frame_duplicate_prob + late_frame_prob must be ≤ 1, got {total:g}")
        return self


class LocalizationSpec(StrictModel):
    """Where the robot believes it is (sim/localization.py): drifting wheel odometry, an AMCL-like corrector.
    All zero: a perfect localization (the robot knows its true pose)."""

    odom_scale_error_pct: float = Field(0.0, ge=0, le=20)  # σ of the run's distance scale error (%)
    odom_yaw_error_pct: float = Field(0.0, ge=0, le=20)  # σ of the run's rotation scale error (%)
    odom_noise_m_per_m: float = Field(0.0, ge=0, le=1)  # random walk of the distance (m per √m driven)
    amcl: bool = True  # a localizer pulls the estimate back to the truth (with odometry drift only)
    update_min_d: float = Field(0.25, gt=0)  # it updates after this much motion (Nav2 amcl's default, m)
    update_min_a: float = Field(0.2, gt=0)  # … or this much turning (Nav2 amcl's default, rad)
    amcl_sigma_m: float = Field(0.03, ge=0)  # its error at each update (m, each axis)
    amcl_sigma_rad: float = Field(0.02, ge=0)  # its heading error at each update (rad)
    relocalize_every_m: float = Field(0.0, ge=0)  # now and then an update lands off (mean metres between); 0: never
    relocalize_sigma_m: float = Field(0.2, ge=0)  # how far off such an update lands (m, each axis)
    relocalize_sigma_rad: float = Field(0.1, ge=0)  # … and its heading (rad)


class ExternalDetector(StrictModel):
    """A detector other than the robot's camera reporting the target's pose — a person tracker, another robot —
    which ``mission sim-robot`` publishes (geometry_msgs/PoseStamped in the map frame, and a TF frame), for a
    node that follows by Nav2's FollowObject. It sees the target in line of sight of the robot's camera, all
    round (no field of view), within range; noisy, with dropouts, all seeded."""

    topic: str = "/target_pose"  # where the poses go ('' = none)
    frame: str = ""  # also broadcast map → this TF frame ('' = no TF)
    rate_hz: float = Field(10.0, gt=0, le=100)  # how often it reports
    noise_m: float = Field(0.03, ge=0)  # σ of the position error (m, each axis)
    dropout: float = Field(0.05, ge=0, lt=1)  # probability a report is lost
    range_m: float = Field(8.0, gt=0)  # it sees the target this far
    line_of_sight: bool = True  # only when nothing solid stands between the camera and the target
    silent_after_s: float | None = Field(None, ge=0)  # stops reporting at this sim time (a detector that died)


class Scenario(StrictModel):
    name: str  # shown in reports
    # how real the robot's senses are (sim/realism.py): a profile of camera and localization keys laid under
    # the scenario's own, which win
    realism: Literal["ideal", "typical", "harsh"] = "ideal"
    description: str = ""  # one line for people reading the file
    duration_s: float = Field(60.0, gt=0)  # simulated seconds of the run
    tree: str = "mission.xml"  # tree file (trees/ name or path) when the config does not choose one
    config: str = ""  # mission config when none is given: a shipped config's name or a file beside this one
    success: Success = Field(default_factory=Success)
    room: Room = Field(default_factory=Room)  # walls round the world
    obstacles: list[Obstacle] = Field(default_factory=list)  # static: in the pre-built map
    unknown_obstacles: list[Obstacle] = Field(default_factory=list)  # not in the map; the lidar sees them
    moving_obstacles: list[MovingObstacle] = Field(default_factory=list)  # not in the map, driving along waypoints
    robot: RobotSpec = Field(default_factory=RobotSpec)  # our robot
    target: TargetSpec | None = None
    dock: DockSpec | None = None
    lighting: Lighting = Field(default_factory=Lighting)  # light and image noise
    camera: CameraSpec = Field(default_factory=CameraSpec)  # the robot camera
    lidar: LidarSpec = Field(default_factory=LidarSpec)  # the robot 2D lidar
    map: MapSpec = Field(default_factory=MapSpec)  # the pre-built occupancy grid
    navigation: NavSpec = Field(default_factory=NavSpec)
    random: RandomSpec = Field(default_factory=RandomSpec)
    faults: Faults = Field(default_factory=Faults)  # injected faults (sim/faults.py); none by default
    localization: LocalizationSpec = Field(default_factory=LocalizationSpec)  # odometry drift, AMCL jumps
    external_detector: ExternalDetector | None = None  # reports the target's pose (sim/external_detector.py)


# --------------------------------------------------------------------------------------------------
# Geometry checks
# --------------------------------------------------------------------------------------------------


def obstacle_footprint(ob: Obstacle) -> Footprint:
    """The obstacle's outline on the floor."""
    if ob.shape == "cylinder":
        return Footprint("circle", ob.x, ob.y, r=ob.radius, name=ob.name or "")
    return Footprint("box", ob.x, ob.y, math.radians(ob.yaw_deg), ob.size[0] / 2, ob.size[1] / 2, name=ob.name or "")


def obstacle_distance(ob: Obstacle, x: float, y: float) -> float:
    """Signed floor distance from (x, y) to the obstacle's footprint (negative inside)."""
    return obstacle_footprint(ob).distance(x, y)


def _check_point(
    sc: Scenario, x: float, y: float, clearance: float, key: str, file: str | None, *, unknown: bool = True
) -> None:
    sx, sy = sc.room.size
    if not (clearance <= x <= sx - clearance and clearance <= y <= sy - clearance):
        raise ConfigError(
            f"({x:g}, {y:g}) is outside the room [0, {sx:g}] × [0, {sy:g}] (with {clearance:g} m clearance)",
            file=file,
            key=key,
        )
    groups = [("obstacles", sc.obstacles)] + ([("unknown_obstacles", sc.unknown_obstacles)] if unknown else [])
    for group, obs in groups:
        for i, ob in enumerate(obs):
            d = obstacle_distance(ob, x, y)
            if d < clearance:
                what = ob.name or f"{group}[{i}]"
                raise ConfigError(
                    f"({x:g}, {y:g}) is {'inside' if d < 0 else 'too close to'} {what} "
                    f"(needs {clearance:g} m clearance)",
                    file=file,
                    key=key,
                )


LEG_STEP_M = 0.05


def _check_legs(
    sc: Scenario, start: Vec2, waypoints: list[Waypoint], loop: bool, clearance: float, key: str, file: str | None
) -> None:
    """Each leg of a path (start → waypoint → … → back to the start when it loops) keeps `clearance` from the
    obstacles: nothing in the simulation stops a target walking through a cabinet, so the scenario must not
    ask it to."""
    points = [start, *((w.x, w.y) for w in waypoints)] + ([start] if loop and waypoints else [])
    obstacles = [*sc.obstacles, *sc.unknown_obstacles]
    for i in range(1, len(points)):
        (ax, ay), (bx, by) = points[i - 1], points[i]
        n = max(1, math.ceil(math.hypot(bx - ax, by - ay) / LEG_STEP_M))
        for ob in obstacles:
            for k in range(n + 1):
                x, y = ax + (bx - ax) * k / n, ay + (by - ay) * k / n
                if obstacle_distance(ob, x, y) < clearance:
                    where = f"waypoints[{i - 1}]" if i <= len(waypoints) else "loop"
                    raise ConfigError(
                        f"the leg from ({ax:g}, {ay:g}) to ({bx:g}, {by:g}) passes through {ob.name or 'an obstacle'} "
                        f"at ({x:.2f}, {y:.2f}) (needs {clearance:g} m clearance)",
                        file=file,
                        key=f"{key}.{where}",
                    )


def _check_code(dictionary_name: str, marker_id: int, key: str, file: str | None) -> None:
    try:
        n = dictionary_size(dictionary_name)
    except ValueError as err:
        raise ConfigError(str(err), file=file, key=f"{key}.dictionary") from None
    if marker_id >= n:
        raise ConfigError(f"id {marker_id} is not in {dictionary_name} (ids 0..{n - 1})", file=file, key=f"{key}.id")


DOCK_WALL_TOLERANCE_M = 0.05  # how far off a wall a dock tag may be and still hang on it
DOCK_FACING_TOLERANCE_DEG = 45.0  # how far from the wall's inward normal the tag may face


def _check_dock_on_wall(sc: Scenario, file: str | None) -> None:
    """A dock tag hangs on a wall, faces into the room, and has room in front for the robot to line up.

    Without this a dock in mid-room or facing the wall loads fine and the mission just never docks."""
    d, (sx, sy) = sc.dock, sc.room.size
    assert d is not None
    walls = [
        ("x = 0", abs(d.x), 0.0),
        ("x = " + f"{sx:g}", abs(d.x - sx), 180.0),
        ("y = 0", abs(d.y), 90.0),
        ("y = " + f"{sy:g}", abs(d.y - sy), -90.0),
    ]
    name, off, inward = min(walls, key=lambda w: w[1])
    if off > DOCK_WALL_TOLERANCE_M:
        raise ConfigError(
            f"({d.x:g}, {d.y:g}) is {off:.2f} m from the nearest wall ({name}); a dock tag hangs on a wall: "
            f"expected x in {{0, {sx:g}}} or y in {{0, {sy:g}}} (±{DOCK_WALL_TOLERANCE_M:g} m)",
            file=file,
            key="dock",
        )
    turn = abs((d.yaw_deg - inward + 180.0) % 360.0 - 180.0)
    if turn > DOCK_FACING_TOLERANCE_DEG:
        raise ConfigError(
            f"{d.yaw_deg:g}° turns the tag {turn:.0f}° away from facing into the room (it hangs on the wall "
            f"at {name}); expected about {inward:g}°, the direction the tag face points",
            file=file,
            key="dock.yaw_deg",
        )
    yaw = math.radians(d.yaw_deg)
    reach = sc.success.standoff_m + sc.camera.mount.x  # the robot centre when docked: camera standoff + mount
    ax, ay = d.x + reach * math.cos(yaw), d.y + reach * math.sin(yaw)
    try:
        _check_point(sc, ax, ay, sc.robot.radius, "dock", file, unknown=False)
    except ConfigError as err:
        raise ConfigError(
            f"no room to dock: the docked robot at ({ax:.2f}, {ay:.2f}), {reach:.2f} m in front of the tag, "
            f"{err.detail.split(' ', 2)[2]}",
            file=file,
            key="dock",
        ) from None


def check_geometry(sc: Scenario, file: str | None = None) -> None:
    """Reject scenarios whose start states or paths are impossible (robot or target inside things)."""
    _check_point(sc, sc.robot.x, sc.robot.y, sc.robot.radius, "robot", file)
    for group in ("obstacles", "unknown_obstacles"):
        for i, ob in enumerate(getattr(sc, group)):
            if ob.shape == "box" and min(ob.size) <= 0:
                raise ConfigError(f"box size must be > 0, got {list(ob.size)}", file=file, key=f"{group}[{i}].size")
            sx, sy = sc.room.size
            if not (0 <= ob.x <= sx and 0 <= ob.y <= sy):
                raise ConfigError(f"({ob.x:g}, {ob.y:g}) is outside the room", file=file, key=f"{group}[{i}]")
    for i, mover in enumerate(sc.moving_obstacles):
        key = f"moving_obstacles[{i}]"
        reach = mover.radius if mover.shape == "cylinder" else 0.5 * math.hypot(mover.size[0], mover.size[1])
        if mover.shape == "box" and min(mover.size) <= 0:
            raise ConfigError(f"box size must be > 0, got {list(mover.size)}", file=file, key=f"{key}.size")
        _check_point(sc, mover.x, mover.y, reach, key, file, unknown=False)
        for j, wp in enumerate(mover.waypoints):
            _check_point(sc, wp.x, wp.y, reach, f"{key}.waypoints[{j}]", file, unknown=False)
        side = mover.radius if mover.shape == "cylinder" else 0.5 * min(mover.size[0], mover.size[1])
        _check_legs(sc, (mover.x, mover.y), mover.waypoints, mover.loop, side, key, file)
        if math.hypot(mover.x - sc.robot.x, mover.y - sc.robot.y) < reach + sc.robot.radius:
            raise ConfigError("starts on top of the robot", file=file, key=key)
    if sc.target is not None:
        t = sc.target
        half = 0.5 * math.hypot(t.size[0], t.size[1])
        _check_point(sc, t.x, t.y, half, "target", file)
        for i, wp in enumerate(t.waypoints):
            _check_point(sc, wp.x, wp.y, half, f"target.waypoints[{i}]", file)
        _check_legs(sc, (t.x, t.y), t.waypoints, t.loop, 0.5 * min(t.size[0], t.size[1]), "target", file)
        if math.hypot(t.x - sc.robot.x, t.y - sc.robot.y) < half + sc.robot.radius:
            raise ConfigError("target starts on top of the robot", file=file, key="target")
        for i, m in enumerate(t.markers):
            _check_code(m.dictionary, m.id, f"target.markers[{i}]", file)
            face_w = t.size[1] if m.face in ("front", "back") else t.size[0]
            side = quad_side(m.dictionary, m.printed_size_m, m.quiet_cells)
            if side > min(face_w, t.size[2]) + 1e-9:
                raise ConfigError(
                    f"marker with quiet zone ({side:.3g} m) does not fit on the {m.face} face "
                    f"({face_w:g} × {t.size[2]:g} m)",
                    file=file,
                    key=f"target.markers[{i}].marker_size_m",
                )
    if sc.dock is not None:
        sx, sy = sc.room.size
        d = sc.dock
        _check_code(d.dictionary, d.id, "dock", file)
        if not (-1e-6 <= d.x <= sx + 1e-6 and -1e-6 <= d.y <= sy + 1e-6):
            raise ConfigError(f"({d.x:g}, {d.y:g}) is outside the room", file=file, key="dock")
        _check_dock_on_wall(sc, file)
        if sc.target is not None:
            for i, m in enumerate(sc.target.markers):
                if (m.dictionary, m.id) == (d.dictionary, d.id):  # perception could not tell them apart
                    raise ConfigError(
                        f"id {m.id} of {m.dictionary} is also the dock's; expected distinct codes on target and dock",
                        file=file,
                        key=f"target.markers[{i}].id",
                    )
    if sc.camera.far_m <= sc.camera.near_m:
        raise ConfigError("far_m must be greater than near_m", file=file, key="camera.far_m")
    if sc.lidar.range_max_m <= sc.lidar.range_min_m:
        raise ConfigError("range_max_m must be greater than range_min_m", file=file, key="lidar.range_max_m")


# --------------------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------------------


def shipped_scenarios() -> list[str]:
    """Names of the scenarios that ship with the package."""
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.yaml"))


def scenario_path(name_or_path: str) -> Path:
    """A bare name is a shipped scenario; anything path-like (or an existing file) is a path."""
    p = Path(name_or_path)
    looks_like_path = p.suffix in (".yaml", ".yml") or "/" in name_or_path or p.is_file()
    if looks_like_path:
        return p
    candidate = SCENARIO_DIR / f"{name_or_path}.yaml"
    if not candidate.is_file():
        raise ConfigError(
            f"unknown scenario {name_or_path!r}; shipped: {', '.join(shipped_scenarios())} (or give a YAML path)",
            key="scenario",
        )
    return candidate


def load_scenario(name_or_path: str) -> Scenario:
    """A validated scenario from a shipped name (``follow_open``) or a YAML path."""
    path = scenario_path(name_or_path)
    sc = load_model(Scenario, path)
    check_geometry(sc, str(path))
    return sc


def scenario_from_dict(data: dict, *, file: str | None = None) -> Scenario:
    """Validate an in-memory scenario (tests, generated sweeps) with the same checks as a file."""
    sc = validate_model(Scenario, data, file=file)
    check_geometry(sc, file)
    return sc
