"""What a goal of Nav2's docking and following actions makes of our trees, without ROS: the tree's inputs from
the goal and the dock database, Nav2's feedback state from the node the tree is in, Nav2's error code from the
node that failed.

The servers (mission/ros/task_servers.py) put this on rclpy. Keeping it apart lets the simulation tests run a
goal's tree in-process exactly as the server will, and keeps the mapping in one readable place:

* **Feedback.** A node named after one of the action's feedback states (``NAV_TO_STAGING_POSE``,
  ``INITIAL_PERCEPTION``, ``CONTROLLING`` …) puts the goal in that state while it runs. A tree of your own
  reports Nav2's states by naming its nodes the same way. Back at staging for another attempt is ``RETRY``
  (Nav2's state while it resets the approach).
* **Errors.** The last such node that failed gives the result's code: for DockRobot, NAV_TO_STAGING_POSE →
  FAILED_TO_STAGE, INITIAL_PERCEPTION → FAILED_TO_DETECT_DOCK, CONTROLLING → FAILED_TO_CONTROL. The node's
  reason (what ``/mission/reason`` says) is the ``error_msg``. A failure no named node explains is UNKNOWN.
* **Before the tree.** A ``dock_id`` not in the database is DOCK_NOT_IN_DB, a dock type not configured is
  DOCK_NOT_VALID; no tree starts and the robot is not moved.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import py_trees

from mission.core.config import TargetSpec
from mission.core.types import Pose2D
from mission.ros.nav2_params import Dock, DockingParams, DockType, FollowingParams

Status = py_trees.common.Status


@dataclass(frozen=True)
class TaskSpec:
    """One action as a tree: which file runs it, and how its nodes read as Nav2's states and errors."""

    action: str  # the nav2_msgs action type, e.g. "DockRobot"
    tree: str  # the shipped tree (a parameter points the server at another)
    states: Mapping[str, str]  # node name → the feedback state constant it reports
    errors: Mapping[str, str]  # node name → the result error constant its failure gives
    retry_state: str = "RETRY"  # the state of going back to staging for another attempt
    retry_from: str = ""  # the state that is a retry after the first attempt ('' = none)

    @property
    def phases(self) -> frozenset[str]:
        return frozenset(self.states) | frozenset(self.errors)


DOCK_ROBOT = TaskSpec(
    action="DockRobot",
    tree="dock_robot.xml",
    states={
        "NAV_TO_STAGING_POSE": "NAV_TO_STAGING_POSE",
        "INITIAL_PERCEPTION": "INITIAL_PERCEPTION",
        "CONTROLLING": "CONTROLLING",
        "WAIT_FOR_CHARGE": "WAIT_FOR_CHARGE",
        "RETURN_TO_STAGING": "NAV_TO_STAGING_POSE",  # after the last attempt (Nav2 stays where it failed)
    },
    errors={
        "NAV_TO_STAGING_POSE": "FAILED_TO_STAGE",
        "INITIAL_PERCEPTION": "FAILED_TO_DETECT_DOCK",
        "CONTROLLING": "FAILED_TO_CONTROL",
        "WAIT_FOR_CHARGE": "FAILED_TO_CHARGE",
    },
    retry_from="NAV_TO_STAGING_POSE",
)

UNDOCK_ROBOT = TaskSpec(
    action="UndockRobot",
    tree="undock_robot.xml",
    states={},  # UndockRobot's feedback is empty
    errors={"CONTROLLING": "FAILED_TO_CONTROL"},
)


FOLLOW_OBJECT = TaskSpec(
    action="FollowObject",
    tree="follow_object.xml",
    states={
        "INITIAL_PERCEPTION": "INITIAL_PERCEPTION",
        "CONTROLLING": "CONTROLLING",
        "LOST": "RETRY",  # Nav2 retries after a loss; our ladder pursues, then searches
        "SEARCH": "RETRY",
    },
    errors={
        "INITIAL_PERCEPTION": "FAILED_TO_DETECT_OBJECT",
        "CONTROLLING": "FAILED_TO_CONTROL",
        "SEARCH": "FAILED_TO_DETECT_OBJECT",
    },
)


class TaskRejected(Exception):
    """A goal that cannot start (no tree runs, the robot is not moved): Nav2's error constant and why."""

    def __init__(self, error: str, message: str) -> None:
        super().__init__(message)
        self.error = error
        self.message = message


