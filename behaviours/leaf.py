"""The base of every mission leaf: blackboard access by declared key, the clock, state/reason, commands.

Why a base class: every leaf follows the same rules (py_trees lifecycle, blackboard only, time from
CLOCK, the commands convention of docs/architecture.md), and getting them right once is simpler than
getting them right eleven times.

Commands convention (read by world adapters):

* navigate → NAV_GOAL = NavGoal(seq increasing), TWIST = None;
* drive    → TWIST = Twist(v, w), NAV_GOAL = None;
* stop     → TWIST = Twist(0, 0), NAV_GOAL = None.

A leaf withdraws its command in ``terminate()`` (preempted, failed or done) — but only if the command on
the blackboard is still its own. py_trees stops a preempted low-priority branch *after* the
higher-priority branch has ticked in the same tick, so blindly writing "stop" there would overwrite the
new branch's command.
"""

from __future__ import annotations

import itertools
import logging
import math
from typing import Any, ClassVar

import numpy as np
import py_trees
from py_trees.blackboard import Blackboard

from mission.behaviours.ports import PortsDeclared
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.blackboard import Key
from mission.core.types import Frame, NavGoal, NavStatus, Pose2D, RobotState, TargetTrack, Twist

log = logging.getLogger(__name__)

# One goal sequence for the whole process, so `seq` keeps increasing when the active leaf changes
# (FOLLOW → LOST → FOLLOW), as a navigator that ignores re-sent goals needs.
_NAV_SEQ = itertools.count(1)

STOP = Twist(0.0, 0.0)

# Camera at the base origin looking forward: what leaves assume (and say so) when the adapter gave no extrinsics.
DEFAULT_EXTRINSICS = se3.transform(se3.R_BODY_OPTICAL)
DEFAULT_HFOV = math.radians(70.0)  # when no frame with intrinsics has arrived yet


