"""The node as a Nav2 client: ``/goal/nav_goal`` → a ``navigate_to_pose`` goal; feedback and result →
``/goal/nav_status`` and ``/goal/nav_reason``, so Nav2's word reaches the tree.

* A new goal (a new ``seq``) is sent as a new NavigateToPose goal, which preempts the previous one on the
  server (bt_navigator ends it aborted; that old result is ignored). Goals are sent at most ``preempt_hz``
  times a second — the follow rate: a follower that republishes faster only ever has its newest goal sent.
* Feedback keeps the status RUNNING with the distance remaining as the reason; the result maps
  SUCCEEDED → succeeded, ABORTED → failed with Nav2's ``error_msg`` and ``error_code``, CANCELED (not by us)
  → failed; a goal the server rejects → failed.
* ``cancel()`` (the behaviour was halted) cancels the active goal; its result is then ignored.
* No server: the goal waits ``server_timeout_s`` for one to appear, then the status is FAILED with
  "navigate_to_pose: no action server" and one warning is logged (not one per goal); the node keeps
  checking, and the first goal after a server appears goes out normally. A server that disappears during a
  goal fails it the same way.

Everything runs on the node's executor thread (the callbacks and the timer that calls :meth:`status`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

from rclpy.action import ActionClient

from mission.core.types import NavGoal, NavStatus, RobotState
from mission.ros.conversions import pose2d_stamped
from mission.ros.messages import RclpyMessages

ACTION_NAME = "navigate_to_pose"
NO_SERVER = f"{ACTION_NAME}: no action server"
# action_msgs/msg/GoalStatus
STATUS_SUCCEEDED, STATUS_CANCELED, STATUS_ABORTED = 4, 5, 6


class ActionNavigation:
    """A Navigation (mission/ros/world_io.py) over Nav2's NavigateToPose action."""

    def __init__(
        self,
        node: Any,
        action_type: type,
        *,
        action_name: str = ACTION_NAME,
        preempt_hz: float = 10.0,
        server_timeout_s: float = 2.0,
        warn: Callable[[str], None] = lambda message: None,
        info: Callable[[str], None] = lambda message: None,
    ) -> None:
        self.action_type = action_type
        self.client = ActionClient(node, action_type, action_name)
        self.msgs = RclpyMessages()
        self.period = 1.0 / preempt_hz if preempt_hz > 0 else 0.0
        self.server_timeout_s = float(server_timeout_s)
        self.warn, self.info = warn, info
        self._pending: tuple[NavGoal, str] | None = None
        self._sent_at = -math.inf  # world time of the last goal sent (the preemption rate)
        self._gen = 0  # the newest goal sent; answers about older ones are ignored
        self._handle: Any = None
        self._status, self._reason = NavStatus.IDLE, ""
        self._waiting_since: float | None = None  # monotonic: discovery is wall-clock business
        self._said_missing = False
        self._server_lost_at: float | None = None
        self.sent = 0
        self.results: dict[str, int] = {}

    # -- Navigation ----------------------------------------------------------------------------------
    def send(self, goal: NavGoal, now: float, frame_id: str) -> None:
        self._pending = (goal, frame_id)
        if self._status != NavStatus.FAILED or self._reason != NO_SERVER:
            self._status, self._reason = NavStatus.RUNNING, ""
        self._flush(now)

    def cancel(self) -> None:
        self._pending = None
        self._gen += 1  # whatever the server says about the goal from now on is not news
        if self._handle is not None:
            self._handle.cancel_goal_async()
            self._handle = None
        self._status, self._reason = NavStatus.IDLE, ""

    def status(self, state: RobotState | None, now: float) -> tuple[str, str]:
        self._flush(now)
        if self._handle is not None and self._status == NavStatus.RUNNING:
            if self.client.server_is_ready():
                self._server_lost_at = None
            else:
                self._server_lost_at = self._server_lost_at or time.monotonic()
                if time.monotonic() - self._server_lost_at > self.server_timeout_s:
                    self._handle, self._gen = None, self._gen + 1
                    self._fail(f"{ACTION_NAME}: the action server went away during the goal")
        return self._status, self._reason

    def close(self) -> None:
        self.client.destroy()

    # -- sending ---------------------------------------------------------------------------------------
    def _flush(self, now: float) -> None:
        if self._pending is None:
            return
        if not self.client.server_is_ready():
            self._waiting_since = self._waiting_since or time.monotonic()
            if time.monotonic() - self._waiting_since >= self.server_timeout_s:
                if not self._said_missing:
                    self._said_missing = True
                    self.warn(
                        f"{NO_SERVER} (is Nav2's bt_navigator running, on this ROS_DOMAIN_ID?); "
                        "navigation leaves fail until one appears"
                    )
                self._fail(NO_SERVER)
            return
        if self._said_missing:
            self._said_missing = False
            self.info(f"{ACTION_NAME}: action server found")
        self._waiting_since = None
        if now - self._sent_at < self.period - 1e-6 and now >= self._sent_at:
            return  # preempting faster than the follow rate: the newest goal goes out when the period is up
        goal, frame_id = self._pending
        self._pending = None
        msg = self.action_type.Goal()
        msg.pose = pose2d_stamped(self.msgs, goal.pose, now, frame_id)
        self._gen += 1
        gen = self._gen
        self._sent_at = now
        self.sent += 1
        self._status, self._reason = NavStatus.RUNNING, ""
        future = self.client.send_goal_async(msg, feedback_callback=lambda fb: self._on_feedback(gen, fb))
        future.add_done_callback(lambda f: self._on_goal_response(gen, f))

    def _fail(self, reason: str) -> None:
        self._status, self._reason = NavStatus.FAILED, reason

    # -- answers ---------------------------------------------------------------------------------------
    def _on_goal_response(self, gen: int, future: Any) -> None:
        handle = future.result()
        if gen != self._gen:
            return  # superseded: the server preempts it with the newer goal
        if handle is None or not handle.accepted:
            self._fail(f"{ACTION_NAME}: the server rejected the goal")
            return
        self._handle = handle
        handle.get_result_async().add_done_callback(lambda f: self._on_result(gen, f))

    def _on_feedback(self, gen: int, feedback: Any) -> None:
        if gen == self._gen and self._status == NavStatus.RUNNING:
            fb = feedback.feedback
            self._reason = f"{ACTION_NAME}: {float(fb.distance_remaining):.2f} m to go"

    def _on_result(self, gen: int, future: Any) -> None:
        answer = future.result()
        code = int(answer.status)
        names = {STATUS_SUCCEEDED: "succeeded", STATUS_CANCELED: "canceled", STATUS_ABORTED: "aborted"}
        name = names.get(code, str(code))
        self.results[name] = self.results.get(name, 0) + 1
        if gen != self._gen:
            return
        self._handle = None
        if code == STATUS_SUCCEEDED:
            self._status, self._reason = NavStatus.SUCCEEDED, f"{ACTION_NAME}: succeeded"
        elif code == STATUS_ABORTED:
            result = answer.result
            why = str(getattr(result, "error_msg", "") or "no reason given")
            self._fail(f"{ACTION_NAME} aborted: {why} (error_code {int(getattr(result, 'error_code', 0))})")
        elif code == STATUS_CANCELED:
            self._fail(f"{ACTION_NAME}: the server canceled the goal")
        else:
            self._fail(f"{ACTION_NAME}: goal ended with status {code}")
