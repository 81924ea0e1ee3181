"""Fake Nav2 docking and following servers for the tests: real rclpy ActionServers for ``dock_robot``,
``undock_robot`` and ``follow_object``, written from the definitions in ros/nav2_msgs/action/*.action.

They stand in, at the edge of the system, for the servers being written (issue 32) and for Nav2's own
docking_server / following_server: each goal is answered by a :class:`Script` — feedback messages a period
apart, then succeeded or aborted with the Result's fields (``error_code``, ``error_msg``, ``num_retries``…), or
held (the last feedback repeated) until it is canceled. Everything a client sent is kept in :attr:`goals`.

The server runs in its own rclpy context with a multi-threaded executor on a background thread (an execute
callback that sleeps between feedback messages must not hold up cancel requests).
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from mission.ros.tf_support import Interfaces

ACTIONS = {"dock_robot": "DockRobot", "undock_robot": "UndockRobot", "follow_object": "FollowObject"}


@dataclass
class Script:
    """How the server answers one goal."""

    feedback: Sequence[Mapping[str, Any]] = ()  # Feedback fields, one message each, `period_s` apart
    outcome: str = "succeed"  # succeed | abort | hold (the last feedback repeats until the goal is canceled)
    result: Mapping[str, Any] = field(default_factory=dict)  # Result fields (succeed / abort)
    accept: bool = True  # False: the goal is rejected
    accept_cancel: bool = True  # False: cancel requests are refused
    period_s: float = 0.05


@dataclass
class Seen:
    """A goal the server received, and what became of it."""

    goal: Any  # the Goal message
    handle: Any = field(repr=False, default=None)
    cancel_requested: bool = False
    end: str = ""  # succeeded | aborted | canceled


class FakeNav2Servers:
    """The three action servers on one node; `scripts[action]` maps a goal to its Script."""

    def __init__(self, nav2: Interfaces, namespace: str = "", node_name: str = "fake_nav2_servers") -> None:
        import rclpy
        from rclpy.action import ActionServer, CancelResponse, GoalResponse
        from rclpy.callback_groups import ReentrantCallbackGroup
        from rclpy.executors import MultiThreadedExecutor

        self._rclpy = rclpy
        self._cancel_response = CancelResponse
        self._goal_response = GoalResponse
        self.types = {name: nav2.get("action", type_name) for name, type_name in ACTIONS.items()}
        self.scripts: dict[str, Callable[[Any], Script]] = {name: lambda goal: Script() for name in ACTIONS}
        self.goals: dict[str, list[Seen]] = {name: [] for name in ACTIONS}
        self._lock = threading.Lock()
        self._vanished: set[str] = set()
        self._executing = 0  # execute callbacks running
        self._release = threading.Event()  # set at close: held goals (and those of a vanished server) return
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(node_name, namespace=namespace, context=self.context)
        group = ReentrantCallbackGroup()
        self.servers = {
            name: ActionServer(
                self.node,
                action_type,
                name,
                execute_callback=lambda handle, name=name: self._execute(name, handle),
                goal_callback=lambda goal, name=name: self._on_goal(name, goal),
                cancel_callback=lambda handle, name=name: self._on_cancel(name, handle),
                callback_group=group,
            )
            for name, action_type in self.types.items()
        }
        self.executor = MultiThreadedExecutor(num_threads=4, context=self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        with contextlib.suppress(Exception):
            while self.context.ok():
                self.executor.spin_once(timeout_sec=0.05)

    # -- what the tests read ---------------------------------------------------------------------------
    def received(self, action: str) -> list[Seen]:
        with self._lock:
            return list(self.goals[action])

    def vanish(self, action: str) -> None:
        """The server of `action` goes away mid-goal: its goals get no result, its endpoints are removed."""
        self._vanished.add(action)
        self.servers.pop(action).destroy()

    def close(self) -> None:
        self._release.set()
        deadline = time.monotonic() + 2.0
        while self._executing and time.monotonic() < deadline:  # held goals end while the executor still runs
            time.sleep(0.01)
        time.sleep(0.05)  # their results go out
        self.executor.shutdown(timeout_sec=2.0)
        for server in self.servers.values():
            server.destroy()
        self.node.destroy_node()
        with contextlib.suppress(Exception):
            self._rclpy.shutdown(context=self.context)
        self._thread.join(timeout=2.0)

    # -- the servers ---------------------------------------------------------------------------------------
    def _on_goal(self, action: str, goal: Any) -> Any:
        ok = self.scripts[action](goal).accept
        return self._goal_response.ACCEPT if ok else self._goal_response.REJECT

    def _on_cancel(self, action: str, handle: Any) -> Any:
        with self._lock:
            for seen in self.goals[action]:
                if seen.handle is handle:
                    seen.cancel_requested = True
        ok = self.scripts[action](handle.request).accept_cancel
        return self._cancel_response.ACCEPT if ok else self._cancel_response.REJECT

    def _execute(self, action: str, handle: Any) -> Any:
        with self._lock:
            self._executing += 1
        try:
            return self._run_script(action, handle)
        finally:
            with self._lock:
                self._executing -= 1

    def _wait_for_feedback_subscriber(self, action: str, timeout_s: float = 2.0) -> None:
        """Wait (at most `timeout_s`) until a client's feedback subscription is discovered. The goal services
        can match before the feedback topic does, and feedback published before that is lost (DDS): under
        load a test's client missed the first message the script sent right after accepting."""
        topic = f"{self.node.get_namespace().rstrip('/')}/{action}/_action/feedback"
        deadline = time.monotonic() + timeout_s
        while self.node.count_subscribers(topic) == 0 and time.monotonic() < deadline:
            time.sleep(0.01)

    def _run_script(self, action: str, handle: Any) -> Any:
        action_type = self.types[action]
        script = self.scripts[action](handle.request)
        seen = Seen(goal=handle.request, handle=handle)
        with self._lock:
            self.goals[action].append(seen)
        steps = [action_type.Feedback(**step) for step in script.feedback]
        if steps:
            self._wait_for_feedback_subscriber(action)
        i = 0
        while True:
            if action in self._vanished:
                self._release.wait()  # no result ever reaches the client
                return action_type.Result()
            if self._release.is_set():  # closing: a held goal ends (aborted by rclpy)
                return action_type.Result()
            if handle.is_cancel_requested:
                handle.canceled()
                seen.end = "canceled"
                return action_type.Result()
            if i < len(steps):
                handle.publish_feedback(steps[i])
                i += 1
            elif script.outcome != "hold":
                break
            elif steps:
                handle.publish_feedback(steps[-1])
            time.sleep(script.period_s)
        if script.outcome == "succeed":
            handle.succeed()
            seen.end = "succeeded"
        else:
            handle.abort()
            seen.end = "aborted"
        return action_type.Result(**script.result)
