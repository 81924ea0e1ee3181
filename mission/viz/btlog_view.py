"""A Groot2 log (.btlog, BT.CPP's FileLogger2) as the ticks every viewer draws: ``mission viz --log run.btlog``.

The tree is the log's own XML (its ``<BehaviorTree>`` instances joined at their ``<SubTree>`` nodes by
``_fullpath``), drawn as BT.CPP shapes it, SubTree nodes included. A log has transitions, not ticks: the
transitions that share a timestamp form one step (in a log `mission run --btlog` wrote, one tick; in
one BT.CPP wrote, usually a single status change), and each step is a record with every node's status
after it, in the same shape as a tick log's (mission.viz.tick_log), so the text, SVG, PNG and HTML
playback views work unchanged. BT.CPP's IDLE is drawn as not ticked, SKIPPED as not ticked with the
feedback "skipped". BT.CPP resets finished nodes to IDLE when their parent finishes; within one step a
node is drawn with the status it reached there (as Groot2 draws it faded), so the step that ends a tree
still shows what succeeded and what failed.
"""

from __future__ import annotations

import time
import xml.etree.ElementTree as ET
from itertools import groupby
from pathlib import Path
from typing import Any

from mission.core.errors import MissionError
from mission.groot import protocol as p
from mission.groot.btlog import read_btlog
from mission.viz.model import VizNode, count, from_description, to_dict
from mission.viz.tick_log import LOG_VERSION, TickLogData

_STATUS_NAMES = {
    p.IDLE: "INVALID",
    p.RUNNING: "RUNNING",
    p.SUCCESS: "SUCCESS",
    p.FAILURE: "FAILURE",
    p.SKIPPED: "INVALID",
}
_EXPLICIT = ("Action", "Condition", "Control", "Decorator")
_NOT_PORTS = frozenset({"ID", "name", "_uid", "_fullpath"})


def _tree_from_xml(xml: str, where: Path) -> tuple[VizNode, list[int]]:
    """The drawing tree and, in its pre-order, each node's UID."""
    try:
        root = ET.fromstring(xml)
    except ET.ParseError as err:
        raise MissionError(f"{where}: the log's tree XML is malformed ({err})") from None
    instances = {el.get("_fullpath", ""): el for el in root.findall("BehaviorTree")}
    if not instances:
        raise MissionError(f"{where}: the log's tree XML has no <BehaviorTree>")
    kinds = {m.get("ID", ""): m.tag for m in root.findall("TreeNodesModel/*")}
    uids: list[int] = []

    def node(el: ET.Element, depth: int) -> dict[str, Any]:
        if depth > 200:
            raise MissionError(f"{where}: the log's tree nests deeper than 200 levels (a SubTree loop?)")
        try:
            uids.append(int(el.get("_uid", "")))
        except ValueError:
            raise MissionError(f"{where}: <{el.tag}> in the log's tree has no numeric _uid") from None
        ports = {k: v for k, v in el.attrib.items() if k not in _NOT_PORTS and not k.startswith("_")}
        if el.tag == "SubTree":
            tree_id = el.get("ID", "")
            inner = instances.get(el.get("_fullpath", ""))
            children = [node(inner[0], depth + 1)] if inner is not None and len(inner) else []
            return {
                "tag": "SubTree",
                "name": _subtree_name(el),
                "kind": "SubTree",
                "ports": ports,
                "children": children,
                "subtree": tree_id,
            }
        tag = el.get("ID", "") if el.tag in _EXPLICIT else el.tag
        kind = el.tag if el.tag in _EXPLICIT else kinds.get(tag)
        return {
            "tag": tag,
            "name": el.get("name") or tag,
            "kind": kind,
            "ports": ports,
            "children": [node(child, depth + 1) for child in el],
        }

    main = instances.get("") or root.find("BehaviorTree")
    assert main is not None
    if not len(main):
        raise MissionError(f"{where}: the main <BehaviorTree> of the log has no root node")
    viz = from_description(node(main[0], 0))
    return viz, uids


def _subtree_name(el: ET.Element) -> str:
    """The SubTree's ``name``; BT.CPP writes none, but its ``_fullpath`` ends with it (else with ``ID::uid``)."""
    tree_id = el.get("ID", "")
    last = el.get("_fullpath", "").rsplit("/", 1)[-1]
    return el.get("name") or (last if last and not last.startswith(f"{tree_id}::") else tree_id)


def read_btlog_ticks(path: str | Path) -> TickLogData:
    """A .btlog as a tick log: header with the tree, one record per timestamp, no end record."""
    log = read_btlog(path)
    root, uids = _tree_from_xml(log.xml, log.path)
    index = {uid: i for i, uid in enumerate(uids)}
    status = [p.IDLE] * len(uids)
    created = time.strftime("%Y-%m-%dT%H:%M:%S%z", time.localtime(log.start_us / 1e6))
    header = {
        "kind": "header",
        "version": LOG_VERSION,
        "format": "btlog",
        "created": created,
        "tree_file": None,
        "nodes": count(root),
        "tree": to_dict(root),
        "map": None,
    }
    data = TickLogData(path=log.path, header=header)
    unknown = 0
    for step, (t_us, group) in enumerate(groupby(log.transitions, key=lambda t: t.t_us), start=1):
        shown = list(status)  # a node reset to IDLE within this step is drawn with the status it reached
        for t in group:
            if t.uid not in index:
                unknown += 1
                continue
            i = index[t.uid]
            status[i] = t.status
            if t.status != p.IDLE:
                shown[i] = t.status
            elif shown[i] == p.RUNNING:  # halted
                shown[i] = p.IDLE
            # else: finished, and reset as its parent finished in this step: drawn with its result
        rows = [[_STATUS_NAMES.get(s, "INVALID"), "skipped" if s == p.SKIPPED else "", None] for s in shown]
        data.ticks.append(
            {"tick": step, "t": round(t_us / 1e6, 6), "status": rows[0][0], "state": "", "reason": "", "nodes": rows}
        )
    if unknown:
        raise MissionError(f"{log.path}: {unknown} transition(s) name a UID that is not in the log's tree")
    if log.torn:
        data.torn_line = len(log.transitions) + 1
    return data
