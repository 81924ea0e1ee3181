"""A client for Nav2's docking and following actions with nav2_simple_commander's names.

``dock_robot`` (nav2_msgs/action/DockRobot), ``undock_robot`` (UndockRobot) and ``follow_object``
(FollowObject), driven the way Nav2 users drive them with ``BasicNavigator`` (navigation2's
nav2_simple_commander/robot_navigator.py, branch main, where the following methods are)::

    with TaskClient() as nav:
        nav.dockRobotByID("home_dock")
        while not nav.isTaskComplete():
            feedback = nav.getFeedback()  # DockRobot.Feedback: state, docking_time, num_retries
        if nav.getResult() is not TaskResult.SUCCEEDED:
            print(nav.getTaskError())  # (901, "dock 'x' is not in the database")

Semantics kept from BasicNavigator:

* ``dockRobotByID`` / ``dockRobotByPose`` / ``undockRobot`` / ``followObjectByTopic`` / ``followObjectByFrame``
  send one goal, wait for the server's answer and return a :class:`RunningTask` — or None when the goal was
  rejected (``getTaskError()`` then says so, with the Result's ``UNKNOWN`` code). The goal's fields are filled
  as BasicNavigator fills them: ``use_dock_id``, ``dock_id`` or ``dock_pose`` + ``dock_type``,
  ``navigate_to_staging_pose`` = ``nav_to_dock``; ``dock_type``; ``pose_topic`` or ``tracked_frame`` and
  ``max_duration`` (0: no limit). Everything else keeps the message's default (``max_staging_time`` 1000 s,
  ``max_undocking_time`` 30 s) unless given as a keyword.
* ``isTaskComplete()`` spins the client for at most 0.1 s and is True once the result is in (or when no task
  was sent); ``getFeedback()`` is the latest feedback message (cleared by each new goal); ``getResult()`` maps
  the goal's final status to :class:`TaskResult` (SUCCEEDED; ABORTED → FAILED; CANCELED; anything else
  UNKNOWN); ``getTaskError()`` is ``(error_code, error_msg)`` of a task that did not succeed, ``(0, '')``
  otherwise.
* ``cancelTask()`` asks the server to cancel the running goal and waits for its answer; the goal's end
  (CANCELED) then comes through ``isTaskComplete()`` like any other.
* A new goal replaces the one being watched (the server preempts or rejects it: its business); whatever the
  old goal still says is ignored.

Differences that matter for a pip-installed client without the ``ros2`` CLI:

* **No waiting for ever.** A server that does not appear within ``server_timeout_s`` raises
  :class:`ServerUnavailable`, one line naming the action and its type; a server that stops answering for that
  long during a goal ends the task (``isTaskComplete()`` True, ``getResult()`` UNKNOWN, the error says so); an
  unanswered goal or cancel request is given up after that long too.
* **Its own context, node and executor** (not a Node subclass): usable from any script, beside any other rclpy
  use in the process; ``destroy()`` (or leaving the ``with`` block) releases them all. Like BasicNavigator it
  does not cancel a running goal when destroyed: call ``cancelTask()`` first if the robot should stop.
  rclpy's signal handlers are not installed for its context, so Ctrl-C is Python's KeyboardInterrupt and a
  script (``mission task``) can still cancel its goal on the way out.
* **Every feedback message**, not only the latest: ``on_feedback`` is called with each one as it arrives
  (while the client spins, in isTaskComplete and the like), so a state that lasted less than a poll is seen.
* **The whole result**: :attr:`last_result` is a :class:`TaskOutcome` with the error code's name from the
  Result's constants (``DOCK_NOT_IN_DB``), the message and ``num_retries``.
* The interface classes come from :func:`mission.ros.tf_support.load_nav2` (a ROS install's nav2_msgs, else
  the one ``scripts/build_ros`` builds), not from a Python import of nav2_msgs.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

from mission.core.errors import MissionError
from mission.ros.tf_support import Interfaces, load_nav2

# action_msgs/msg/GoalStatus
STATUS_UNKNOWN, STATUS_SUCCEEDED, STATUS_CANCELED, STATUS_ABORTED = 0, 4, 5, 6
# action_msgs/srv/CancelGoal: return_code
CANCEL_ERROR_NONE = 0
SPIN_S = 0.1  # what isTaskComplete spins at most, as BasicNavigator


class TaskResult(Enum):
    """nav2_simple_commander's TaskResult."""

    UNKNOWN = 0
    SUCCEEDED = 1
    CANCELED = 2
    FAILED = 3


