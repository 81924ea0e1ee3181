"""Every blackboard key, declared once with its type and meaning. Nothing else invents keys.

One namespace per concern:

* ``/perception`` — the newest frame and what the sources saw in it (written by the adapter / perception);
* ``/target``     — per-target tracks built from detections (written by the perception behaviour);
* ``/robot``      — robot state, sensors and map (written by the world adapter);
* ``/goal``       — commands: intent for the adapter (written by behaviours) and navigator feedback;
* ``/mission``    — the mission's own state (written by behaviours, read by viewers and metrics).

Use :func:`register` to give a py_trees blackboard client access to keys by their constant, so a
typo is an AttributeError at import, not a silent new key at run time.
"""

from __future__ import annotations

from dataclasses import dataclass

import py_trees


@dataclass(frozen=True)
class Key:
    path: str  # absolute blackboard path, e.g. "/robot/state"
    type: str  # the Python type stored there (documentation and checks)
    doc: str

    @property
    def namespace(self) -> str:
        return self.path.rsplit("/", 1)[0]

    @property
    def name(self) -> str:
        return self.path.rsplit("/", 1)[1]


# /perception --------------------------------------------------------------------------------------
FRAME = Key("/perception/frame", "Frame | None", "newest camera frame from the adapter")
FRAME_SEQ = Key("/perception/frame_seq", "int", "increments with every new frame; perception runs once per seq")
DETECTIONS = Key("/perception/detections", "list[Detection]", "detections in the last processed frame")
PERCEPTION_STATS = Key(
    "/perception/stats",
    "dict[str, int]",
    "counters: frames_processed, frames_dropped, frames_stale, source_errors:<name>, …",
)

# /target ------------------------------------------------------------------------------------------
TRACKS = Key("/target/tracks", "dict[str, TargetTrack]", "per named target (config perception.targets)")
BELIEFS = Key(
    "/target/beliefs",
    "dict[str, TargetBelief]",
    "per named target, since it was lost: where it can be and what the camera has seen (LOST and SEARCH keep it)",
)

# /robot -------------------------------------------------------------------------------------------
CLOCK = Key("/robot/clock", "float", "now, in the adapter's time base (sim time or ROS time), seconds")
ROBOT_STATE = Key("/robot/state", "RobotState | None", "base pose and velocity in the map frame")
CAMERA_EXTRINSICS = Key("/robot/camera_extrinsics", "ndarray 4×4", "T_base_optical: camera optical frame in base")
SCAN = Key("/robot/scan", "LaserScan | None", "latest 2D lidar scan")
MAP = Key("/robot/map", "OccupancyGrid | None", "the static map (pre-mapping phase)")
MOVERS = Key(
    "/robot/movers",
    "tuple[Mover, ...]",
    "what the lidar sees move that the map does not hold, with its velocity (mission.core.movers); the loop "
    "updates it on every new scan",
)
WORLD_FAULT = Key(
    "/robot/fault",
    "str",
    "why the world's inputs cannot be trusted now (TF missing, stale or looping; the clock jumped back or "
    "stopped; images late); '' when all is well. Written by the adapter",
)

# /goal --------------------------------------------------------------------------------------------
NAV_GOAL = Key("/goal/nav_goal", "NavGoal | None", "goal for the navigator in the map frame (Nav2 /goal_pose)")
TWIST = Key("/goal/twist", "Twist | None", "direct velocity command; when set it overrides navigation")
NAV_STATUS = Key("/goal/nav_status", "str", "NavStatus of the current nav goal, written by the adapter")
NAV_REASON = Key("/goal/nav_reason", "str", "the navigator's word on the current goal: why it failed, or progress")
DOCK_SETPOINT = Key("/goal/dock_setpoint", "DockSetpoint | None", "detected dock pose for a docking server")

# /mission -----------------------------------------------------------------------------------------
STATE = Key("/mission/state", "str", "EXPLORE | DOCK | FOLLOW | LOST | SEARCH | DONE | FAILED")
REASON = Key("/mission/reason", "str", "why the mission (or the current phase) failed or finished")

ALL_KEYS: tuple[Key, ...] = tuple(v for v in list(globals().values()) if isinstance(v, Key))


class MissionState:
    EXPLORE = "EXPLORE"
    DOCK = "DOCK"
    FOLLOW = "FOLLOW"
    LOST = "LOST"
    SEARCH = "SEARCH"
    DONE = "DONE"
    FAILED = "FAILED"


def register(
    client: py_trees.blackboard.Client,
    *,
    read: tuple[Key, ...] = (),
    write: tuple[Key, ...] = (),
) -> None:
    """Give a blackboard client access to declared keys (read, write or both)."""
    for k in read:
        if k not in write:
            client.register_key(key=k.path, access=py_trees.common.Access.READ)
    for k in write:
        client.register_key(key=k.path, access=py_trees.common.Access.WRITE)


def get(client: py_trees.blackboard.Client, key: Key, default: object = None) -> object:
    """Read a declared key through a client, returning `default` when nothing was written yet."""
    try:
        return client.get(key.path)
    except KeyError:
        return default


def set_(client: py_trees.blackboard.Client, key: Key, value: object) -> None:
    """Write a declared key through a client."""
    client.set(key.path, value, overwrite=True)


def writer(name: str) -> py_trees.blackboard.Client:
    """A client that may write every declared key: for world adapters and tests seeding inputs."""
    c = py_trees.blackboard.Client(name=name)
    register(c, write=ALL_KEYS)
    return c
