"""Nav2's docking and following actions served by our trees: ``dock_robot`` (nav2_msgs/action/DockRobot),
``undock_robot`` (UndockRobot) and ``follow_object`` (FollowObject), with the definitions of navigation2's jazzy
branch, so a Nav2 client (nav2_simple_commander's ``dockRobotByID``, ``undockRobot``, ``followObjectByTopic``)
works unchanged.

A goal runs a tree on the node's one runner (``TreeRunner.start_tree`` with the goal's inputs); the node's
timer ticks it, as it ticks a mission. After each tick the servers — a run observer — look at the goal:

* a cancel request halts the tree and stops the robot; the goal ends CANCELED;
* the tree's SUCCESS or FAILURE ends the goal with Nav2's result (mission/ros/nav2_tasks.py maps the node that
  failed to the error code, its reason to ``error_msg``) and stops the robot;
* otherwise feedback: Nav2's state from the node the tree is in, the time since the goal, the retries;
* FollowObject: past ``max_duration`` the goal SUCCEEDS (opennav_following's rule); poses that TF cannot place
  for ``detection_timeout`` end it with TF_ERROR.

One robot runs one tree: a new goal, of either action, preempts the running one, which ends ABORTED with
"preempted by a newer goal" (Nav2's SimpleActionServer accepts the newer goal the same way; its docking
server then aborts both, which we do not copy). A goal that cannot start — a dock id not in the database — is
accepted and aborted at once with its code, the running goal untouched and the robot not moved.

The execute callbacks are coroutines on the node's single-threaded executor: they start the tree and await
a future the tick completes, so the executor is never blocked and nothing needs a lock.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from mission.core import blackboard as bbk
from mission.core.errors import MissionError
from mission.core.observers import RunObserver, Tick
from mission.core.types import Pose2D
from mission.ros import nav2_tasks as tasks
from mission.ros.conversions import pose_to_matrix
from mission.ros.nav2_params import DockingParams, FollowingParams

ATTEMPT_ENTRY = "attempt"  # the root blackboard entry dock_robot.xml counts its attempts in


@dataclass
class _Active:
    """The goal whose tree runs now."""

    handle: Any
    future: Any
    spec: tasks.TaskSpec
    plan: tasks.TaskPlan
    watch: tasks.PhaseWatch
    result_type: Any
    feedback_type: Any
    started: float  # ROS time of the goal's start (s)
    tree: Any  # the tree this goal started: another goal may have replaced it
    max_duration: float = 0.0  # s; > 0: the goal succeeds after this long (FollowObject)
    retries: int = 0  # entries into the RETRY state (a tree without an {attempt} counter)
    last_state: str = "NONE"


class TaskServers(RunObserver):
    """The action servers of the node in server mode (``tree:=none``): one goal at a time on one runner."""

    def __init__(
        self,
        node: Any,
        nav2: Any,
        runner: Any,
        docking: DockingParams,
        following: FollowingParams | None = None,
        *,
        external: Any = None,
        trees: dict[str, str] | None = None,
        map_frame: str = "map",
        now: Callable[[], float],
        log: Any,
    ) -> None:
        from rclpy.action import ActionServer, CancelResponse, GoalResponse

        self.node, self.runner, self.docking, self.map_frame = node, runner, docking, map_frame
        self.following = following or FollowingParams()
        self.external = external  # ExternalPoses: the followed object's poses (mission/ros/external_poses.py)
        self.now, self.log = now, log
        self.trees = {
            "dock": tasks.DOCK_ROBOT.tree,
            "undock": tasks.UNDOCK_ROBOT.tree,
            "follow": tasks.FOLLOW_OBJECT.tree,
            **(trees or {}),
        }
        self.dock_action = nav2.get("action", "DockRobot")
        self.undock_action = nav2.get("action", "UndockRobot")
        self.follow_action = nav2.get("action", "FollowObject")
        self._config_targets = dict(runner.perception.targets)  # what a goal's retargeting is undone to
        self.active: _Active | None = None
        self.docked_type = ""  # the dock type of the last successful docking (UndockRobot's default)
        self.counts = {"goals": 0, "succeeded": 0, "aborted": 0, "canceled": 0, "rejected": 0}

        def accept(_request: Any) -> Any:
            return GoalResponse.ACCEPT

        def cancel(_handle: Any) -> Any:
            return CancelResponse.ACCEPT

        served = [
            ("dock_robot", self.dock_action, self._execute_dock),
            ("undock_robot", self.undock_action, self._execute_undock),
        ]
        if external is not None:
            served.append(("follow_object", self.follow_action, self._execute_follow))
        self.servers = [
            ActionServer(node, action, name, execute_callback=run, goal_callback=accept, cancel_callback=cancel)
            for name, action, run in served
        ]

    # -- goals -------------------------------------------------------------------------------------------
    def _robot_pose(self) -> Pose2D | None:
        state = self.runner.get(bbk.ROBOT_STATE)
        return None if state is None else state.pose

    async def _execute_dock(self, handle: Any) -> Any:
        request = handle.request
        pose, frame = None, ""
        if not request.use_dock_id:
            pose, frame = _pose2d(request.dock_pose.pose), str(request.dock_pose.header.frame_id)
        goal = tasks.DockGoal(
            use_dock_id=bool(request.use_dock_id),
            dock_id=str(request.dock_id),
            dock_pose=pose,
            dock_frame=frame,
            dock_type=str(request.dock_type),
            max_staging_time=float(request.max_staging_time),
            navigate_to_staging_pose=bool(request.navigate_to_staging_pose),
        )
        what = f"dock {goal.dock_id!r}" if goal.use_dock_id else f"dock pose ({pose.x:.2f}, {pose.y:.2f})"
        return await self._run(
            handle,
            tasks.DOCK_ROBOT,
            self.dock_action,
            what,
            lambda robot: tasks.plan_dock(goal, self.docking, robot, tree=self.trees["dock"], map_frame=self.map_frame),
        )

    async def _execute_undock(self, handle: Any) -> Any:
        request = handle.request
        goal = tasks.UndockGoal(dock_type=str(request.dock_type), max_undocking_time=float(request.max_undocking_time))
        return await self._run(
            handle,
            tasks.UNDOCK_ROBOT,
            self.undock_action,
            "undock",
            lambda robot: tasks.plan_undock(goal, self.docking, robot, self.docked_type, tree=self.trees["undock"]),
        )

    async def _execute_follow(self, handle: Any) -> Any:
        request = handle.request
        d = request.max_duration
        goal = tasks.FollowGoal(
            pose_topic=str(request.pose_topic),
            tracked_frame=str(request.tracked_frame),
            max_duration=float(d.sec) + float(d.nanosec) * 1e-9,
        )
        what = f"frame {goal.tracked_frame!r}" if goal.tracked_frame else f"poses on {goal.pose_topic}"
        return await self._run(
            handle,
            tasks.FOLLOW_OBJECT,
            self.follow_action,
            what,
            lambda _robot: tasks.plan_follow(goal, self.following, tree=self.trees["follow"]),
            follow=goal,
        )

    async def _run(
        self,
        handle: Any,
        spec: tasks.TaskSpec,
        action: Any,
        what: str,
        make_plan: Callable[[Pose2D | None], tasks.TaskPlan],
        follow: tasks.FollowGoal | None = None,
    ) -> Any:
        from rclpy.task import Future

        self.counts["goals"] += 1
        try:
            plan = make_plan(self._robot_pose())
        except tasks.TaskRejected as rejected:
            self.counts["rejected"] += 1
            self.log.warning(f"{spec.action} {what}: {rejected.error}: {rejected.message}")
            handle.abort()
            return self._result(action.Result, False, rejected.error, rejected.message)
        if self.active is not None:
            self._end(self.active, "abort", "UNKNOWN", "preempted by a newer goal", stop=False)
        for name, target in plan.retarget.items():
            self.runner.perception.retarget(name, target)
        if follow is not None:
            if follow.tracked_frame:
                self.external.follow_frame(follow.tracked_frame)
            else:
                self.external.follow_topic(follow.pose_topic)
        try:
            self.runner.start_tree(plan.tree, plan.inputs)
        except MissionError as err:  # a user's tree that does not load: the goal fails, the node goes on
            self.log.error(f"{spec.action}: the tree {plan.tree} cannot run: {err}")
            handle.abort()
            return self._result(action.Result, False, "UNKNOWN", f"the tree {plan.tree} cannot run: {err}")
        watch = tasks.PhaseWatch(spec)
        self.runner.tree.visitors.append(watch)
        future = Future()
        self.active = _Active(
            handle,
            future,
            spec,
            plan,
            watch,
            action.Result,
            action.Feedback,
            self.now(),
            self.runner.tree,
            max_duration=follow.max_duration if follow is not None else 0.0,
        )
        self.log.info(f"{spec.action} {what}: running {self.runner.tree_path.name}")
        return await future

    # -- RunObserver ---------------------------------------------------------------------------------------
    def on_tick(self, run: Any, tick: Tick) -> None:
        active = self.active
        if active is None:
            return
        if active.handle.is_cancel_requested:
            self._end(active, "cancel", "NONE", "canceled")
            return
        if run.tree is not active.tree:  # stopped from outside (the node closing)
            self._end(active, "abort", "UNKNOWN", "the tree was stopped", stop=False)
            return
        elapsed = self.now() - active.started
        if active.max_duration > 0 and elapsed > active.max_duration:
            self._end(active, "succeed", "NONE", "")  # opennav_following: max_duration reached is success
            return
        ext = self.external
        if (
            active.spec is tasks.FOLLOW_OBJECT
            and ext is not None
            and ext.error
            and ext.last_placed is None
            and elapsed > self.following.detection_timeout
        ):
            self._end(active, "abort", "TF_ERROR", ext.error)
            return
        status = tick.status.name
        if status == "SUCCESS":
            if active.plan.dock_type is not None and active.spec is tasks.DOCK_ROBOT:
                self.docked_type = active.plan.dock_type.name
            elif active.spec is tasks.UNDOCK_ROBOT:
                self.docked_type = ""
            self._end(active, "succeed", "NONE", "")
        elif status == "FAILURE":
            error, message = tasks.failure(active.spec, active.watch, str(run.get(bbk.REASON, "") or ""))
            self._end(active, "abort", error, message)
        else:
            self._feedback(active)

    def on_end(self, run: Any, outcome: Any) -> None:
        if self.active is not None:
            self._end(self.active, "abort", "UNKNOWN", "the node is shutting down", stop=False)

    # -- ending and reporting ------------------------------------------------------------------------------
    def _attempt(self) -> int:
        value = self.runner.tree_entry(ATTEMPT_ENTRY)
        return int(value) if isinstance(value, int | float) and not isinstance(value, bool) else 1

    def _retries(self, active: _Active) -> int:
        """Retries so far: the tree's {attempt} counter when it has one (DockRobot), else the losses (RETRY)."""
        value = self.runner.tree_entry(ATTEMPT_ENTRY)
        return max(0, self._attempt() - 1) if value is not None else active.retries

    def _feedback(self, active: _Active) -> None:
        states = tasks.feedback_states(active.spec, active.watch, self._attempt())
        if not states:  # the tree has not reached a named node yet: nothing to say
            return
        if states[0] == active.last_state:  # said at the end of the last tick: only what came after
            states = states[1:] or states
        for state in states:
            self._feedback_one(active, state)

    def _feedback_one(self, active: _Active, state: str) -> None:
        fb = active.feedback_type()
        if state == "RETRY" and active.last_state != "RETRY" and self.runner.tree_entry(ATTEMPT_ENTRY) is None:
            active.retries += 1
        active.last_state = state
        if not hasattr(fb, "state"):  # UndockRobot's feedback is empty: Nav2 sends none
            return
        fb.state = int(getattr(fb, state))
        fb.num_retries = self._retries(active)
        elapsed = _duration(self.now() - active.started)
        for name in ("docking_time", "following_time"):
            if hasattr(fb, name):
                setattr(fb, name, elapsed)
        active.handle.publish_feedback(fb)

    def _end(self, active: _Active, how: str, error: str, message: str, stop: bool = True) -> None:
        self.active = None
        if stop:
            self.runner.stop_tree()  # halt, zero velocity; perception goes on
        for name in active.plan.retarget:  # perception looks for what the config says again
            if name in self._config_targets:
                self.runner.perception.retarget(name, self._config_targets[name])
        if self.external is not None and active.spec is tasks.FOLLOW_OBJECT:
            self.external.stop()
        success = how == "succeed"
        retries = self._retries(active)
        result = self._result(active.result_type, success, error, message, retries)
        if hasattr(result, "total_elapsed_time"):
            result.total_elapsed_time = _duration(self.now() - active.started)
        if how == "succeed":
            active.handle.succeed()
            self.counts["succeeded"] += 1
            self.log.info(f"{active.spec.action}: succeeded" + (f" after {retries} retries" if retries else ""))
        elif how == "cancel":
            active.handle.canceled()
            self.counts["canceled"] += 1
            self.log.info(f"{active.spec.action}: canceled")
        else:
            if active.handle.is_active:
                active.handle.abort()
            self.counts["aborted"] += 1
            self.log.warning(f"{active.spec.action}: {error}: {message}")
        active.future.set_result(result)

    def _result(self, result_type: Any, success: bool, error: str, message: str, retries: int = 0) -> Any:
        result = result_type()
        if hasattr(result, "success"):
            result.success = success
        result.error_code = int(getattr(result_type, error, result_type.UNKNOWN))
        result.error_msg = message
        if hasattr(result, "num_retries"):
            result.num_retries = retries
        return result

    def destroy(self) -> None:
        for server in self.servers:
            server.destroy()


def _pose2d(pose: Any) -> Pose2D:
    from mission.core import se3

    t = pose_to_matrix(pose)
    return Pose2D(float(t[0, 3]), float(t[1, 3]), se3.yaw_of(t))


def _duration(seconds: float) -> Any:
    from builtin_interfaces.msg import Duration

    seconds = max(0.0, seconds)
    whole = int(seconds)
    return Duration(sec=whole, nanosec=int((seconds - whole) * 1e9))
