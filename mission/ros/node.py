"""The ROS 2 node ``mission_tree``: the mission tree on live topics (``ros2 run mission tree``).

``install/mission/lib/mission/tree`` (colcon) and ``mission tree`` both run :func:`main`.

The node is wiring around the one loop (mission/app/runner.py). Perception runs when an image arrives:
the image callback places the frame (the camera pose from TF at the image's stamp) and calls
``runner.perceive()``, so a detection leaves on ``/detected_aruco_pose`` without waiting for a tick. Each
timer tick (``tick_hz``, on ROS time: ``-p use_sim_time:=true`` follows ``/clock``) is one
``runner.step()`` — the ROS adapter writes the newest odometry, scan, map, TF-derived poses and Nav2's
navigation status to the blackboard, the tree ticks on the latest blackboard (a frame perceived on arrival
is not perceived again), the adapter sends the tree's commands (``navigate_to_pose`` goals, ``/cmd_vel``).
Observers publish the rest (mission/ros/outputs.py): what perception found in each frame
(``/marker_detected`` on transitions, ``/aruco/debug``, ``/detected_aruco_pose``, ``/aruco_poses``,
``/tf``), ``/mission/tree`` when the tree changes (at most 2 Hz, latched), the tree for Nav2's tools
(``/behavior_tree_log``, nav2_msgs/BehaviorTreeLog status changes; ``/behavior_tree``, the XML) and
``/mission/status``. Two timers on the wall clock keep running when ROS time stops: the 1 Hz heartbeat,
and a watchdog that notices ``/clock`` or the camera going silent and then ticks the tree itself, so it
sees the fault. ``serve_port`` adds the live web view, ``groot_port`` Groot2's live monitor
(mission.groot.publisher).

``tree:=none`` runs no mission: perception only (the design notes' aruco_pose_streamer), and the node serves
Nav2's docking and following actions, ``dock_robot``, ``undock_robot`` and ``follow_object``, each goal running
its tree (``dock_tree``, ``undock_tree``, ``follow_tree``) on the same loop (mission/ros/task_servers.py).
``--params-file FILE`` reads Nav2's docking_server and following_server parameters — the dock database, dock
types, timeouts, retries, desired distance by Nav2's names (mission/ros/nav2_params.py) — from the ``/**``,
``docking_server``, ``following_server`` or ``mission_tree`` section. A followed object's poses (a goal's
``pose_topic`` or ``tracked_frame``) reach perception through the ``external_pose`` source, which server mode
adds to the config's sources.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import difflib
import json
import math
import sys
import time
from collections.abc import Sequence
from typing import Any

from mission.app.shipped import resolve_config
from mission.core import blackboard as bbk
from mission.core.config import MissionConfig, SourceConfig, TargetSpec, load_config
from mission.core.errors import ConfigError, MissionError
from mission.core.perception import PerceptionSource
from mission.perception_plugins.aruco import ArucoParams
from mission.perception_plugins.pipeline import source_statuses
from mission.ros import dds
from mission.ros.nav2_params import read_params_file, resolve_params_file

NODE_NAME = "mission_tree"

_ARUCO_DEFAULTS = ArucoParams()  # the aruco source's own defaults: one place for each (perception_plugins/aruco.py)

# name → (default, description): the node's ROS parameters (docs/ros.md's table lists the same)
PARAMETERS: dict[str, tuple[Any, str]] = {
    "image_topic": ("/camera/image_raw", "camera images (bgr8, rgb8, mono8)"),
    "camera_info_topic": ("/camera/camera_info", "camera calibration, paired with images by stamp"),
    "depth_topic": ("/camera/depth/image_raw", "depth images (16UC1 mm or 32FC1 m), paired by stamp"),
    "camera_frame": ("camera_optical_frame", "frame used when an image header has no frame_id"),
    "camera_exposure_s": (
        0.0,
        "the camera's exposure time as its driver is set (s): EXPLORE turns no faster than "
        "keeps a marker readable through the smear; 0 = not known, no cap",
    ),
    "marker_size_m": (_ARUCO_DEFAULTS.marker_size_m, "ArUco marker side length (without `config`)"),
    "dictionary": (
        _ARUCO_DEFAULTS.dictionary,
        "ArUco dictionary (without `config`); an unknown name stops the node with the names there are",
    ),
    "config": ("", "mission config YAML; its perception sources and targets replace the two above"),
    "tree": ("", "tree file or shipped tree name; empty = the config's tree; `none` = perception only"),
    "tick_hz": (0.0, "tree ticks per second; 0 = the config's run.tick_hz (15)"),
    "base_frame": ("base_link", "robot base frame"),
    "map_frame": ("map", "frame of goals (/goal_pose, /target_goal_pose)"),
    "odom_topic": ("/odom", "nav_msgs/Odometry"),
    "scan_topic": ("/scan", "sensor_msgs/LaserScan"),
    "map_topic": ("/map", "nav_msgs/OccupancyGrid (latched)"),
    "amcl_topic": ("/amcl_pose", "fallback for map → odom when /tf has none (AMCL's pose)"),
    "odom_frame": ("odom", "odometry frame: map → odom → base_frame on /tf"),
    "target_marker_id": (-1, "marker id of the `target` (>= 0 overrides the config's perception.targets)"),
    "camera_info_tolerance_s": (0.1, "largest stamp difference when pairing image ↔ camera info / depth"),
    "camera_xyz_rpy": (
        [0.0, 0.0, 0.3, 0.0, 0.0, 0.0],
        "fallback camera mount (no TF base_frame → camera): camera body frame x y z roll pitch yaw",
    ),
    "navigator": ("action", "`action`: Nav2's navigate_to_pose (status, errors reach the tree); `topic`: /goal_pose"),
    "nav_preempt_hz": (10.0, "at most this many new navigate_to_pose goals a second (the follow rate)"),
    "nav_server_timeout_s": (2.0, "wait this long for a navigate_to_pose server, then navigation leaves fail"),
    "goal_tolerance_m": (0.25, "navigator:=topic only: distance at which a sent goal counts as reached"),
    "tf_tolerance_s": (0.1, "an image this much newer than the newest transform still gets it (held)"),
    "image_late_s": (0.5, "images older than this on arrival are reported late in /robot/fault"),
    "input_timeout_s": (2.0, "no /clock (use_sim_time) or no image for this long (wall) is a fault the tree sees"),
    "dock_tree": ("dock_robot.xml", "tree:=none: the tree a dock_robot goal runs (file or shipped name)"),
    "undock_tree": ("undock_robot.xml", "tree:=none: the tree an undock_robot goal runs (file or shipped name)"),
    "follow_tree": ("follow_object.xml", "tree:=none: the tree a follow_object goal runs (file or shipped name)"),
    "serve_port": (0, "serve the live web view of the tree on 127.0.0.1:PORT; 0 = off"),
    "groot_port": (0, "serve Groot2's live monitor on 127.0.0.1:PORT and PORT+1 (Groot2's default 1667); 0 = off"),
}


# Ranges beyond the type of the default (None: any value of that type).
_PARAM_RANGES: dict[str, tuple[float, float, str]] = {
    "tick_hz": (0.0, 200.0, "a number from 0 (the config's rate) to 200"),
    "marker_size_m": (1e-6, math.inf, "a side length > 0 (m)"),
    "camera_info_tolerance_s": (0.0, math.inf, "a time ≥ 0 (s)"),
    "camera_exposure_s": (0.0, 0.2, "an exposure time from 0 (not known) to 0.2 s"),
    "goal_tolerance_m": (1e-6, math.inf, "a distance > 0 (m)"),
    "serve_port": (0, 65535, "a TCP port 0..65535"),
    "nav_preempt_hz": (1e-3, 1000.0, "a rate > 0 (Hz)"),
    "nav_server_timeout_s": (0.0, math.inf, "a time ≥ 0 (s)"),
    "tf_tolerance_s": (0.0, math.inf, "a time ≥ 0 (s)"),
    "image_late_s": (0.0, math.inf, "a time ≥ 0 (s; 0 = off)"),
    "input_timeout_s": (0.1, math.inf, "a time > 0 (s)"),
    "groot_port": (0, 65534, "a TCP port 1..65534 (PORT and PORT+1 are used), or 0 for off"),
    "target_marker_id": (-1, math.inf, "a marker id ≥ 0, or -1"),
}


# Parameters every rclpy node has (declared by rclpy itself): given on the command line, they are not unknown.
BUILTIN_PARAMETERS = ("use_sim_time",)
NAVIGATORS = ("action", "topic")


def given_params(argv: Sequence[str]) -> list[str]:
    """Names set with ``-p NAME:=VALUE`` / ``--param`` after ``--ros-args`` (a ``node:`` prefix removed)."""
    names, in_ros, it = [], False, iter(argv)
    for token in it:
        if token == "--ros-args":
            in_ros = True
        elif token == "--":
            in_ros = False
        elif in_ros and token in ("-p", "--param"):
            rule = next(it, "")
            names.append(rule.split(":=", 1)[0].rsplit(":", 1)[-1])
    return names


def ros_params_files(argv: Sequence[str]) -> list[str]:
    """Files given with ``--params-file FILE`` after ``--ros-args``: rcl applies what matches our own parameters,
    and the node reads Nav2's docking_server keys from them too."""
    files, in_ros, it = [], False, iter(argv)
    for token in it:
        if token == "--ros-args":
            in_ros = True
        elif token == "--":
            in_ros = False
        elif in_ros and token == "--params-file":
            files.append(next(it, ""))
    return [f for f in files if f]