class MissionLeaf(py_trees.behaviour.Behaviour, PortsDeclared):
    """A py_trees leaf that talks to the world only through declared blackboard keys.

    Subclasses list the keys they read and write in ``READS`` / ``WRITES``; the constructor registers
    exactly those (cheap, no world attached), so a leaf cannot touch an undeclared key. Subclasses declare
    their XML ports in a nested ``Params`` (behaviours/ports.py); the constructor takes them as keywords
    and keeps the checked values as ``self.params``.
    """

    READS: ClassVar[tuple[Key, ...]] = ()
    WRITES: ClassVar[tuple[Key, ...]] = ()
    COMMANDS: ClassVar[bool] = False  # True for leaves that write NAV_GOAL / TWIST
    params: Any  # an instance of the subclass's Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        params = self.bind_params(ports)  # before anything is attached: a bad port leaves nothing behind
        name = type(self).__name__ if name is None else name
        super().__init__(name=name)
        self.params = params
        self.bb = self.attach_blackboard_client(name=name)
        reads = (bbk.CLOCK, bbk.ROBOT_STATE, bbk.CAMERA_EXTRINSICS, bbk.WORLD_FAULT, *self.READS)
        writes = tuple(self.WRITES)
        if self.COMMANDS:
            reads = (*reads, bbk.NAV_STATUS, bbk.NAV_REASON)
            writes = (*writes, bbk.NAV_GOAL, bbk.TWIST, bbk.STATE, bbk.REASON)
        bbk.register(self.bb, read=tuple(dict.fromkeys(reads)), write=tuple(dict.fromkeys(writes)))
        self._writable = frozenset(k.path for k in writes)
        self._readable = frozenset(k.path for k in reads) | self._writable
        self._own_goal: NavGoal | None = None
        self._own_twist: Twist | None = None
        self._warned_clock = False

    # -- reading ------------------------------------------------------------------------------------
    # The client checks access on every call and feeds the activity stream viewers read; with no stream
    # (nobody watching) a declared key goes straight to the store: the same value, a tenth of the cost
    # (the tree benchmark). An undeclared key still goes through the client, which refuses it.
    def read(self, key: Key, default: Any = None) -> Any:
        if Blackboard.activity_stream is None and key.path in self._readable:
            return Blackboard.storage.get(key.path, default)
        return bbk.get(self.bb, key, default)

    def write(self, key: Key, value: Any) -> None:
        if Blackboard.activity_stream is None and key.path in self._writable:
            Blackboard.storage[key.path] = value
            return
        bbk.set_(self.bb, key, value)

    def now(self) -> float:
        """CLOCK from the blackboard (the adapter's time base); never wall time.

        Falls back to the robot state's stamp (logged once) so a leaf's timers still advance when an
        adapter forgets the clock.
        """
        clock = self.read(bbk.CLOCK)
        if clock is not None:
            return float(clock)
        state = self.robot()
        if not self._warned_clock:
            self._warned_clock = True
            log.warning("%s: %s is not set; using the robot state's stamp as the clock", self.name, bbk.CLOCK.path)
        return float(state.stamp) if state is not None else 0.0

    def robot(self) -> RobotState | None:
        return self.read(bbk.ROBOT_STATE)

    def world_fault(self) -> str:
        """Why the world's inputs cannot be trusted now ('' when all is well): TF, clock, late images."""
        return str(self.read(bbk.WORLD_FAULT, "") or "")

    def waiting_for_pose(self, prefix: str = "") -> str:
        """The feedback of a leaf that needs the robot pose and has none, with the adapter's reason."""
        fault = self.world_fault()
        return f"{prefix}waiting for the robot pose" + (f" ({fault})" if fault else "")

    def extrinsics(self) -> np.ndarray:
        """T_base_optical from the blackboard, or DEFAULT_EXTRINSICS when the adapter did not give one."""
        ext = self.read(bbk.CAMERA_EXTRINSICS)
        return DEFAULT_EXTRINSICS if ext is None else np.asarray(ext, dtype=np.float64)

    def camera_xy(self, robot: Pose2D) -> tuple[float, float]:
        """Where the camera's optical centre is on the map floor, for the robot at `robot`.

        The planar transform applied by hand: a 4×4 product per tick costs more than the rest of a leaf's work."""
        ext = self.extrinsics()
        ex, ey = float(ext[0, 3]), float(ext[1, 3])
        c, s = math.cos(robot.yaw), math.sin(robot.yaw)
        return robot.x + c * ex - s * ey, robot.y + s * ex + c * ey

    def camera_pose(self, robot: Pose2D) -> tuple[float, float, float]:
        """(x, y, yaw) of the camera's optical centre and viewing direction in the map."""
        T = se3.planar(robot.x, robot.y, robot.yaw) @ self.extrinsics()
        return float(T[0, 3]), float(T[1, 3]), math.atan2(float(T[1, 2]), float(T[0, 2]))

    def hfov(self) -> float:
        """The camera's horizontal field of view (rad), from the newest frame's intrinsics (a leaf that asks
        declares FRAME in READS)."""
        frame: Frame | None = self.read(bbk.FRAME)
        k = None if frame is None else frame.intrinsics
        if k is None or not k.fx > 0 or not k.width:
            return DEFAULT_HFOV
        return 2.0 * math.atan2(k.width / 2.0, k.fx)

    def track(self, target: str) -> TargetTrack | None:
        """The named target's track (TRACKS is written by PerceiveTargets); None if never configured."""
        tracks = self.read(bbk.TRACKS) or {}
        return tracks.get(target)

    # -- mission state --------------------------------------------------------------------------------
    def set_state(self, state: str) -> None:
        self.write(bbk.STATE, state)

    def fail(self, reason: str) -> py_trees.common.Status:
        """Write `reason` to /mission/reason and the feedback, and return FAILURE."""
        self.feedback_message = reason
        self.write(bbk.REASON, reason)
        return py_trees.common.Status.FAILURE

    # -- commands -------------------------------------------------------------------------------------
    def navigate(self, pose: Pose2D) -> NavGoal:
        """Send a new navigation goal (new seq) and release any direct drive."""
        goal = NavGoal(pose=pose, stamp=self.now(), seq=next(_NAV_SEQ))
        self.resend_goal(goal)
        return goal

    def resend_goal(self, goal: NavGoal) -> None:
        """Keep `goal` (same seq) as the command: the adapter sees nothing new."""
        self._own_goal = goal
        self._own_twist = None
        self.write(bbk.NAV_GOAL, goal)
        self.write(bbk.TWIST, None)

    def drive(self, v: float, w: float) -> Twist:
        """Command a base velocity directly (overrides navigation)."""
        own = self._own_twist
        # the same command as last tick is the same object: nothing new for the adapter to compare
        twist = own if own is not None and own.v == v and own.w == w else Twist(float(v), float(w))
        self._own_twist = twist
        self._own_goal = None
        self.write(bbk.TWIST, twist)
        self.write(bbk.NAV_GOAL, None)
        return twist

    def halt(self) -> None:
        """Stop the base: TWIST = Twist(0, 0), NAV_GOAL = None (named so as not to shadow py_trees' stop())."""
        self.drive(0.0, 0.0)

    def owns_command(self) -> bool:
        """True while the command on the blackboard is still the one this leaf wrote."""
        if not self.COMMANDS:
            return False
        goal, twist = self.read(bbk.NAV_GOAL), self.read(bbk.TWIST)
        if self._own_goal is not None and goal == self._own_goal:
            return True
        return self._own_twist is not None and twist == self._own_twist and goal is None

    def withdraw_commands(self) -> None:
        """Stop the robot if our command is still the active one; leave another leaf's command alone."""
        if self.owns_command():
            self.write(bbk.NAV_GOAL, None)
            self.write(bbk.TWIST, STOP)
        self._own_goal = None
        self._own_twist = None

    def nav_outcome(self, goal: NavGoal) -> str | None:
        """NavStatus.SUCCEEDED / FAILED once the navigator has reported on `goal`, else None.

        NAV_STATUS is about the newest goal the adapter has taken, and the adapter takes a goal after the
        tick that wrote it; a terminal status is trusted only once the clock has moved past the goal's stamp
        (one sense → act round trip later), so a "succeeded" left over from the previous goal is not read as
        this goal's.
        """
        status = str(self.read(bbk.NAV_STATUS, NavStatus.IDLE))
        if status in (NavStatus.SUCCEEDED, NavStatus.FAILED) and self.now() > goal.stamp:
            return status
        return None

    def nav_reason(self) -> str:
        """What the navigator said about the current goal (why it failed: Nav2's error, 'no action server')."""
        return str(self.read(bbk.NAV_REASON, "") or "")

    def terminate(self, new_status: py_trees.common.Status) -> None:
        self.withdraw_commands()
