"""What the ROS node publishes about a run, as run observers (core/observers.py).

* :class:`PerceptionOutputs` — after every perceived frame: ``/marker_detected`` (on transitions),
  ``/aruco/debug`` (observations), ``/aruco_poses``, ``/detected_aruco_pose`` (the ``target`` track's
  detection in this frame, else the nearest detection), ``/tf`` (one frame per marker and label) and,
  when the node perceives only, the dock's pose through the world (``detected_dock_pose``).
* :class:`TreePublisher` — ``/mission/tree``: the tree snapshot when it changed, at most 2 Hz, latched.
* :class:`BehaviorTreeLogPublisher` — the tree for Nav2's tools: ``/behavior_tree_log``
  (nav2_msgs/BehaviorTreeLog: every node whose status changed in a tick, as bt_navigator publishes it) and
  ``/behavior_tree`` (std_msgs/String, latched: the tree's XML).
* :class:`StatusPublisher` — ``/mission/status`` (std_msgs/String JSON, latched, on change): the mission
  state, the root's status, the reason, the world fault (what the sim-robot scores a run by) and the tree.

The run's tree may come and go (an action server's goals, ``on_tree``): ``/behavior_tree`` then carries the
new tree's XML and ``/behavior_tree_log`` its changes from IDLE; ``/mission/tree`` the new tree's snapshot at
once (``"tree": null`` while none runs); ``/mission/status`` names the tree that runs (``"tree": null``).

/detected_aruco_pose goes out first: it is what a downstream controller waits for.

The payloads are plain data built in :mod:`mission.ros.marker_outputs` (tested without rclpy).
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mission.core import blackboard as bbk
from mission.core.observers import RunObserver, Tick
from mission.core.perception import Perceived
from mission.ros.conversions import matrix_to_pose, pose_stamped, transform_stamped
from mission.ros.marker_outputs import (
    VisibilityEdge,
    current_detection,
    detection_matrix,
    observation_json,
    tf_child_frames,
)
from mission.ros.messages import RclpyMessages, header_msg, time_msg

TREE_PUBLISH_PERIOD_S = 0.5  # /mission/tree at most 2 Hz


class PerceptionOutputs(RunObserver):
    """Publishes what perception found in each frame (see the module doc)."""

    def __init__(
        self,
        node: Any,
        msgs: RclpyMessages,
        *,
        camera_frame: str,
        has_target: bool,
        emit_dock: Callable[[str, Any], None] | None = None,
        tf_message: type | None = None,
    ) -> None:
        from mission.ros.ros_adapter import RELIABLE

        self.msgs = msgs
        self.camera_frame = camera_frame
        self.has_target = has_target  # the config names a `target`: publish its track, not the nearest
        self.emit_dock = emit_dock
        self.tf_message = tf_message
        cls = msgs.cls
        self.pub_marker = node.create_publisher(cls("std_msgs/msg/Bool"), "/marker_detected", RELIABLE)
        self.pub_debug = node.create_publisher(cls("std_msgs/msg/String"), "/aruco/debug", RELIABLE)
        self.pub_target = node.create_publisher(cls("geometry_msgs/msg/PoseStamped"), "/detected_aruco_pose", RELIABLE)
        self.pub_poses = node.create_publisher(cls("geometry_msgs/msg/PoseArray"), "/aruco_poses", RELIABLE)
        self.pub_tf = None
        if tf_message is not None:
            from rclpy.qos import QoSProfile

            self.pub_tf = node.create_publisher(tf_message, "/tf", QoSProfile(depth=100))
        self.edge = VisibilityEdge()

    def on_perception(self, run: Any, perceived: Perceived) -> None:
        if not perceived.processed or perceived.frame is None:
            return
        m, detections = self.msgs, perceived.detections
        changed = self.edge.update(bool(detections))
        if changed is not None:
            self.pub_marker.publish(m.new("std_msgs/msg/Bool", data=changed))
        if not detections:
            return
        frame = perceived.frame
        frame_id, stamp = frame.frame_id or self.camera_frame, float(frame.stamp)
        tracks = run.get(bbk.TRACKS, {}) or {}
        if self.has_target:
            target = current_detection(tracks, "target", stamp)
        else:
            target = min(detections, key=lambda d: d.distance)
        if target is not None:
            self.pub_target.publish(pose_stamped(m, detection_matrix(target), stamp, frame_id))
        self.pub_debug.publish(
            m.new("std_msgs/msg/String", data=json.dumps(observation_json(frame_id, stamp, detections)))
        )
        self.pub_poses.publish(
            m.new(
                "geometry_msgs/msg/PoseArray",
                header=header_msg(m, stamp, frame_id),
                poses=[matrix_to_pose(m, detection_matrix(d)) for d in detections],
            )
        )
        if self.emit_dock is not None:
            dock = current_detection(tracks, "dock", stamp)
            if dock is not None:
                self.emit_dock("dock", pose_stamped(m, detection_matrix(dock), stamp, frame_id))
        if self.pub_tf is not None and self.tf_message is not None:
            transforms = [
                transform_stamped(m, detection_matrix(d), stamp, frame_id, child)
                for d in detections
                for child in tf_child_frames(d)
            ]
            if transforms:
                self.pub_tf.publish(self.tf_message(transforms=transforms))


class TreePublisher(RunObserver):
    """``/mission/tree``: the snapshot when the tree's statuses or feedback changed, at most 2 Hz."""

    def __init__(self, node: Any, msgs: RclpyMessages) -> None:
        from mission.ros.ros_adapter import LATCHED

        self.msgs = msgs
        self.pub = node.create_publisher(msgs.cls("std_msgs/msg/String"), "/mission/tree", LATCHED)
        self._last_body = ""
        self._last_pub = -math.inf
        self._pending = False
        self._lock = threading.Lock()  # on_tree may come from an action server's thread

    def on_tick(self, run: Any, tick: Tick) -> None:
        self._publish(run, now=False)

    def on_tree(self, run: Any) -> None:
        """A new tree (or none) is published at once, not after the 2 Hz limit."""
        self._publish(run, now=True)

    def _publish(self, run: Any, *, now: bool) -> None:
        snap = run.snapshot()
        volatile = ("tick", "clock", "perception")  # change every frame; the tree itself may not
        body = json.dumps({k: v for k, v in snap.items() if k not in volatile}, sort_keys=True)
        with self._lock:
            if body != self._last_body:
                self._last_body = body
                self._pending = True
            t = time.monotonic()
            if not self._pending or (not now and t - self._last_pub < TREE_PUBLISH_PERIOD_S):
                return
            self._pending = False
            self._last_pub = t
        self.pub.publish(self.msgs.new("std_msgs/msg/String", data=json.dumps(snap)))