def check_params(params: dict[str, Any], given: Sequence[str] = ()) -> None:
    """Every parameter has the type of its default and a usable value, and every one given is known.

    ROS itself accepts ``-p tick_hz:=-5`` or ``-p tick_hz:=fast`` (dynamic typing) and ignores a misspelt
    name (``-p marker_size:=0.1`` for marker_size_m): here each is one ConfigError naming the parameter, with
    a did-you-mean, before anything starts."""
    for name in given:
        if name not in PARAMETERS and name not in BUILTIN_PARAMETERS:
            close = difflib.get_close_matches(name, list(PARAMETERS), n=1)
            hint = f" (did you mean {close[0]}?)" if close else ""
            raise ConfigError(
                f"unknown parameter{hint}; the node's parameters: {', '.join(PARAMETERS)}", key=f"-p {name}"
            )
    for name, (default, _doc) in PARAMETERS.items():
        value, key = params[name], f"-p {name}"
        if isinstance(default, list):
            ok = (
                isinstance(value, list | tuple)
                and len(value) == len(default)
                and all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in value)
            )
            if not ok:
                raise ConfigError(f"expected 6 numbers [x, y, z, roll, pitch, yaw], got {value!r}", key=key)
            continue
        if isinstance(default, str):
            if not isinstance(value, str):
                raise ConfigError(f"expected a string, got {value!r}", key=key)
            if name == "navigator" and value not in NAVIGATORS:
                raise ConfigError(f"expected one of {', '.join(NAVIGATORS)}, got {value!r}", key=key)
            continue
        kind = int if isinstance(default, int) else float
        number = isinstance(value, int if kind is int else int | float) and not isinstance(value, bool)
        if not number or not math.isfinite(value):
            raise ConfigError(f"expected {'an integer' if kind is int else 'a finite number'}, got {value!r}", key=key)
        low, high, what = _PARAM_RANGES.get(name, (-math.inf, math.inf, ""))
        if not low <= value <= high:
            raise ConfigError(f"expected {what}, got {value!r}", key=key)