class PhaseWatch(py_trees.visitors.VisitorBase):
    """Which of the action's named nodes the tree is in, and which failed last, with its reason.

    A py_trees visitor sees every ticked node right after its update, before a parent resets it, so a node
    that fails and is retried within the same tick is still seen failing."""

    def __init__(self, spec: TaskSpec) -> None:
        super().__init__(full=False)
        self.spec = spec
        self.current: str | None = None  # the deepest named node running at the end of the last tick
        self.passed: list[str] = []  # the named nodes the last tick ran or finished, in the order it did
        self.failed: str | None = None  # the last named node that failed
        self.reason = ""  # its feedback message when it failed
        self._running: str | None = None
        self._passed: list[str] = []

    def initialise(self) -> None:
        self._running = None
        self._passed = []

    def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        name = behaviour.name
        if name not in self.spec.phases:
            return
        if behaviour.status in (Status.RUNNING, Status.SUCCESS) and name not in self._passed:
            self._passed.append(name)  # a phase done within one tick (seen at once) is still a phase
        if behaviour.status == Status.RUNNING:
            self._running = name  # leaves are visited after their parents: the deepest wins
        elif behaviour.status == Status.FAILURE and name in self.spec.errors:
            self.failed, self.reason = name, str(behaviour.feedback_message or "")

    def finalise(self) -> None:
        self.current = self._running
        self.passed = self._passed


def feedback_state(spec: TaskSpec, watch: PhaseWatch, attempt: int, phase: str | None = None) -> str:
    """The feedback state constant's name for where the tree is (NONE before any named node runs), or for
    `phase` (one of the named nodes)."""
    phase = watch.current if phase is None else phase
    state = spec.states.get(phase or "", "NONE")
    if spec.retry_from and attempt > 1 and state == spec.retry_from and phase != "RETURN_TO_STAGING":
        return spec.retry_state
    return state


def feedback_states(spec: TaskSpec, watch: PhaseWatch, attempt: int) -> list[str]:
    """Every state the last tick went through, in order, ending where the tree is: a phase the tree finished
    within one tick (the dock already in view: INITIAL_PERCEPTION) is reported too, as Nav2's servers do
    before they wait for anything. Empty before the tree reaches a named node (a node still waiting for its
    camera does not tick it): Nav2's servers never send NONE as feedback."""
    states = [feedback_state(spec, watch, attempt, p) for p in watch.passed if p in spec.states]
    states.append(feedback_state(spec, watch, attempt))
    states = [s for s in states if s != "NONE"]
    return [s for i, s in enumerate(states) if i == 0 or s != states[i - 1]]


def failure(spec: TaskSpec, watch: PhaseWatch, reason: str) -> tuple[str, str]:
    """(error constant name, error_msg) for a tree that ended in FAILURE; `reason` is /mission/reason."""
    if watch.failed is None:
        return "UNKNOWN", reason or "the tree failed"
    return spec.errors[watch.failed], watch.reason or reason or f"{watch.failed} failed"


# --- DockRobot ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class DockGoal:
    """A DockRobot goal's fields (nav2_msgs/action/DockRobot), as plain values."""

    use_dock_id: bool = True
    dock_id: str = ""
    dock_pose: Pose2D | None = None  # when not use_dock_id
    dock_frame: str = ""  # dock_pose's header.frame_id ('' = the map frame)
    dock_type: str = ""
    max_staging_time: float = 1000.0
    navigate_to_staging_pose: bool = True


@dataclass(frozen=True)
class TaskPlan:
    """What a goal starts: the tree and its inputs, and what perception must look for."""

    tree: str
    inputs: Mapping[str, Any]
    dock: Dock | None = None
    dock_type: DockType | None = None
    retarget: Mapping[str, TargetSpec] = field(default_factory=dict)  # perception target → what it is now


def _dock_target(dock: Dock) -> dict[str, TargetSpec]:
    """The dock's ``id`` is what the camera reads on it (Nav2: "e.g. for use with AprilTag detection"): a
    number is the marker id of the ``dock`` target, a word its label; no id keeps the config's dock target."""
    ident = dock.id.strip()
    if not ident:
        return {}
    if ident.isdigit():
        return {"dock": TargetSpec(marker_id=int(ident))}
    return {"dock": TargetSpec(label=ident)}


def _in_map(frame: str, map_frame: str, what: str) -> None:
    if frame and frame != map_frame:
        raise TaskRejected(
            "DOCK_NOT_VALID", f"{what} is in frame {frame!r}; this server takes docks in the map frame {map_frame!r}"
        )


