"""The pybullet world as a ROS 2 robot — what Gazebo with ros_gz_bridge and Nav2 present to a mission node.

:class:`SimRobot` is a world adapter that wraps the simulation (sim/sim_adapter.py) and puts it behind topics:

* out, on sim time: ``/clock`` every step; the camera image, camera info (and depth when the scenario renders
  it) at the camera rate; ``/odom`` and ``/tf`` (map → odom, odom → base_link) every step; with a
  ``localization:`` that drifts, ``/odom`` is the wheels' odometry, map → odom the AMCL-like corrector's, and
  ``/amcl_pose`` (transient local) its estimate at each update; ``/scan`` at the lidar rate; ``/map``
  (transient local) and ``/tf_static`` (base_link → camera_link → camera_optical_frame,
  base_link → base_scan) once;
* in: ``/cmd_vel`` (a twist overrides navigation while it keeps coming, 0.5 s), Nav2's ``navigate_to_pose``
  action served by the sim's navigator (feedback with the distance remaining; succeeded, aborted with the
  navigator's reason, canceled; a new goal preempts the running one, which ends aborted as in
  bt_navigator), and ``/goal_pose``;
* back from the node: ``/mission/status`` (state, reason, root status), so the run is scored here against
  ground truth by the same code and criteria as ``mission run`` (mission/app/sim_run.py);
* ``/sim/ground_truth`` (std_msgs/String, JSON, every step): what only a simulator knows — the robot's true
  pose in the map, and how the camera stands to the dock tag (lateral, distance from the scenario's standoff,
  skew), as the runs are scored. For tests and benches of a node in server mode, whose goals this process
  does not see.

A scenario's ``external_detector`` adds what a robot team's person tracker would publish: the target's pose on
a topic (and a TF frame), in line of sight of the robot, noisy and with dropouts — for FollowObject goals.

With ``serve`` (``mission sim-robot --serve``) the node runs no mission but serves Nav2's actions: its tree
finishing ends a goal, not the run, which lasts the scenario's duration (or ``--max-duration``).

Faults (``--fault``, for tests and demonstrations): ``abort_goals`` (every goal aborted), ``no_nav_server``
(no navigate_to_pose action server: a robot whose Nav2 is not up), ``no_tf`` (no /tf
or /tf_static), ``tf_loop`` (a second publisher sends base_link → odom), ``tf_stale_at=S`` (/tf stops at S s),
``clock_back_at=S`` (at S s the clock jumps back 5 s, once), ``image_delay_s=D`` (images published D s after
they were taken, with their true stamp).
"""

from __future__ import annotations

import itertools
import json
import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import py_trees

from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.errors import ConfigError
from mission.core.types import Frame, NavGoal, NavStatus, Pose2D, RobotState, Twist
from mission.ros.conversions import (
    array_to_image,
    grid_to_msg,
    intrinsics_to_camera_info,
    pose2d_to_pose_with_covariance,
    pose_stamped,
    pose_to_matrix,
    scan_to_msg,
    state_to_odometry,
    transform_stamped,
)
from mission.ros.messages import RclpyMessages, time_msg
from mission.sim.sim_adapter import SimAdapter

CMD_VEL_TIMEOUT_S = 0.5  # a twist holds this long (sim time) without a new one
CLOCK_JUMP_S = 5.0
NODE_NAME = "sim_robot"
FAULTS = ("abort_goals", "no_nav_server", "no_tf", "tf_loop", "tf_stale_at", "clock_back_at", "image_delay_s")
_SEQ = itertools.count(1_000_000)  # goal seqs of this process (the node's own seqs never reach here)


@dataclass
class Faults:
    abort_goals: bool = False
    no_nav_server: bool = False
    no_tf: bool = False
    tf_loop: bool = False
    tf_stale_at: float | None = None
    clock_back_at: float | None = None
    image_delay_s: float = 0.0

    @classmethod
    def parse(cls, items: list[str]) -> Faults:
        f = cls()
        for item in items:
            name, _, value = item.partition("=")
            if name not in FAULTS:
                raise ConfigError(f"unknown fault {name!r}; known: {', '.join(FAULTS)}", key="--fault")
            if name in ("abort_goals", "no_nav_server", "no_tf", "tf_loop"):
                setattr(f, name, True)
                continue
            try:
                setattr(f, name, float(value))
            except ValueError:
                raise ConfigError(f"{name}: expected {name}=SECONDS, got {item!r}", key="--fault") from None
        return f


