"""The world-adapter contract: the only code that knows where data comes from and where commands go.

The runner (mission/app/runner.py) drives every world the same way, once per step::

    adapter.sense(bb)   # newest frame, robot state, scan, map, clock, navigator status → blackboard
    (perception)        # the runner's perception stage on a new frame → detections, tracks
    tree.tick()         # behaviours read the blackboard and write intent (/goal/*)
    adapter.act(bb)     # intent → the simulated base / Nav2 goal_pose, cmd_vel, docking
    adapter.advance(dt) # simulated worlds step time; live worlds return at once

Optional: ``ground_truth()`` (a simulated world: what really is, for metrics and pictures),
``exhausted`` (a world that can run out, such as a bag: True once it has, and the loop ends) and
``waiting_for()`` (a live robot: what it still waits for before it may move, '' once its inputs are alive;
until then the runner senses and perceives but does not tick the tree, so nothing is commanded and the
mission's clock has not started).

Implementations: ``mission.sim.sim_adapter.SimAdapter`` (pybullet), ``mission.ros.ros_adapter`` (rclpy) and replay.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import py_trees


@runtime_checkable
class WorldAdapter(Protocol):
    def setup(self) -> None:
        """Connect / load the world. Constructors stay light; the heavy work happens here."""

    def sense(self, bb: py_trees.blackboard.Client) -> None:
        """Write the newest inputs to the blackboard (keys in mission.core.blackboard)."""

    def act(self, bb: py_trees.blackboard.Client) -> None:
        """Read /goal/nav_goal, /goal/twist (and /goal/dock_setpoint) and carry them out."""

    def advance(self, dt: float) -> None:
        """Let `dt` seconds of world time pass (a no-op for live worlds that run on their own clock)."""

    def now(self) -> float:
        """The world's time now (sim time, ROS time, the bag's time), seconds."""

    def close(self) -> None:
        """Release the world (disconnect, stop threads)."""


def waiting_for(world: object) -> str:
    """What `world` still waits for before the tree may run ('' for worlds that never wait: sim, replay)."""
    ask = getattr(world, "waiting_for", None)
    return str(ask()) if callable(ask) else ""