def build_config(params: dict[str, Any]) -> tuple[MissionConfig, str | None]:
    """The mission config: the YAML file when `config` is set, else an ArUco source from the ROS params."""
    config_file = params["config"] or None
    if config_file:
        config_file = resolve_config(config_file)  # a shipped config by name, as `mission run --config` takes
        config = load_config(config_file)
    else:
        source = SourceConfig(
            plugin="aruco",
            params={"dictionary": params["dictionary"], "marker_size_m": float(params["marker_size_m"])},
        )
        config = MissionConfig()
        config.perception.sources = [source]
    if int(params["target_marker_id"]) >= 0:
        config.perception.targets["target"] = TargetSpec(marker_id=int(params["target_marker_id"]))
    return config, config_file


class MissionNode:
    """Owns the rclpy node, the runner and the output publishers."""

    def __init__(
        self,
        argv: Sequence[str],
        cli_config: str | None = None,
        cli_tree: str | None = None,
        params_files: Sequence[str] = (),
    ) -> None:
        import rclpy
        from rcl_interfaces.msg import ParameterDescriptor
        from rclpy.node import Node

        self.rclpy = rclpy
        self.node = Node(NODE_NAME)
        for name, (default, doc) in PARAMETERS.items():
            # dynamic typing: `-p tick_hz:=10` (an int) is as good as 10.0
            self.node.declare_parameter(name, default, ParameterDescriptor(description=doc, dynamic_typing=True))
        self.params = {name: self.node.get_parameter(name).value for name in PARAMETERS}
        self.given = given_params(argv)
        self.params_files = [resolve_params_file(f) for f in (*params_files, *ros_params_files(argv))]
        if cli_config:
            self.params["config"] = cli_config
        if cli_tree:
            self.params["tree"] = cli_tree
        self.log = self.node.get_logger()
        self.runner = None
        self.sources: list[PerceptionSource] = []
        self._ticks_failed = 0
        self._tick_errors: set[str] = set()
        self.live_view: Any = None
        self.groot: Any = None
        self.tasks: Any = None

    # -- set-up ------------------------------------------------------------------------------------
    def setup(self) -> None:
        """Check the parameters, then wire the one loop: world, runner, observers, timers."""
        from rclpy.clock import Clock, ClockType

        from mission.app.runner import TreeRunner
        from mission.ros.messages import RclpyMessages
        from mission.ros.outputs import BehaviorTreeLogPublisher, PerceptionOutputs, StatusPublisher, TreePublisher
        from mission.ros.ros_adapter import RELIABLE, RosAdapter
        from mission.ros.tf_support import load_nav2, load_tf_message
        from mission.ros.world_io import RosTopics

        p, n = self.params, self.node
        check_params(p, self.given)
        config, config_file = build_config(p)
        tree = str(p["tree"] or "")
        self.perception_only = tree.lower() == "none"
        docking = self._docking_params() if self.perception_only else None
        if docking is not None and not any(s.plugin == "external_pose" for s in config.perception.sources):
            config.perception.sources.append(SourceConfig(plugin="external_pose"))  # follow_object's poses
        topics = RosTopics(
            image_topic=p["image_topic"],
            camera_info_topic=p["camera_info_topic"],
            depth_topic=p["depth_topic"],
            odom_topic=p["odom_topic"],
            scan_topic=p["scan_topic"],
            map_topic=p["map_topic"],
            amcl_topic=p["amcl_topic"],
            camera_frame=p["camera_frame"],
            base_frame=p["base_frame"],
            map_frame=p["map_frame"],
            odom_frame=p["odom_frame"],
            camera_info_tolerance_s=float(p["camera_info_tolerance_s"]),
            camera_exposure_s=float(p["camera_exposure_s"]),
            camera_xyz_rpy=[float(v) for v in p["camera_xyz_rpy"]],
            goal_tolerance_m=float(p["goal_tolerance_m"]),
            tf_tolerance_s=float(p["tf_tolerance_s"]),
            image_late_s=float(p["image_late_s"]),
        )
        self.msgs = RclpyMessages()
        tf = load_tf_message()
        tf_message = tf.message
        if tf_message is None:
            self.log.warning(f"/tf disabled (no TF in or out; camera_xyz_rpy and /amcl_pose are used): {tf.detail}")
        else:
            self.log.info(f"/tf: reading the robot's frames, publishing marker frames ({tf.detail})")
        self.nav2 = load_nav2()
        navigation = None
        # server mode without nav2_msgs (a bare pip install) still streams what perception sees
        if p["navigator"] == "action" and (self.nav2.ok or not self.perception_only):
            if not self.nav2.ok:
                raise ConfigError(
                    f"navigator:=action needs nav2_msgs: {self.nav2.detail}; or -p navigator:=topic", key="-p navigator"
                )
            from mission.ros.nav_client import ActionNavigation

            def navigation() -> ActionNavigation:
                return ActionNavigation(
                    n,
                    self.nav2.get("action", "NavigateToPose"),
                    preempt_hz=float(p["nav_preempt_hz"]),
                    server_timeout_s=float(p["nav_server_timeout_s"]),
                    warn=self.log.warning,
                    info=self.log.info,
                )

        self.adapter = RosAdapter(n, topics, tf_message=tf_message, navigation=navigation)
        self.outputs = PerceptionOutputs(
            n,
            self.msgs,
            camera_frame=topics.camera_frame,
            has_target="target" in config.perception.targets,
            emit_dock=self.adapter.emit if self.perception_only else None,
            tf_message=tf_message,
        )
        # in server mode the trees come with goals: the same outputs show each goal's tree
        observers: list[Any] = [self.outputs, TreePublisher(n, self.msgs), StatusPublisher(n, self.msgs)]
        if self.nav2.ok:
            observers.append(BehaviorTreeLogPublisher(n, self.msgs, self.nav2, self.adapter.now))
        else:
            self.log.warning(f"/behavior_tree_log disabled: {self.nav2.detail}")
        if int(p["serve_port"]) > 0:
            from mission.viz.web import LiveView

            self.live_view = LiveView(int(p["serve_port"]), close_at_end=False, quiet=True, option="-p serve_port")
            observers.append(self.live_view)
            self.log.info(f"live view at {self.live_view.url}")
        if int(p["groot_port"]) > 0:
            from mission.groot.publisher import Groot2Publisher

            self.groot = Groot2Publisher(int(p["groot_port"]), option="-p groot_port", quiet=True)
            observers.append(self.groot)
            self.log.info(f"Groot2 monitor on {self.groot.host}:{self.groot.port}")
        # a bad param is an error naming the config file and key; an unknown dictionary only warns
        self.runner = TreeRunner(
            config,
            self.adapter,
            None if self.perception_only else (tree or None),
            config_file=config_file,
            observers=observers,
            perception_only=self.perception_only,
        )
        self.runner.setup()
        self.sources = self.runner.sources
        if docking is not None:
            self._serve_tasks(docking)
        self.config = config
        self.adapter.on_image = self._on_image
        self.adapter.on_time_jump = self._on_time_jump
        self.sub_redetect = n.create_subscription(
            self.msgs.cls("std_msgs/msg/Empty"), "/mission/redetect", self._on_redetect, RELIABLE
        )
        tick_hz = float(p["tick_hz"]) or float(config.run.tick_hz)
        self.tick_timer = n.create_timer(1.0 / tick_hz, self._on_tick)  # ROS time: sim time with use_sim_time
        # wall clock: these keep running when ROS time stops (the simulation died, a bag paused)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.heartbeat_timer = n.create_timer(1.0, self._on_heartbeat, clock=steady)
        self.input_timeout_s = float(p["input_timeout_s"])
        self.use_sim_time = bool(n.get_parameter("use_sim_time").value)
        self._last_clock = time.monotonic()
        self._last_step = time.monotonic()
        if self.use_sim_time:
            self.sub_clock = n.create_subscription(
                self.msgs.cls("rosgraph_msgs/msg/Clock"), "/clock", self._on_clock, 10
            )
        self.watchdog_timer = n.create_timer(min(0.5, self.input_timeout_s / 2), self._on_watchdog, clock=steady)
        names = ", ".join(getattr(s, "name", type(s).__name__) for s in self.sources)
        what = f"tree {self.runner.tree_path}"
        if self.perception_only:
            what = "perception only" + ("; serving Nav2's docking and following actions" if self.tasks else "")
        self.log.info(
            f"{NODE_NAME}: {what} at {tick_hz:g} Hz; sources: {names}; "
            f"image {topics.image_topic}, camera info {topics.camera_info_topic}, camera frame {topics.camera_frame}"
        )

    def _server_params(self, server: str) -> tuple[dict[str, Any], str | None]:
        flat: dict[str, Any] = {}
        for path in self.params_files:
            flat.update(read_params_file(path, server, NODE_NAME))
        return flat, (self.params_files[-1] if self.params_files else None)

    def _docking_params(self) -> Any:
        """Nav2's docking_server parameters from the params files (defaults without one)."""
        from mission.ros.nav2_params import DockType, docking_params

        flat, file = self._server_params("docking_server")
        docking = docking_params(flat, file=file, warn=self.log.warning)
        if not docking.dock_types:  # Nav2 insists on dock_plugins; one default type keeps dock-by-pose simple
            docking = dataclasses.replace(docking, dock_types={"dock": DockType("dock")})
        return docking

    def _serve_tasks(self, docking: Any) -> None:
        from mission.ros.task_servers import TaskServers

        if not self.nav2.ok:
            self.log.warning(f"dock_robot / undock_robot not served: {self.nav2.detail}")
            return
        from rclpy.qos import qos_profile_sensor_data

        from mission.ros.external_poses import ExternalPoses
        from mission.ros.nav2_params import following_params

        flat, file = self._server_params("following_server")
        following = following_params(flat, file=file, warn=self.log.warning)
        if following.static_object_timeout > 0:
            self.log.warning("following_server static_object_timeout: not supported yet; a goal ends by max_duration")
        external = ExternalPoses(self.node, self.msgs.cls("geometry_msgs/msg/PoseStamped"), qos_profile_sensor_data)
        self.adapter.external = external
        self.tasks = TaskServers(
            self.node,
            self.nav2,
            self.runner,
            docking,
            following,
            external=external,
            trees={
                "dock": str(self.params["dock_tree"]),
                "undock": str(self.params["undock_tree"]),
                "follow": str(self.params["follow_tree"]),
            },
            map_frame=str(self.params["map_frame"]),
            now=self.adapter.now,
            log=self.log,
        )
        self.runner.attach(self.tasks)
        docks = ", ".join(docking.docks) or "none (dock by pose)"
        types = ", ".join(docking.dock_types)
        self.log.info(f"serving dock_robot, undock_robot, follow_object; docks: {docks}; dock types: {types}")

    # -- callbacks ---------------------------------------------------------------------------------
    def _failed(self, what: str, err: Exception) -> None:
        """A failing tick or perception must not take the node down: count, log once per kind."""
        self._ticks_failed += 1
        kind = f"{what}: {type(err).__name__}: {err}"
        if kind not in self._tick_errors:
            self._tick_errors.add(kind)
            self.log.error(f"{kind}; further identical errors are counted, not logged")

    def _on_tick(self) -> None:
        self._last_step = time.monotonic()
        try:
            self.runner.step()
        except Exception as err:
            self._failed("tick failed", err)

    def _on_image(self) -> None:
        """Perception on arrival: place the new frame at its stamp and perceive it now, not at the next tick.

        Until the first CameraInfo has arrived the frame waits for the tick instead: a driver publishes the
        two together, and the first image would otherwise be perceived with the fallback pinhole."""
        if not self.adapter.cache.stats.received.get("camera_info"):
            return
        try:
            if self.adapter.sense_frame(self.runner.bb):
                self.runner.perceive()
        except Exception as err:
            self._failed("perception failed", err)

    def _on_time_jump(self) -> None:
        if self.runner is not None and self.runner.perception is not None:
            self.runner.perception.reset_time()  # frames stamped before the old time are new, not stale

    def _on_clock(self, _msg: Any) -> None:
        self._last_clock = time.monotonic()

    def _on_watchdog(self) -> None:
        """Wall clock: notice /clock or the camera going silent; with ROS time stopped, tick the tree from here."""
        now, limit = time.monotonic(), self.input_timeout_s
        problems = []
        if self.use_sim_time and now - self._last_clock > limit:
            silent = now - self._last_clock
            problems.append(f"no /clock for {silent:.1f} s: the simulation (or the robot's clock) stopped")
        seen = self.adapter.last_input.get("image")
        if seen is not None and now - seen > limit:
            problems.append(f"no camera image on {self.adapter.topics.image_topic} for {now - seen:.1f} s")
        fault = "; ".join(problems)
        if fault and fault.split(" for ")[0] != self.adapter.extra_fault.split(" for ")[0]:
            self.log.warning(fault)
        self.adapter.extra_fault = fault
        if fault and now - self._last_step > limit and self.runner.tree is not None:
            self._on_tick()  # ROS time stands still: the tree still sees what is wrong

    def counters(self) -> dict[str, Any]:
        stats = dict(self.runner.get(bbk.PERCEPTION_STATS, {}) or {}) if self.runner else {}
        cache = self.adapter.cache.stats
        return {
            "mode": "perception" if self.perception_only else "tree",
            "tick": self.runner.ticks if self.runner else 0,
            "mission_state": self.runner.get(bbk.STATE, "") if self.runner else "",
            "frames_received": cache.received.get("image", 0),
            "frames_processed": int(stats.get("frames_processed", 0)),
            "frames_dropped": cache.images_dropped,
            "marker_visible": self.outputs.edge.visible,
            "ticks_failed": self._ticks_failed,
            "fault": self.runner.get(bbk.WORLD_FAULT, "") if self.runner else "",
            "time_jumps": self.adapter.time_jumps,
            "navigation": {
                "sent": getattr(self.adapter.navigation, "sent", None),
                "results": getattr(self.adapter.navigation, "results", None),
            },
            **cache.to_json(),
            "perception": {k: v for k, v in stats.items() if k not in ("frames_processed",)},
            "sources": source_statuses(self.sources),  # the VLM's budget, breaker (and why), model cost
            **({"goals": dict(self.tasks.counts)} if self.tasks is not None else {}),  # server mode: Nav2's actions
        }

    def _on_heartbeat(self) -> None:
        from mission.ros.marker_outputs import heartbeat_json

        self.outputs.pub_debug.publish(
            self.msgs.new("std_msgs/msg/String", data=json.dumps(heartbeat_json(NODE_NAME, self.counters())))
        )

    def _on_redetect(self, _msg: Any) -> None:
        reset = 0
        for src in self.sources:
            for method in ("reset_latch", "redetect", "reset"):
                fn = getattr(src, method, None)
                if callable(fn):
                    fn()
                    reset += 1
                    break
        self.log.info(f"/mission/redetect: reset {reset} source latch(es)")

    # -- run ---------------------------------------------------------------------------------------
    def spin(self) -> None:
        from rclpy.executors import ExternalShutdownException

        with contextlib.suppress(KeyboardInterrupt, ExternalShutdownException):
            self.rclpy.spin(self.node)

    def close(self) -> None:
        if self.tasks is not None:
            self.tasks.destroy()
            if self.tasks.external is not None:
                self.tasks.external.stop()
        if self.runner is not None:
            try:
                self.runner.close()  # observers end, sources close, the world lets go of its topics
            except Exception as err:  # closing must not hide the reason we stopped
                self.log.warning(f"closing the runner: {err}")
        if self.live_view is not None:
            self.live_view.close()
        if self.groot is not None:
            self.groot.close()
        self.node.destroy_node()


