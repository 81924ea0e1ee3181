"""`mission task`: send Nav2's docking and following goals from a terminal, as `ros2 action send_goal` would.

`mission task dock --id home_dock`, `dock --pose X Y YAW`, `undock`, `follow --topic T | --frame F` — one goal
to ``dock_robot`` / ``undock_robot`` / ``follow_object`` through :class:`mission.ros.task_client.TaskClient`
(nav2_simple_commander's calls). Feedback is printed when it changes (the state's name, the retries), then the
result: ``SUCCEEDED: …``, or ``FAILED: DOCK_NOT_IN_DB (901): dock 'x' is not in the database`` with the error
code's name from the action's Result constants.

Exit status: 0 succeeded; 1 failed, rejected, canceled by someone else or the server went away; 2 bad
arguments or no action server (one line naming the action); 128 + the signal when Ctrl-C (SIGINT) or SIGTERM
stopped it. The first signal while a goal runs cancels the goal and waits for the server to say it is canceled
(up to --server-timeout); a second one stops at once.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from mission.ros import dds

ACTION_OF = {"dock": "dock_robot", "undock": "undock_robot", "follow": "follow_object"}


class _Stopped(BaseException):
    """A signal that stops the command now (none was running a goal, or it was the second)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


class _Signals:
    """SIGINT / SIGTERM: while a goal runs, the first is noted (the loop cancels the goal); else stop now."""

    def __init__(self) -> None:
        self.signum: int | None = None
        self.goal_running = False

    def _handle(self, signum: int, frame: Any) -> None:
        if self.goal_running and self.signum is None:
            self.signum = signum
            return
        raise _Stopped(signum)

    @contextmanager
    def installed(self) -> Iterator[_Signals]:
        previous = {s: signal.signal(s, self._handle) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            yield self
        finally:
            for s, handler in previous.items():
                signal.signal(s, handler)


def _say(line: str) -> None:
    print(line, flush=True)


def check(args: argparse.Namespace) -> str | None:
    """What is wrong with a combination of arguments argparse cannot check, or None."""
    if args.action == "dock" and args.id is not None:
        given = [f"--{name}" for name in ("type", "frame") if getattr(args, name) is not None]
        if given:
            verb = "go" if len(given) > 1 else "goes"
            return f"{' and '.join(given)} {verb} with --pose (a dock in the database has its own type and frame)"
    return None


def feedback_line(action: str, feedback: Any, names: dict[int, str]) -> tuple[tuple[Any, ...], str] | None:
    """(what counts as a change, the line) for a feedback message; None when it carries nothing (UndockRobot)."""
    if not hasattr(feedback, "state"):
        return None
    state = names.get(int(feedback.state), str(int(feedback.state)))
    retries = int(getattr(feedback, "num_retries", 0))
    elapsed = getattr(feedback, "docking_time", None) or getattr(feedback, "following_time", None)
    at = f", {elapsed.sec + elapsed.nanosec * 1e-9:.1f} s" if elapsed is not None else ""
    return (state, retries), f"{action}: {state} (retries {retries}{at})"


def result_line(outcome: Any) -> str:
    """The last line: how the task ended, with the Result's error code by name."""
    kind = outcome.result.name
    if outcome.result.name == "SUCCEEDED":
        details = []
        if outcome.num_retries:
            details.append(f"{outcome.num_retries} retr{'y' if outcome.num_retries == 1 else 'ies'}")
        if outcome.elapsed_s:
            details.append(f"after {outcome.elapsed_s:.1f} s")
        return f"SUCCEEDED: {outcome.action}" + (f" ({', '.join(details)})" if details else "")
    if outcome.error_code and outcome.message is not None:  # no message: no result came (the server went away)
        line = f"{kind}: {outcome.error_name} ({outcome.error_code})"
        return f"{line}: {outcome.error_msg}" if outcome.error_msg else f"{line}: {outcome.action}"
    return f"{kind}: {outcome.error_msg}" if outcome.error_msg else f"{kind}: {outcome.action}"


def _send(nav: Any, args: argparse.Namespace) -> Any:
    if args.action == "dock":
        if args.id is not None:
            return nav.dockRobotByID(args.id, not args.no_nav, max_staging_time=args.max_staging_time)
        from mission.core.types import Pose2D
        from mission.ros.conversions import pose2d_stamped
        from mission.ros.messages import RclpyMessages

        x, y, yaw = args.pose
        # stamp 0: "the latest transform" to the server, whichever clock (sim or wall) it runs on
        pose = pose2d_stamped(RclpyMessages(), Pose2D(x, y, yaw), 0.0, args.frame or "map")
        return nav.dockRobotByPose(pose, args.type or "", not args.no_nav, max_staging_time=args.max_staging_time)
    if args.action == "undock":
        return nav.undockRobot(args.type or "", max_undocking_time=args.max_undocking_time)
    if args.topic is not None:
        return nav.followObjectByTopic(args.topic, args.max_duration)
    return nav.followObjectByFrame(args.frame, args.max_duration)


def main(args: argparse.Namespace) -> int:
    problem = check(args)
    if problem:
        print(f"mission task {args.action}: error: {problem}", file=sys.stderr)
        return 2
    for note in dds.configure_transport():
        _say(f"mission task: {note}")
    signals = _Signals()
    try:
        with signals.installed():
            return _run(args, signals)
    except _Stopped as stop:
        return 128 + stop.signum


def _run(args: argparse.Namespace, signals: _Signals) -> int:
    from mission.ros.task_client import RunningTask, TaskClient, constants

    task = {"dock": RunningTask.DOCK_ROBOT, "undock": RunningTask.UNDOCK_ROBOT, "follow": RunningTask.FOLLOW_OBJECT}
    with TaskClient("mission_task", args.namespace or "", server_timeout_s=args.server_timeout) as nav:
        action = nav.action_name(task[args.action])
        names = constants(nav.action_type(task[args.action]).Feedback)
        last: list[tuple[Any, ...]] = []
        early: list[str] | None = []  # feedback that came before the goal's acceptance was read: said after it

        def on_feedback(feedback: Any) -> None:
            change = feedback_line(action, feedback, names)
            if change is not None and change[0] not in last[-1:]:
                last.append(change[0])
                if early is None:
                    _say(change[1])
                else:
                    early.append(change[1])

        nav.on_feedback = on_feedback
        nav.wait_for_server(task[args.action])  # a signal now stops at once: there is nothing to cancel
        signals.goal_running = True  # from here a signal cancels the goal
        if _send(nav, args) is None:
            _say(f"FAILED: {nav.getTaskError()[1]}")
            return 1 if signals.signum is None else 128 + signals.signum
        _say(f"{action}: goal accepted (Ctrl-C cancels it)")
        for line in early:
            _say(line)
        early = None
        deadline: float | None = None  # after a cancel: how long the server has to end the goal
        while not nav.isTaskComplete():
            if signals.signum is not None and deadline is None:
                _say(f"{action}: canceling the goal")
                if not nav.cancelTask():
                    _say(f"{action}: {nav.getTaskError()[1]}")
                    return 128 + signals.signum
                deadline = time.monotonic() + nav.server_timeout_s
            if deadline is not None and time.monotonic() > deadline:
                _say(f"{action}: the server accepted the cancel but did not end the goal in {nav.server_timeout_s:g} s")
                return 128 + signals.signum
        outcome = nav.last_result
        _say(result_line(outcome))
        if outcome.result.name == "SUCCEEDED":
            return 0
        if outcome.result.name == "CANCELED" and signals.signum is not None:
            return 128 + signals.signum
        return 1