class RunningTask(Enum):
    """nav2_simple_commander's RunningTask, the members this client sends (same numbers)."""

    NONE = 0
    DOCK_ROBOT = 10
    UNDOCK_ROBOT = 11
    FOLLOW_OBJECT = 13


class TaskClientError(MissionError):
    """The client cannot do what was asked (no nav2_msgs, an interface this nav2_msgs lacks)."""


class ServerUnavailable(TaskClientError):
    """No action server for the action within ``server_timeout_s``."""


@dataclass(frozen=True)
class ActionSpec:
    """One of the actions: its name (relative, as Nav2's servers offer it), type and who serves it."""

    task: RunningTask
    name: str
    type_name: str  # nav2_msgs/action/DockRobot
    server: str  # who serves it, for the no-server message


ACTIONS = {
    RunningTask.DOCK_ROBOT: ActionSpec(
        RunningTask.DOCK_ROBOT, "dock_robot", "nav2_msgs/action/DockRobot", "Nav2's docking_server"
    ),
    RunningTask.UNDOCK_ROBOT: ActionSpec(
        RunningTask.UNDOCK_ROBOT, "undock_robot", "nav2_msgs/action/UndockRobot", "Nav2's docking_server"
    ),
    RunningTask.FOLLOW_OBJECT: ActionSpec(
        RunningTask.FOLLOW_OBJECT, "follow_object", "nav2_msgs/action/FollowObject", "Nav2's following_server"
    ),
}


def constants(msg_class: type) -> dict[int, str]:
    """value → name of a message's integer constants (``DockRobot.Result``: 901 → ``DOCK_NOT_IN_DB``).

    rosidl puts each constant on the class (and ``<FIELD>__DEFAULT`` for field defaults, left out here).
    """
    out: dict[int, str] = {}
    for name, value in vars(msg_class).items():
        if name.isupper() and not name.endswith("__DEFAULT") and type(value) is int:
            out.setdefault(value, name)
    return out


def constant_name(msg_class: type, value: int) -> str:
    """The constant's name for `value`, or the number as text when the message defines none."""
    return constants(msg_class).get(int(value), str(int(value)))


def seconds(duration: Any) -> float:
    """builtin_interfaces Duration / Time → float seconds."""
    return float(duration.sec) + float(duration.nanosec) * 1e-9


@dataclass(frozen=True)
class TaskOutcome:
    """How a task ended: the TaskResult, the goal status and the Result's fields, with names."""

    action: str  # the action's name, e.g. dock_robot (with the client's namespace)
    result: TaskResult
    status: int  # action_msgs/msg/GoalStatus
    error_code: int
    error_name: str  # the Result constant of error_code (DOCK_NOT_IN_DB), "NONE" for 0
    error_msg: str
    num_retries: int | None  # None: the Result has no such field (UndockRobot)
    elapsed_s: float | None = None  # FollowObject's total_elapsed_time
    message: Any = field(default=None, repr=False, compare=False)  # the Result message itself