def _parse_cli(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="tree", description="the mission tree as a ROS 2 node")
    parser.add_argument("--config", default=None, help="mission config YAML (same as -p config:=FILE)")
    parser.add_argument("--tree", default=None, help="tree file, shipped tree name, or `none` (perception only)")
    parser.add_argument(
        "--params-file",
        action="append",
        default=[],
        metavar="FILE",
        help="with --tree none: a Nav2 params file (docking_server / following_server keys)",
    )
    return parser.parse_args(list(argv))


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``install/mission/lib/mission/tree`` and ``mission tree``."""
    argv = list(sys.argv if argv is None else argv)
    for note in dds.configure_transport():
        print(f"[{NODE_NAME}] {note}", file=sys.stderr)
    import rclpy
    from rclpy.utilities import remove_ros_args

    try:
        cli = _parse_cli(remove_ros_args(argv)[1:])
        rclpy.init(args=argv)
    except Exception as err:  # e.g. `-p name:=` — rcl's own parser: one line, not a traceback
        why = " ".join(str(err).split(", at /")[0].split())
        print(f"{NODE_NAME}: error: --ros-args: {why}", file=sys.stderr)
        return 2
    node: MissionNode | None = None
    try:
        node = MissionNode(argv, cli_config=cli.config, cli_tree=cli.tree, params_files=cli.params_file)
        try:
            node.setup()
        except MissionError as err:
            for line in str(err).splitlines():  # several problems (a config file's): one line each
                print(f"{NODE_NAME}: error: {line}", file=sys.stderr)
            return 2
        node.spin()
        return 0
    finally:
        if node is not None:
            node.close()
        if rclpy.ok():
            rclpy.shutdown()


if __name__ == "__main__":
    sys.exit(main())
