"""What happened in one tick, as JSON-ready data: every node's status, feedback and own tick time, the
blackboard keys each node read and wrote, the mission state and where things are.

One :class:`TickProbe` per running tree, shared by every viewer (tick log, live page, report trees), so
the tree is instrumented once however many viewers watch it. It adds a py_trees visitor (timing) and a
post-tick handler (statuses, blackboard activity) — it observes and never changes what the tree does.
Cost, measured on the 8-node test tree (2-core machine): ≈0.1 ms more per tree tick with the
instrumentation, ≈0.15 ms to build a record — under 0.5 % of a 15 Hz tick period.

Node ids are pre-order indices (:mod:`mission.viz.model`); a record's ``nodes`` rows are
``[status, feedback, own_us]`` in that order (``own_us`` is null for nodes not ticked this tick).
"""

from __future__ import annotations

import math
import time
import weakref
from dataclasses import dataclass, field
from typing import Any

import py_trees

from mission.core import blackboard as bbk
from mission.core.snapshot import active_branch, snapshot
from mission.viz.model import VizNode, flatten_subtrees, from_description, from_snapshot, merge_static

_READS = {"READ", "ACCESSED"}
_WRITES = {"WRITE", "INITIALISED"}


def preorder(root: py_trees.behaviour.Behaviour) -> list[py_trees.behaviour.Behaviour]:
    """Nodes in pre-order: index = node id in every viewer."""
    out = [root]
    for c in root.children:
        out.extend(preorder(c))
    return out


def static_tree(root: py_trees.behaviour.Behaviour, tree_path: Any = None, factory: Any = None) -> VizNode:
    """The live tree's structure, with XML tags, ports and subtree names when its file is known.

    `factory` is the one the tree was built by (the runner's): its node types, and the port values a run
    set on it (``--set Tag.port=…``, BehaviourFactory.set_port), which the drawing shows as the node has
    them rather than as the file writes them."""
    live = from_snapshot(snapshot(root))
    if tree_path:
        try:
            from mission.trees.loader import describe_tree

            merge_static(live, flatten_subtrees(from_description(describe_tree(tree_path, factory))))
        except Exception:  # a tree we cannot describe is still drawn, with py_trees class names
            pass
    values = factory.port_values() if factory is not None and hasattr(factory, "port_values") else {}
    for n in live.walk():
        n.status, n.feedback = "INVALID", ""
        for port, value in values.get(n.type, {}).items():
            n.ports[port] = str(value).lower() if isinstance(value, bool) else str(value)
            n.defaults.pop(port, None)
    return live


class _TimingVisitor(py_trees.visitors.VisitorBase):
    """Time between consecutive node yields = that node's own share of the tick."""

    def __init__(self) -> None:
        super().__init__(full=False)
        self.own: dict[Any, float] = {}
        self._last = 0.0

    def initialise(self) -> None:
        self.own = {}
        self._last = time.perf_counter()

    def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        now = time.perf_counter()
        self.own[behaviour.id] = self.own.get(behaviour.id, 0.0) + (now - self._last)
        self._last = now


def _num(v: float) -> float | None:
    return round(float(v), 4) if v is not None and math.isfinite(float(v)) else None


def _pose(p: Any) -> list[float] | None:
    if p is None:
        return None
    return [_num(p.x), _num(p.y), _num(p.yaw)]


@dataclass
class _TreeTick:
    nodes: list[list[Any]]
    reads: dict[str, list[str]] = field(default_factory=dict)
    writes: dict[str, list[str]] = field(default_factory=dict)
    tick_us: float = 0.0
    status: str = "INVALID"
    active: list[str] = field(default_factory=list)