class TaskClient:
    """Sends DockRobot, UndockRobot and FollowObject goals and watches them; see the module docstring."""

    def __init__(
        self,
        node_name: str = "task_client",
        namespace: str = "",
        *,
        server_timeout_s: float = 5.0,
        interfaces: Interfaces | None = None,
        on_feedback: Callable[[Any], None] | None = None,
    ) -> None:
        if not (math.isfinite(server_timeout_s) and server_timeout_s > 0):
            raise ValueError(f"server_timeout_s: expected seconds > 0, got {server_timeout_s!r}")
        nav2 = interfaces if interfaces is not None else load_nav2()
        if not nav2.ok:
            raise TaskClientError(f"Nav2's docking and following actions need nav2_msgs: {nav2.detail}")
        try:
            import rclpy
            from rclpy.executors import SingleThreadedExecutor
            from rclpy.signals import SignalHandlerOptions
        except ImportError as err:
            raise TaskClientError(f"Nav2's actions need rclpy ({err}): pip install 'mission[ros]'") from None

        self.nav2 = nav2
        self.namespace = namespace
        self.on_feedback = on_feedback  # called with every feedback message of the watched goal, as it arrives
        self.server_timeout_s = float(server_timeout_s)
        self._rclpy = rclpy
        self._context = rclpy.Context()
        rclpy.init(context=self._context, signal_handler_options=SignalHandlerOptions.NO)
        try:
            self.node = rclpy.create_node(node_name, namespace=namespace, context=self._context)
            self._executor = SingleThreadedExecutor(context=self._context)
            self._executor.add_node(self.node)
        except BaseException:
            rclpy.shutdown(context=self._context)
            raise
        self._clients: dict[RunningTask, Any] = {}  # made on first use: an older nav2_msgs may lack FollowObject
        self._destroyed = False
        # the task being watched
        self._task = RunningTask.NONE
        self._gen = 0  # the newest goal sent; feedback of older goals is ignored
        self._live = False  # the newest goal is being watched (sent, not ended)
        self._goal_handle: Any = None
        self._result_future: Any = None
        self._lost_since: float | None = None  # monotonic: when the server stopped being seen during a goal
        # what BasicNavigator keeps
        self.feedback: Any = None
        self.status: int | None = None
        self.last_action_error_code = 0
        self.last_action_error_msg = ""
        self.last_result: TaskOutcome | None = None

    # -- nav2_simple_commander's methods --------------------------------------------------------------
    def dockRobotByID(
        self, dock_id: str, nav_to_dock: bool = True, *, max_staging_time: float | None = None
    ) -> RunningTask | None:
        """Dock at the dock named `dock_id` in the server's dock database."""
        goal = self._goal(RunningTask.DOCK_ROBOT)
        goal.use_dock_id = True
        goal.dock_id = str(dock_id)
        goal.navigate_to_staging_pose = bool(nav_to_dock)
        if max_staging_time is not None:
            goal.max_staging_time = _non_negative("max_staging_time", max_staging_time)
        return self._send(RunningTask.DOCK_ROBOT, goal)

    def dockRobotByPose(
        self, dock_pose: Any, dock_type: str = "", nav_to_dock: bool = True, *, max_staging_time: float | None = None
    ) -> RunningTask | None:
        """Dock at a dock given by its pose (geometry_msgs/PoseStamped) and type ('' when the server has one)."""
        goal = self._goal(RunningTask.DOCK_ROBOT)
        goal.use_dock_id = False
        goal.dock_pose = dock_pose
        goal.dock_type = str(dock_type)
        goal.navigate_to_staging_pose = bool(nav_to_dock)
        if max_staging_time is not None:
            goal.max_staging_time = _non_negative("max_staging_time", max_staging_time)
        return self._send(RunningTask.DOCK_ROBOT, goal)

    def undockRobot(self, dock_type: str = "", *, max_undocking_time: float | None = None) -> RunningTask | None:
        """Undock from the current dock (`dock_type` when the server cannot know it)."""
        goal = self._goal(RunningTask.UNDOCK_ROBOT)
        goal.dock_type = str(dock_type)
        if max_undocking_time is not None:
            goal.max_undocking_time = _non_negative("max_undocking_time", max_undocking_time)
        return self._send(RunningTask.UNDOCK_ROBOT, goal)

    def followObjectByTopic(self, topic: str, max_duration: float = 0) -> RunningTask | None:
        """Follow the object whose pose (geometry_msgs/PoseStamped) is published on `topic`; 0 s: no limit."""
        goal = self._goal(RunningTask.FOLLOW_OBJECT)
        goal.pose_topic = str(topic)
        goal.max_duration = self._duration(max_duration)
        return self._send(RunningTask.FOLLOW_OBJECT, goal)

    def followObjectByFrame(self, frame: str, max_duration: float = 0) -> RunningTask | None:
        """Follow the TF frame `frame`; 0 s: no limit."""
        goal = self._goal(RunningTask.FOLLOW_OBJECT)
        goal.tracked_frame = str(frame)
        goal.max_duration = self._duration(max_duration)
        return self._send(RunningTask.FOLLOW_OBJECT, goal)

    def isTaskComplete(self, task: RunningTask = RunningTask.NONE, *, timeout_sec: float = SPIN_S) -> bool:
        """True once the task's result is in (or it ended otherwise, or there is none); spins ≤ `timeout_sec`."""
        if self._result_future is None:
            return True  # no task, or it ended
        self._spin_until(self._result_future, timeout_sec)
        if self._result_future.done():
            self._finish(self._result_future.result())
            return True
        client = self._clients[self._task]
        if client.server_is_ready():
            self._lost_since = None
            return False
        now = time.monotonic()
        self._lost_since = self._lost_since or now
        if now - self._lost_since < self.server_timeout_s:
            return False
        name = self.action_name(self._task)
        self._end(STATUS_UNKNOWN, None, f"{name}: the action server went away during the goal")
        return True

    def getFeedback(self, task: RunningTask = RunningTask.NONE) -> Any:
        """The latest feedback message of the running task (its action's Feedback), or None."""
        return self.feedback

    def getResult(self) -> TaskResult:
        """How the last task ended (UNKNOWN while it runs)."""
        return {
            STATUS_SUCCEEDED: TaskResult.SUCCEEDED,
            STATUS_ABORTED: TaskResult.FAILED,
            STATUS_CANCELED: TaskResult.CANCELED,
        }.get(self.status, TaskResult.UNKNOWN)

    def getTaskError(self) -> tuple[int, str]:
        """(error_code, error_msg) of the last task that did not succeed (or of a rejected goal)."""
        return self.last_action_error_code, self.last_action_error_msg

    def cancelTask(self) -> bool:
        """Ask the server to cancel the running task; whether it agreed. The end comes via isTaskComplete()."""
        if self._result_future is None or self._goal_handle is None:
            return False
        name = self.action_name(self._task)
        future = self._goal_handle.cancel_goal_async()
        self._spin_until(future, self.server_timeout_s)
        self.clearPreviousState()
        if not future.done():
            self.setTaskError(0, f"{name}: no answer to the cancel request within {self.server_timeout_s:g} s")
            return False
        answer = future.result()
        if answer is None or answer.return_code != CANCEL_ERROR_NONE or not answer.goals_canceling:
            code = "no answer" if answer is None else f"return code {answer.return_code}"
            self.setTaskError(0, f"{name}: the server refused to cancel the goal ({code})")
            return False
        return True

    def clearPreviousState(self) -> None:
        self.feedback = None
        self.last_action_error_code = 0
        self.last_action_error_msg = ""

    def setTaskError(self, error_code: int, error_msg: str) -> None:
        self.last_action_error_code = int(error_code)
        self.last_action_error_msg = str(error_msg)

    def destroy(self) -> None:
        """Release the action clients, the node, the executor and the context (again: nothing happens)."""
        if self._destroyed:
            return
        self._destroyed = True
        for client in self._clients.values():
            client.destroy()
        self._executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        if self._context.ok():
            self._rclpy.shutdown(context=self._context)

    destroyNode = destroy_node = destroy  # BasicNavigator's names

    def __enter__(self) -> TaskClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.destroy()

    # -- helpers ------------------------------------------------------------------------------------------
    def action_type(self, task: RunningTask) -> type:
        """The interface class of a task's action (``DockRobot``)."""
        spec = ACTIONS[task]
        name = spec.type_name.rsplit("/", 1)[1]
        try:
            return self.nav2.get("action", name)
        except AttributeError:
            raise TaskClientError(
                f"{spec.name}: the nav2_msgs in use has no {spec.type_name} ({self.nav2.detail}); "
                "a newer nav2_msgs (or scripts/build_ros) has it"
            ) from None

    def action_name(self, task: RunningTask) -> str:
        """The action's name as the user knows it: ``dock_robot``, ``/robot1/dock_robot`` in a namespace."""
        ns = self.namespace.strip("/")
        return f"/{ns}/{ACTIONS[task].name}" if ns else ACTIONS[task].name

    def _goal(self, task: RunningTask) -> Any:
        return self.action_type(task).Goal()

    def _duration(self, value: float) -> Any:
        from builtin_interfaces.msg import Duration

        ns = round(_non_negative("max_duration", value) * 1e9)
        return Duration(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def _client(self, task: RunningTask) -> Any:
        client = self._clients.get(task)
        if client is None:
            from rclpy.action import ActionClient

            client = ActionClient(self.node, self.action_type(task), ACTIONS[task].name)
            self._clients[task] = client
        return client

    def _spin_until(self, future: Any, timeout_sec: float) -> None:
        if not future.done():
            self._executor.spin_until_future_complete(future, timeout_sec=timeout_sec)

    def wait_for_server(self, task: RunningTask) -> None:
        """Wait up to ``server_timeout_s`` for the task's action server; ServerUnavailable if none appears.

        Sending a goal does this first; calling it beforehand separates "no server" from the goal itself.
        """
        self._wait_for_server(task, self._client(task))

    def _wait_for_server(self, task: RunningTask, client: Any) -> None:
        deadline = time.monotonic() + self.server_timeout_s
        while not client.server_is_ready():
            if time.monotonic() >= deadline:
                spec = ACTIONS[task]
                domain = os.environ.get("ROS_DOMAIN_ID") or "0"
                raise ServerUnavailable(
                    f"{self.action_name(task)}: no {spec.type_name} action server after {self.server_timeout_s:g} s "
                    f"(ROS_DOMAIN_ID={domain}): is {spec.server} (or the mission node) running on this domain, "
                    "with the same DDS profile?"
                )
            self._executor.spin_once(timeout_sec=0.02)

    def _send(self, task: RunningTask, goal: Any) -> RunningTask | None:
        self.clearPreviousState()
        self._task, self._goal_handle, self._result_future = task, None, None
        self._lost_since, self.status, self.last_result, self._live = None, None, None, False
        client = self._client(task)
        self._wait_for_server(task, client)
        self._gen += 1
        gen = self._gen
        self._live = True  # feedback may come before the goal's acceptance is read
        future = client.send_goal_async(goal, feedback_callback=self._feedback_callback(gen))
        self._spin_until(future, self.server_timeout_s)
        name = self.action_name(task)
        unknown = getattr(self.action_type(task).Result, "UNKNOWN", 0)
        if not future.done():
            self._live = False
            self.setTaskError(unknown, f"{name}: no answer to the goal within {self.server_timeout_s:g} s")
            return None
        handle = future.result()
        if handle is None or not handle.accepted:
            self._live = False
            self.setTaskError(unknown, f"{name}: the server rejected the goal")
            return None
        self._goal_handle = handle
        self._result_future = handle.get_result_async()
        return task

    def _feedback_callback(self, gen: int) -> Callable[[Any], None]:
        def on_feedback(message: Any) -> None:
            if gen == self._gen and self._live:
                self.feedback = message.feedback
                if self.on_feedback is not None:
                    self.on_feedback(message.feedback)

        return on_feedback

    def _finish(self, answer: Any) -> None:
        self._end(int(answer.status), answer.result, "")

    def _end(self, status: int, result: Any, why: str) -> None:
        """The task ended with `status` and `result` (None: no result, `why` says what happened)."""
        task = self._task
        self._live = False
        self._result_future = None
        self._goal_handle = None
        self.status = status
        result_class = self.action_type(task).Result
        code = int(getattr(result, "error_code", 0)) if result is not None else getattr(result_class, "UNKNOWN", 0)
        msg = str(getattr(result, "error_msg", "")) if result is not None else why
        retries = getattr(result, "num_retries", None)
        elapsed = getattr(result, "total_elapsed_time", None)
        self.last_result = TaskOutcome(
            action=self.action_name(task),
            result=self.getResult(),
            status=status,
            error_code=code,
            error_name=constant_name(result_class, code),
            error_msg=msg,
            num_retries=None if retries is None else int(retries),
            elapsed_s=None if elapsed is None else seconds(elapsed),
            message=result,
        )
        if self.last_result.result is not TaskResult.SUCCEEDED:
            self.setTaskError(code, msg)


def _non_negative(name: str, value: float) -> float:
    value = float(value)
    if not (math.isfinite(value) and value >= 0):
        raise ValueError(f"{name}: expected seconds ≥ 0, got {value!r}")
    return value