BT_STATUS = {"SUCCESS": "SUCCESS", "FAILURE": "FAILURE", "RUNNING": "RUNNING", "INVALID": "IDLE"}


class BehaviorTreeLogPublisher(RunObserver):
    """``/behavior_tree_log`` and ``/behavior_tree``: what Nav2's tools and behaviour-tree panels read.

    After every tick, one nav2_msgs/BehaviorTreeLog with an event per node whose status changed (py_trees'
    INVALID is BT.CPP's IDLE); ``uid`` is the node's place in a depth-first walk from 1, stable for the tree,
    ``node_name`` its name in the tree. The XML of the tree file goes out latched, again for every new tree
    (``on_tree``); a tree that stops or is replaced gets a last log of its nodes as the halt left them, and
    the next tree's first log reports its nodes' changes from IDLE."""

    def __init__(self, node: Any, msgs: RclpyMessages, nav2: Any, now: Callable[[], float]) -> None:
        from mission.ros.ros_adapter import LATCHED, RELIABLE

        self.msgs, self.now = msgs, now
        self.log_type = nav2.get("msg", "BehaviorTreeLog")
        self.event_type = nav2.get("msg", "BehaviorTreeStatusChange")
        self.pub_log = node.create_publisher(self.log_type, "/behavior_tree_log", RELIABLE)
        self.pub_xml = node.create_publisher(msgs.cls("std_msgs/msg/String"), "/behavior_tree", LATCHED)
        self._last: dict[int, str] = {}  # uid → the status last reported, for the tree in _tree
        self._tree: Any = None
        self._lock = threading.Lock()  # on_tree may come from an action server's thread
        self.published = 0

    def on_start(self, run: Any) -> None:
        self._follow(run)

    def on_tree(self, run: Any) -> None:
        with self._lock:
            if self._tree is not None:  # the old tree as its halt left it
                self._log(self._tree)
        self._follow(run)

    def _follow(self, run: Any) -> None:
        with self._lock:
            self._tree, self._last = run.tree, {}
        if run.tree is not None and run.tree_path is not None:
            self.pub_xml.publish(self.msgs.new("std_msgs/msg/String", data=Path(run.tree_path).read_text()))

    def on_tick(self, run: Any, tick: Tick) -> None:
        with self._lock:
            if run.tree is not None and run.tree is self._tree:
                self._log(run.tree)

    def _log(self, tree: Any) -> None:
        stamp = time_msg(self.msgs, self.now())
        events = []
        for uid, behaviour in enumerate(tree.root.iterate(), start=1):
            status = BT_STATUS.get(behaviour.status.name, "IDLE")
            previous = self._last.get(uid, "IDLE")
            if status != previous:
                self._last[uid] = status
                events.append(
                    self.event_type(
                        timestamp=stamp,
                        node_name=behaviour.name,
                        uid=uid,
                        previous_status=previous,
                        current_status=status,
                    )
                )
        if events:
            self.pub_log.publish(self.log_type(timestamp=stamp, event_log=events))
            self.published += 1


class StatusPublisher(RunObserver):
    """``/mission/status``: {state, status, reason, fault, tree, tick, clock} as JSON when any but tick/clock
    changed. ``tree`` is the file name of the tree that runs (null while none does: perception only, or an
    action server between goals; ``status`` is then the last tree's last status)."""

    def __init__(self, node: Any, msgs: RclpyMessages) -> None:
        from mission.ros.ros_adapter import LATCHED

        self.msgs = msgs
        self.pub = node.create_publisher(msgs.cls("std_msgs/msg/String"), "/mission/status", LATCHED)
        self._last: tuple[str, ...] = ()

    def on_tick(self, run: Any, tick: Tick) -> None:
        path = getattr(run, "tree_path", None)
        body = (
            str(run.get(bbk.STATE, "")),
            tick.status.name,
            str(run.get(bbk.REASON, "")),
            str(run.get(bbk.WORLD_FAULT, "")),
            None if run.tree is None or path is None else Path(path).name,
        )
        if body != self._last:
            self._last = body
            state, status, reason, fault, tree = body
            data = {
                "state": state,
                "status": status,
                "reason": reason,
                "fault": fault,
                "tree": tree,
                "tick": tick.index,
                "clock": round(float(tick.clock), 3),
            }
            self.pub.publish(self.msgs.new("std_msgs/msg/String", data=json.dumps(data)))
