"""A Nav2 user's client script for the docking actions, written from nav2_msgs' .action definitions only.

It imports rclpy and nav2_msgs (the colcon build of ``ros/nav2_msgs``, as a Nav2 install provides it) and
nothing of the mission package: the closed-loop tests (tests/ros/test_nav2_actions.py) and the bench
(bench/nav2_actions.py) run it as a separate process, so what passes here is
what a team's existing client code would see. It takes a plan, a JSON list of steps, runs them in order and
prints one JSON line per event:

* ``{"dock": {"id": "home_dock"}}`` or ``{"dock": {"pose": [x, y, yaw], "type": "", "frame": "map",
  "navigate": true}}``; ``{"undock": {"type": ""}}``; ``{"follow": {"topic": "/target_pose"}}`` or
  ``{"follow": {"frame": "target"}}``, with ``"max_duration": S``;
* a step may carry ``"cancel_after_s": S`` (cancel S wall seconds after acceptance) or
  ``"preempt_after_s": S`` with ``"then": STEP`` (send STEP while the first still runs);
* events: ``accepted``, ``feedback`` (when state or retries change), ``result`` (status name, error_code,
  error_msg, num_retries, and the simulator's ground truth at that moment from ``/sim/ground_truth``).

Usage: ``python nav2_task_client.py PLAN_JSON [TIMEOUT_S]``.
"""

from __future__ import annotations

import json
import math
import sys
import threading
import time

import rclpy
from action_msgs.msg import GoalStatus
from nav2_msgs.action import DockRobot, FollowObject, UndockRobot
from rclpy.action import ActionClient
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from std_msgs.msg import String

STATUS = {
    GoalStatus.STATUS_SUCCEEDED: "SUCCEEDED",
    GoalStatus.STATUS_ABORTED: "ABORTED",
    GoalStatus.STATUS_CANCELED: "CANCELED",
}


_EMIT_LOCK = threading.Lock()


def emit(**event) -> None:
    """One JSON line. The executor's thread (feedback) and the plan's (results) both emit: unlocked, print's
    text and its newline are two writes, and two events could share a line (seen once in CI)."""
    with _EMIT_LOCK:
        sys.stdout.write(json.dumps(event) + "\n")
        sys.stdout.flush()


class Client:
    def __init__(self) -> None:
        self.node = rclpy.create_node("nav2_task_client")
        self.dock = ActionClient(self.node, DockRobot, "dock_robot")
        self.undock = ActionClient(self.node, UndockRobot, "undock_robot")
        self.follow = ActionClient(self.node, FollowObject, "follow_object")
        self.truth: dict = {}
        self.node.create_subscription(String, "/sim/ground_truth", self._on_truth, 10)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.running = True
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def close(self) -> None:
        self.running = False
        self._thread.join(timeout=2.0)
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()

    def _spin(self) -> None:
        while self.running and rclpy.ok():
            try:
                self.executor.spin_once(timeout_sec=0.05)
            except ExternalShutdownException:  # rclpy shut down under us (Ctrl-C): nothing more to hear
                return

    def _on_truth(self, msg: String) -> None:
        self.truth = json.loads(msg.data)

    def goal(self, step: dict):
        if "dock" in step:
            spec, goal = step["dock"], DockRobot.Goal()
            if "id" in spec:
                goal.use_dock_id, goal.dock_id = True, spec["id"]
            else:
                x, y, yaw = spec["pose"]
                goal.use_dock_id = False
                goal.dock_pose.header.frame_id = spec.get("frame", "map")
                goal.dock_pose.pose.position.x, goal.dock_pose.pose.position.y = float(x), float(y)
                goal.dock_pose.pose.orientation.z = math.sin(yaw / 2)
                goal.dock_pose.pose.orientation.w = math.cos(yaw / 2)
                goal.dock_type = spec.get("type", "")
            goal.navigate_to_staging_pose = bool(spec.get("navigate", True))
            if "max_staging_time" in spec:
                goal.max_staging_time = float(spec["max_staging_time"])
            return "dock", self.dock, goal
        if "follow" in step:
            spec, goal = step["follow"], FollowObject.Goal()
            goal.pose_topic = spec.get("topic", "")
            goal.tracked_frame = spec.get("frame", "")
            seconds = float(spec.get("max_duration", 0.0))
            goal.max_duration.sec = int(seconds)
            goal.max_duration.nanosec = int((seconds - int(seconds)) * 1e9)
            return "follow", self.follow, goal
        spec, goal = step["undock"], UndockRobot.Goal()
        goal.dock_type = spec.get("type", "")
        if "max_undocking_time" in spec:
            goal.max_undocking_time = float(spec["max_undocking_time"])
        return "undock", self.undock, goal

    def send(self, step: dict, timeout: float):
        kind, client, goal = self.goal(step)
        if not client.wait_for_server(timeout_sec=timeout):
            emit(event="no_server", action=kind)
            return None
        last = {}

        def on_feedback(msg) -> None:
            fb = msg.feedback
            now = {"state": getattr(fb, "state", None), "num_retries": getattr(fb, "num_retries", None)}
            if now != last:
                last.update(now)
                emit(event="feedback", action=kind, t=self.truth.get("t"), **now)

        future = client.send_goal_async(goal, feedback_callback=on_feedback)
        handle = _wait(future, timeout)
        emit(event="accepted" if handle.accepted else "rejected", action=kind)
        return kind, handle

    def result(self, kind: str, handle, timeout: float) -> dict:
        answer = _wait(handle.get_result_async(), timeout)
        r = answer.result
        event = {
            "event": "result",
            "action": kind,
            "status": STATUS.get(answer.status, str(answer.status)),
            "success": getattr(r, "success", None),
            "error_code": r.error_code,
            "error_msg": r.error_msg,
            "num_retries": getattr(r, "num_retries", None),
            "total_elapsed_time": _seconds(getattr(r, "total_elapsed_time", None)),
            "truth": self.truth,
        }
        emit(**event)
        return event


def _seconds(duration) -> float | None:
    return None if duration is None else duration.sec + duration.nanosec * 1e-9


def _wait(future, timeout: float):
    deadline = time.monotonic() + timeout
    while not future.done():
        if time.monotonic() > deadline:
            raise TimeoutError("no answer from the server")
        time.sleep(0.01)
    return future.result()


def main() -> int:
    plan = json.loads(sys.argv[1])
    timeout = float(sys.argv[2]) if len(sys.argv) > 2 else 120.0
    rclpy.init()
    client = Client()
    deadline = time.monotonic() + 10.0  # a simulator's truth, when there is one, for the results
    while not client.truth and time.monotonic() < deadline:
        time.sleep(0.05)
    try:
        for step in plan:
            sent = client.send(step, 30.0)
            if sent is None:
                return 2
            kind, handle = sent
            if "cancel_after_s" in step:
                time.sleep(float(step["cancel_after_s"]))
                _wait(handle.cancel_goal_async(), 10.0)
                emit(event="cancel_sent", action=kind)
            if "preempt_after_s" in step:
                time.sleep(float(step["preempt_after_s"]))
                newer = client.send(step["then"], 30.0)
                client.result(kind, handle, timeout)
                if newer is not None:
                    client.result(newer[0], newer[1], timeout)
                continue
            client.result(kind, handle, timeout)
        return 0
    finally:
        client.close()
        rclpy.shutdown()


if __name__ == "__main__":
    sys.exit(main())
