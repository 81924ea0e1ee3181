"""A tree as plain data: every node's name, kind, status and feedback — for logs, the ROS topic
``/mission/tree``, the web view and reports. One function, used by every viewer."""

from __future__ import annotations

from typing import Any

import py_trees


def node_kind(node: py_trees.behaviour.Behaviour) -> str:
    """Action | Condition | Control | Decorator (Groot2's vocabulary)."""
    if isinstance(node, py_trees.composites.Composite):
        return "Control"
    if isinstance(node, py_trees.decorators.Decorator):
        return "Decorator"
    return str(getattr(type(node), "NODE_TYPE", "Action"))


def snapshot(root: py_trees.behaviour.Behaviour) -> dict[str, Any]:
    """The tree under `root` with statuses, as nested dicts (JSON-serialisable)."""
    return {
        "name": root.name,
        "type": type(root).__name__,
        "kind": node_kind(root),
        "status": root.status.name,
        "feedback": root.feedback_message or "",
        "children": [snapshot(c) for c in root.children],
    }


def active_branch(root: py_trees.behaviour.Behaviour) -> list[str]:
    """Names from the root down the running (or last ticked) path: what the robot is doing now."""
    path = [root.name]
    node = root
    while node.children:
        running = [c for c in node.children if c.status == py_trees.common.Status.RUNNING]
        ticked = running or [c for c in node.children if c.status != py_trees.common.Status.INVALID]
        if not ticked:
            break
        node = ticked[-1] if not running else running[0]
        path.append(node.name)
    return path