@dataclass
class _Goal:
    handle: Any  # the action goal handle, or None for a /goal_pose goal
    future: Any
    nav: NavGoal
    done: bool = False
    feedback: list[float] = field(default_factory=list)


class SimRobot:
    """A WorldAdapter: the SimAdapter's world, with sensors out and commands in over ROS (module doc)."""

    def __init__(self, sim: SimAdapter, faults: Faults | None = None, serve: bool = False) -> None:
        self.sim = sim
        self.faults = faults or Faults()
        self.serve = serve
        self.msgs = RclpyMessages()
        self.node: Any = None
        self.finished = False  # the node's tree reported SUCCESS or FAILURE
        self._status = py_trees.common.Status.RUNNING
        self._state, self._reason = "", ""
        self._remote: dict[str, Any] = {}
        self._twist: tuple[float, Twist] | None = None  # (sim time received, twist)
        self._goal: _Goal | None = None
        self._new_nav: NavGoal | None = None
        self._frame_seq = 0
        self._scan_stamp: float | None = None
        self._late: deque[tuple[float, Frame]] = deque()
        self._clock_offset = 0.0
        self._jumped = False
        self.counts: dict[str, int] = {}

    # -- set-up --------------------------------------------------------------------------------------
    def setup(self) -> None:
        import rclpy
        from rclpy.action import ActionServer, CancelResponse, GoalResponse
        from rclpy.executors import SingleThreadedExecutor

        from mission.ros.ros_adapter import LATCHED, RELIABLE, TF_QOS, TF_STATIC_QOS
        from mission.ros.tf_support import load_nav2, load_tf_message

        self.sim.setup()
        if not rclpy.ok():
            rclpy.init()
        self.node = rclpy.create_node(NODE_NAME)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        n, m = self.node, self.msgs
        tf = load_tf_message()
        nav2 = load_nav2()
        if tf.message is None or not nav2.ok:
            raise ConfigError(f"sim-robot needs tf2_msgs and nav2_msgs: {tf.detail}; {nav2.detail}", key="ros")
        self.tf_message = tf.message
        self.nav_action = nav2.get("action", "NavigateToPose")
        sensor = RELIABLE  # reliable publishers also reach best-effort (sensor-data) subscribers
        pose, string = m.cls("geometry_msgs/msg/PoseStamped"), m.cls("std_msgs/msg/String")
        self.pub = {
            "clock": n.create_publisher(m.cls("rosgraph_msgs/msg/Clock"), "/clock", 10),
            "image": n.create_publisher(m.cls("sensor_msgs/msg/Image"), "/camera/image_raw", sensor),
            "info": n.create_publisher(m.cls("sensor_msgs/msg/CameraInfo"), "/camera/camera_info", sensor),
            "depth": n.create_publisher(m.cls("sensor_msgs/msg/Image"), "/camera/depth/image_raw", sensor),
            "odom": n.create_publisher(m.cls("nav_msgs/msg/Odometry"), "/odom", sensor),
            "scan": n.create_publisher(m.cls("sensor_msgs/msg/LaserScan"), "/scan", sensor),
            "map": n.create_publisher(m.cls("nav_msgs/msg/OccupancyGrid"), "/map", LATCHED),
            "tf": n.create_publisher(self.tf_message, "/tf", TF_QOS),
            "tf_static": n.create_publisher(self.tf_message, "/tf_static", TF_STATIC_QOS),
            "truth": n.create_publisher(m.cls("std_msgs/msg/String"), "/sim/ground_truth", RELIABLE),
        }
        loc = self.sim.localization
        if loc is not None and loc.spec.amcl:  # AMCL's estimate at each update, latched as amcl publishes it
            amcl = m.cls("geometry_msgs/msg/PoseWithCovarianceStamped")
            self.pub["amcl_pose"] = n.create_publisher(amcl, "/amcl_pose", LATCHED)
        self._amcl_updates = 0
        detector = self.sim.scenario.external_detector
        if detector is not None and detector.topic:
            self.pub["detector"] = n.create_publisher(pose, detector.topic, RELIABLE)
        self.subs = [
            n.create_subscription(m.cls("geometry_msgs/msg/Twist"), "/cmd_vel", self._on_cmd_vel, RELIABLE),
            n.create_subscription(pose, "/goal_pose", self._on_goal_pose, RELIABLE),
            n.create_subscription(string, "/mission/status", self._on_status, LATCHED),
        ]
        self.server = (
            None
            if self.faults.no_nav_server
            else ActionServer(
                n,
                self.nav_action,
                "navigate_to_pose",
                execute_callback=self._execute,
                goal_callback=lambda _req: GoalResponse.ACCEPT,
                cancel_callback=lambda _h: CancelResponse.ACCEPT,
            )
        )
        self._publish_static()

    def _publish_static(self) -> None:
        m, t = self.msgs, self.sim.t
        cam = self.sim.scenario.camera.mount
        lidar_z = self.sim.scenario.lidar.height_m
        self.pub["map"].publish(grid_to_msg(m, self.sim.occupancy_grid, t))
        if self.faults.no_tf:
            return
        statics = [
            transform_stamped(
                m,
                se3.transform(se3.rot_y(math.radians(cam.pitch_deg)), (cam.x, cam.y, cam.z)),
                t,
                "base_link",
                "camera_link",
            ),
            transform_stamped(m, se3.transform(se3.R_BODY_OPTICAL), t, "camera_link", "camera_optical_frame"),
            transform_stamped(m, se3.transform(None, (0.0, 0.0, lidar_z)), t, "base_link", "base_scan"),
        ]
        self.pub["tf_static"].publish(self.tf_message(transforms=statics))

    # -- ROS callbacks (run by _spin, on this thread) ------------------------------------------------------
    def _spin(self) -> None:
        for _ in range(50):
            self.executor.spin_once(timeout_sec=0.0)

    def _count(self, what: str) -> None:
        self.counts[what] = self.counts.get(what, 0) + 1

    def _on_cmd_vel(self, msg: Any) -> None:
        self._twist = (self.sim.t, Twist(float(msg.linear.x), float(msg.angular.z)))

    def _on_goal_pose(self, msg: Any) -> None:
        t = pose_to_matrix(msg.pose)
        self._start(None, None, Pose2D(float(t[0, 3]), float(t[1, 3]), se3.yaw_of(t)))
        self._count("goal_pose")

    def _on_status(self, msg: Any) -> None:
        d = json.loads(msg.data)
        self._remote = d
        self._state, self._reason = str(d.get("state", "")), str(d.get("reason", ""))
        status = py_trees.common.Status.__members__.get(str(d.get("status", "RUNNING")), py_trees.common.Status.RUNNING)
        self._status = status
        self.finished = not self.serve and status in (py_trees.common.Status.SUCCESS, py_trees.common.Status.FAILURE)

    async def _execute(self, handle: Any) -> Any:
        from rclpy.task import Future

        t = pose_to_matrix(handle.request.pose.pose)
        future = Future()
        self._start(handle, future, Pose2D(float(t[0, 3]), float(t[1, 3]), se3.yaw_of(t)))
        self._count("goals")
        return await future

    def _start(self, handle: Any, future: Any, pose: Pose2D) -> None:
        if self._goal is not None and not self._goal.done:
            self._end(self._goal, "abort", "preempted by a newer goal")
        nav = NavGoal(pose=pose, stamp=self.sim.t, seq=next(_SEQ))
        self._goal = _Goal(handle, future, nav)
        self._new_nav = nav
        if self.faults.abort_goals:
            self._end(self._goal, "abort", "the simulated Nav2 aborts every goal (fault abort_goals)")

    def _end(self, goal: _Goal, how: str, why: str = "") -> None:
        goal.done = True
        self._count(f"goals_{how}")
        if goal.handle is None:
            return
        result = self.nav_action.Result()
        if how == "succeed":
            goal.handle.succeed()
        elif how == "cancel":
            goal.handle.canceled()
        else:
            result.error_code, result.error_msg = 9000, why  # 9000: UNKNOWN in Nav2's numbering
            goal.handle.abort()
        goal.future.set_result(result)

    # -- WorldAdapter --------------------------------------------------------------------------------
    def now(self) -> float:
        return self.sim.now()

    def sense(self, bb: py_trees.blackboard.Client) -> None:
        self._spin()
        seq = bbk.get(bb, bbk.FRAME_SEQ, 0)
        self.sim.sense(bb)
        t = self.sim.t
        self._maybe_jump(t)
        stamp = t - self._clock_offset
        self.pub["clock"].publish(self.msgs.new("rosgraph_msgs/msg/Clock", clock=time_msg(self.msgs, stamp)))
        state = bbk.get(bb, bbk.ROBOT_STATE)
        if isinstance(state, RobotState):
            self._publish_pose(state, stamp)
        frame = bbk.get(bb, bbk.FRAME)
        if bbk.get(bb, bbk.FRAME_SEQ, 0) != seq and isinstance(frame, Frame):
            self._late.append((t + self.faults.image_delay_s, frame))
        while self._late and self._late[0][0] <= t + 1e-9:
            self._publish_frame(self._late.popleft()[1])
        scan = bbk.get(bb, bbk.SCAN)
        if scan is not None and scan.stamp != self._scan_stamp:
            self._scan_stamp = scan.stamp
            self.pub["scan"].publish(scan_to_msg(self.msgs, _restamp(scan, scan.stamp - self._clock_offset)))
        self._report_goal(state)
        self._publish_truth(stamp)
        # what the remote tree says, for the metrics (this process runs no tree)
        bbk.set_(bb, bbk.STATE, self._state)
        bbk.set_(bb, bbk.REASON, self._reason)

    def _maybe_jump(self, t: float) -> None:
        at = self.faults.clock_back_at
        if at is not None and not self._jumped and t >= at:
            self._jumped = True
            self._clock_offset = CLOCK_JUMP_S

    def _publish_pose(self, state: RobotState, stamp: float) -> None:
        m = self.msgs
        loc = self.sim.localization  # drifting odometry and an AMCL-like corrector, when the scenario has them
        p = state.pose if loc is None else loc.odom
        mo = (0.0, 0.0, 0.0) if loc is None else (loc.map_from_odom.x, loc.map_from_odom.y, loc.map_from_odom.yaw)
        restamped = RobotState(p, state.twist, stamp)
        self.pub["odom"].publish(state_to_odometry(m, restamped, "odom", "base_link"))
        if self.faults.no_tf or (self.faults.tf_stale_at is not None and self.sim.t >= self.faults.tf_stale_at):
            return
        transforms = [
            transform_stamped(m, se3.planar(*mo), stamp, "map", "odom"),  # identity: perfect odometry
            transform_stamped(m, se3.planar(p.x, p.y, p.yaw), stamp, "odom", "base_link"),
        ]
        if self.faults.tf_loop:
            transforms.append(transform_stamped(m, se3.invert(se3.planar(p.x, p.y, p.yaw)), stamp, "base_link", "odom"))
        self.pub["tf"].publish(self.tf_message(transforms=transforms))
        if loc is not None and "amcl_pose" in self.pub and loc.updates != self._amcl_updates:
            self._amcl_updates = loc.updates
            sigma = (loc.spec.amcl_sigma_m, loc.spec.amcl_sigma_rad)
            self.pub["amcl_pose"].publish(pose2d_to_pose_with_covariance(m, loc.estimate, stamp, "map", *sigma))

    def _publish_truth(self, stamp: float) -> None:
        from mission.app.metrics import dock_errors

        self._publish_detector(stamp)
        gt = self.sim.ground_truth()
        p = gt.robot
        body: dict[str, Any] = {"t": round(stamp, 4), "robot": [p.x, p.y, p.yaw], "collisions": gt.collisions}
        if gt.target is not None:
            body["target"] = [gt.target.x, gt.target.y, gt.target.yaw]
        if gt.T_map_dock is not None:
            standoff = float(getattr(getattr(self.sim.scenario, "success", None), "standoff_m", 0.30) or 0.30)
            err = dock_errors(gt.T_map_optical, gt.T_map_dock, p.yaw, standoff)
            body["dock"] = {k: round(float(v), 5) for k, v in vars(err).items()}
        self.pub["truth"].publish(self.msgs.new("std_msgs/msg/String", data=json.dumps(body)))

    def _publish_detector(self, stamp: float) -> None:
        """The scenario's external detector's report of this step, if any (sim/external_detector.py)."""
        report, d = self.sim.detector_report, self.sim.scenario.external_detector
        if report is None or d is None:
            return
        if "detector" in self.pub:
            self.pub["detector"].publish(pose_stamped(self.msgs, report, stamp, "map"))
        if d.frame and not self.faults.no_tf:
            tf = transform_stamped(self.msgs, report, stamp, "map", d.frame)
            self.pub["tf"].publish(self.tf_message(transforms=[tf]))
        self._count("detections")

    def _publish_frame(self, frame: Frame) -> None:
        m, stamp = self.msgs, float(frame.stamp) - self._clock_offset
        if frame.intrinsics is not None:
            self.pub["info"].publish(intrinsics_to_camera_info(m, frame.intrinsics, stamp, frame.frame_id))
        if frame.depth is not None:
            self.pub["depth"].publish(array_to_image(m, frame.depth.astype("float32"), "32FC1", stamp, frame.frame_id))
        encoding = "bgr8" if frame.image.ndim == 3 else "mono8"
        self.pub["image"].publish(array_to_image(m, frame.image, encoding, stamp, frame.frame_id))
        self._count("images")

    def _report_goal(self, state: Any) -> None:
        goal, nav = self._goal, self.sim.navigator
        if goal is None or goal.done or nav is None:
            return
        if goal.handle is not None and goal.handle.is_cancel_requested:
            self._new_nav = None
            self.sim.navigator.cancel()
            self._end(goal, "cancel")
            return
        if self.sim.goal_seq != goal.nav.seq:  # not taken by the navigator yet (next act)
            return
        if nav.status == NavStatus.SUCCEEDED:
            self._end(goal, "succeed")
        elif nav.status == NavStatus.FAILED:
            self._end(goal, "abort", nav.reason or "navigation failed")
        elif goal.handle is not None and isinstance(state, RobotState):
            fb = self.nav_action.Feedback()
            fb.distance_remaining = float(state.pose.distance_to(goal.nav.pose))
            goal.handle.publish_feedback(fb)

    def act(self, bb: py_trees.blackboard.Client) -> None:
        self._spin()
        t = self.sim.t
        twist = self._twist
        goal = self._goal
        nav = goal.nav if goal is not None and not goal.done else None
        moving = twist is not None and (twist[1].v != 0.0 or twist[1].w != 0.0)
        newer = twist is not None and (nav is None or twist[0] > goal.nav.stamp)
        # a zero twist is the node letting go of /cmd_vel: it stops the base, never a navigation
        if twist is not None and t - twist[0] <= CMD_VEL_TIMEOUT_S and newer and (moving or nav is None):
            bbk.set_(bb, bbk.TWIST, twist[1])
            bbk.set_(bb, bbk.NAV_GOAL, None)
            if nav is not None:  # a twist took over: the navigation stops
                self._end(goal, "abort", "/cmd_vel took over")
        else:
            bbk.set_(bb, bbk.TWIST, None)
            bbk.set_(bb, bbk.NAV_GOAL, nav)
        self.sim.act(bb)

    def advance(self, dt: float) -> None:
        self.sim.advance(dt)

    def ground_truth(self) -> Any:
        return self.sim.ground_truth()

    def tree_status(self) -> py_trees.common.Status:
        """The remote tree's root status, as the node last reported it."""
        return self._status

    def close(self) -> None:
        import rclpy

        if self._goal is not None and not self._goal.done:
            self._end(self._goal, "abort", "the simulation ended")
        if self.node is not None:
            self._spin()
            if self.server is not None:
                self.server.destroy()
            self.executor.shutdown(timeout_sec=1.0)
            self.node.destroy_node()
            self.node = None
        if rclpy.ok():
            rclpy.shutdown()
        self.sim.close()

    # -- what the report needs of the world ------------------------------------------------------------
    @property
    def occupancy_grid(self) -> Any:
        return self.sim.occupancy_grid

    @property
    def dock_xy(self) -> Any:
        return self.sim.dock_xy


def _restamp(scan: Any, stamp: float) -> Any:
    import dataclasses

    return dataclasses.replace(scan, stamp=stamp)