def plan_dock(
    goal: DockGoal,
    params: DockingParams,
    robot: Pose2D | None,
    *,
    tree: str = DOCK_ROBOT.tree,
    map_frame: str = "map",
) -> TaskPlan:
    """The DockRobot tree's inputs for `goal` (dock_robot.xml's header lists them), or TaskRejected."""
    if goal.use_dock_id:
        dock = params.find_dock(goal.dock_id)
        if dock is None:
            known = ", ".join(sorted(params.docks)) or "none (no docks or dock_database given)"
            raise TaskRejected("DOCK_NOT_IN_DB", f"dock {goal.dock_id!r} is not in the dock database; known: {known}")
    else:
        if goal.dock_pose is None:
            raise TaskRejected("DOCK_NOT_VALID", "use_dock_id is false and the goal has no dock_pose")
        p = goal.dock_pose
        dock = Dock("dock_pose", goal.dock_type, p.x, p.y, p.yaw, goal.dock_frame or map_frame)
    dock_type = params.find_type(dock.type)
    if dock_type is None:
        known = ", ".join(params.dock_types) or "none"
        raise TaskRejected("DOCK_NOT_VALID", f"dock type {dock.type!r} is not one of dock_plugins: {known}")
    _in_map(dock.frame, map_frame, f"dock {dock.name!r}")
    staging = Pose2D(*dock.staging_pose(dock_type))
    navigate = goal.navigate_to_staging_pose
    if navigate and robot is not None:
        # docking_server.cpp: within dock_prestaging_tolerance (x, y, yaw as one L2 norm) the robot stays
        near = math.hypot(robot.x - staging.x, robot.y - staging.y, _angle(robot.yaw - staging.yaw))
        navigate = near >= params.dock_prestaging_tolerance
    inputs = {
        "staging_pose": staging,
        "navigate_to_staging_pose": navigate,
        "max_staging_time": float(goal.max_staging_time),
        "num_attempts": int(params.max_retries) + 1,
        "initial_perception_timeout": float(params.initial_perception_timeout),
        "dock_approach_timeout": float(params.dock_approach_timeout),
    }
    return TaskPlan(tree, inputs, dock, dock_type, _dock_target(dock))


# --- UndockRobot ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class UndockGoal:
    """An UndockRobot goal's fields."""

    dock_type: str = ""
    max_undocking_time: float = 30.0


def plan_undock(
    goal: UndockGoal,
    params: DockingParams,
    robot: Pose2D | None,
    docked_type: str = "",
    *,
    tree: str = UNDOCK_ROBOT.tree,
) -> TaskPlan:
    """The UndockRobot tree's inputs: the staging pose from where the robot is now (docking_server.cpp's
    undockRobot: the robot's pose is the dock's), with the goal's dock type, the one the server last docked
    at, or the only one configured."""
    name = goal.dock_type or docked_type
    dock_type = params.find_type(name)
    if dock_type is None:
        known = ", ".join(params.dock_types) or "none"
        why = (
            f"dock type {name!r} is not one of dock_plugins: {known}"
            if name
            else (f"no dock type given, none docked at by this server, and more than one configured: {known}")
        )
        raise TaskRejected("DOCK_NOT_VALID", why)
    if robot is None:
        raise TaskRejected("UNKNOWN", "no robot pose yet (odometry / TF): cannot place the staging pose")
    yaw = robot.yaw + (math.pi if params.dock_backwards else 0.0)
    here = Dock("robot", dock_type.name, robot.x, robot.y, yaw)
    inputs = {
        "staging_pose": Pose2D(*here.staging_pose(dock_type)),
        "undock_backward": not params.dock_backwards,
        "max_undocking_time": float(goal.max_undocking_time),
        "undock_linear_tolerance": float(params.undock_linear_tolerance),
        "undock_angular_tolerance": float(params.undock_angular_tolerance),
    }
    return TaskPlan(tree, inputs, None, dock_type)


def _angle(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))


# --- FollowObject ---------------------------------------------------------------------------------------

EXTERNAL_SOURCE = "external_pose"  # the source instance that turns the goal's poses into detections


@dataclass(frozen=True)
class FollowGoal:
    """A FollowObject goal's fields."""

    pose_topic: str = ""
    tracked_frame: str = ""
    max_duration: float = 0.0  # s; 0 = until canceled


def plan_follow(goal: FollowGoal, params: FollowingParams, *, tree: str = FOLLOW_OBJECT.tree) -> TaskPlan:
    """The FollowObject tree's inputs; `target` is retargeted to the external poses. ``tracked_frame`` wins over
    ``pose_topic`` when both are given, as in opennav_following."""
    if not goal.pose_topic and not goal.tracked_frame:
        raise TaskRejected("FAILED_TO_DETECT_OBJECT", "No pose topic or target frame provided.")
    inputs = {
        "detection_timeout": float(params.detection_timeout),
        "desired_distance": float(params.desired_distance),
    }
    return TaskPlan(tree, inputs, retarget={"target": TargetSpec(source=EXTERNAL_SOURCE)})