class TickProbe:
    """Instrumentation of one py_trees BehaviourTree; use :func:`probe_for` to get the shared one."""

    def __init__(self, tree: py_trees.trees.BehaviourTree, tree_path: Any = None, factory: Any = None) -> None:
        self.tree = tree
        self.nodes = preorder(tree.root)
        self.ids = {n.id: i for i, n in enumerate(self.nodes)}
        self.static = static_tree(tree.root, tree_path, factory)
        self._clients: dict[Any, int] = {}
        for i, n in enumerate(self.nodes):
            for client in getattr(n, "blackboards", []):
                self._clients[client.unique_identifier] = i
        self._timing = _TimingVisitor()
        self._t0 = 0.0
        self.last: _TreeTick | None = None
        self.users = 0
        self._own_stream = py_trees.blackboard.Blackboard.activity_stream is None
        if self._own_stream:
            py_trees.blackboard.Blackboard.enable_activity_stream(maximum_size=100_000)
        tree.add_visitor(self._timing)
        tree.add_pre_tick_handler(self._pre)
        tree.add_post_tick_handler(self._post)

    def _pre(self, _tree: py_trees.trees.BehaviourTree) -> None:
        self._t0 = time.perf_counter()

    def _post(self, tree: py_trees.trees.BehaviourTree) -> None:
        tick_us = (time.perf_counter() - self._t0) * 1e6
        own = self._timing.own
        # A node that is not running keeps its last feedback in py_trees ("following target" on a stopped
        # FollowTarget); viewers would show it as current, so an INVALID node's feedback is left out.
        nodes = [
            [
                n.status.name,
                (n.feedback_message or "") if n.status is not py_trees.common.Status.INVALID else "",
                None if n.id not in own else round(own[n.id] * 1e6, 1),
            ]
            for n in self.nodes
        ]
        reads: dict[str, set[str]] = {}
        writes: dict[str, set[str]] = {}
        stream = py_trees.blackboard.Blackboard.activity_stream
        if stream is not None:
            for item in stream.data:
                who = self._clients.get(item.client_id)
                key = str(who) if who is not None else item.client_name
                if item.activity_type in _READS:
                    reads.setdefault(key, set()).add(item.key)
                elif item.activity_type in _WRITES:
                    writes.setdefault(key, set()).add(item.key)
            stream.clear()
        self.last = _TreeTick(
            nodes=nodes,
            reads={k: sorted(v) for k, v in reads.items()},
            writes={k: sorted(v) for k, v in writes.items()},
            tick_us=round(tick_us, 1),
            status=tree.root.status.name,
            active=active_branch(tree.root),
        )

    def record(self, runner: Any, ground_truth: Any = None) -> dict[str, Any]:
        """The JSON-ready record of the tick that just ran (call after the tree ticked: an observer's on_tick)."""
        tt = self.last or _TreeTick(nodes=[["INVALID", "", None] for _ in self.nodes])
        rec: dict[str, Any] = {
            "tick": int(getattr(runner, "ticks", 0)),
            "t": _num(_run_time(runner)),
            "state": runner.get(bbk.STATE, "") or "",
            "reason": runner.get(bbk.REASON, "") or "",
            "status": tt.status,
            "tick_us": tt.tick_us,
            "active": tt.active,
            "nodes": tt.nodes,
            "bb": {"read": tt.reads, "write": tt.writes},
        }
        rec.update(world_record(runner, ground_truth))
        return rec

    def close(self) -> None:
        """Remove the instrumentation (the tree keeps running without it)."""
        for lst, item in (
            (self.tree.visitors, self._timing),
            (self.tree.pre_tick_handlers, self._pre),
            (self.tree.post_tick_handlers, self._post),
        ):
            if item in lst:
                lst.remove(item)
        if self._own_stream:
            py_trees.blackboard.Blackboard.disable_activity_stream()


def world_record(runner: Any, gt: Any = None) -> dict[str, Any]:
    """Where the robot, its goal, the target and the detections are (map frame; ground truth when simulated)."""
    state = runner.get(bbk.ROBOT_STATE)
    goal = runner.get(bbk.NAV_GOAL)
    twist = runner.get(bbk.TWIST)
    out: dict[str, Any] = {
        "robot": _pose(getattr(state, "pose", None)),
        "goal": _pose(getattr(goal, "pose", None)),
        "twist": None if twist is None else [_num(twist.v), _num(twist.w)],
    }
    tracks = runner.get(bbk.TRACKS, {}) or {}
    est = {}
    for name, tr in tracks.items():
        pm = getattr(tr, "pose_map", None)
        if pm is not None:
            est[name] = {
                "xy": [_num(pm[0][3]), _num(pm[1][3])],
                "visible": bool(getattr(tr, "visible", False)),
                "misses": int(getattr(tr, "misses", 0)),
            }
    out["tracks"] = est
    dets = runner.get(bbk.DETECTIONS, []) or []
    out["detections"] = [
        {
            "source": d.source,
            "id": d.marker_id,
            "label": d.label,
            "distance": _num(d.distance),
            "corners": None if d.corners is None else [[_num(u), _num(v)] for u, v in d.corners],
        }
        for d in dets
    ]
    if gt is not None:
        robot = getattr(gt, "robot", None)
        target = getattr(gt, "target", None)
        truth: dict[str, Any] = {"robot": _pose(robot), "target": _pose(target)}
        if robot is not None and target is not None:
            truth["distance"] = _num(robot.distance_to(target))
        los = getattr(gt, "target_in_los", None)
        if los is not None:
            truth["los"] = bool(los)
        out["truth"] = truth
    return out


_PROBES: weakref.WeakKeyDictionary[Any, TickProbe] = weakref.WeakKeyDictionary()


def probe_for(runner: Any) -> TickProbe:
    """The one probe of `runner`'s tree (created on first use, after ``runner.setup()``; the run must have a
    tree: ``runner.tree`` is None while an action server's run waits for a goal).

    Every viewer that calls this must call :func:`release_probe` with it when it is done (reference counted);
    the runner's tree may have changed by then (``on_tree``), so a viewer keeps the probe it was given.
    """
    tree = runner.tree
    if tree is None:
        raise ValueError("the run has no tree to probe (perception only, or no goal yet)")
    probe = _PROBES.get(tree)
    if probe is None:
        probe = TickProbe(tree, getattr(runner, "tree_path", None), getattr(runner, "factory", None))
        _PROBES[tree] = probe
    probe.users += 1
    return probe


def release(runner: Any) -> None:
    """A viewer is done with the probe of `runner`'s current tree (see :func:`release_probe`)."""
    probe = None if runner.tree is None else _PROBES.get(runner.tree)
    if probe is not None:
        release_probe(probe)


def release_probe(probe: TickProbe) -> None:
    """A viewer is done with `probe`; the last one removes the instrumentation from its tree."""
    probe.users -= 1
    if probe.users <= 0:
        if _PROBES.get(probe.tree) is probe:
            del _PROBES[probe.tree]
        probe.close()


def _run_time(runner: Any) -> float:
    """Seconds since the run's first step: the sim's clock starts at 0 anyway; ROS time counts from 1970."""
    elapsed = getattr(runner, "elapsed", None)
    if callable(elapsed):
        return float(elapsed())
    return float(runner.get(bbk.CLOCK, 0.0) or 0.0)
