"""Groot2's live monitor and its .btlog of a run whose trees come and go (issue 32: an action server's goals).

A real run in the simulation (tests/helpers/goal_runs.py) starts with no tree; the test starts a goal tree,
stops it, starts another and preempts that one, stepping the real loop between, while the Groot2 side of the
protocol (tests/helpers/groot2_client.py, real ZeroMQ on 127.0.0.1) asks what Groot2 asks. Groot2 tells a new
tree by the tree UUID of the replies and then asks for FULLTREE again. A .btlog holds one tree: the first.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET

import pytest

from mission.groot.btlog import BtLogWriter, read_btlog
from mission.groot.publisher import Groot2Publisher
from tests.helpers.goal_runs import DOCK_ROOT, DOCK_TREE, EXPLORE_ROOT, EXPLORE_TREE, GOAL, STAGING, goal_runner, steps
from tests.helpers.groot2_client import Groot2Client, ProtocolError

IDLE, RUNNING = 0, 1
IDLE_FROM = 10  # STATUS shows a node back at IDLE as 10 + the status it had


def served(client: Groot2Client) -> tuple[bytes, str, dict[str, int], set[int]]:
    """(tree UUID, main tree ID, uid by node name, every uid) of the tree Groot2 is sent now."""
    reply = client.request("T")
    root = ET.fromstring(reply.parts[0])
    main = root.find("BehaviorTree")
    uids = {int(el.get("_uid")) for el in root.iter() if el.get("_uid")}
    by_name = {el.get("name"): int(el.get("_uid")) for el in root.iter() if el.get("name") and el.get("_uid")}
    return reply.tree_uuid, main.get("ID"), by_name, uids


def test_groot2_is_served_each_goal_tree_under_a_new_uuid_and_a_stopped_one_halted(capsys):
    publisher = Groot2Publisher(0)
    runner = goal_runner(publisher)
    client = Groot2Client(publisher.port)
    try:
        assert "waiting for a goal" in capsys.readouterr().err  # the banner: listening, no tree yet
        steps(runner, 2)
        with pytest.raises(ProtocolError, match="no tree yet"):
            client.full_tree()
        assert client.statuses() == {}

        runner.start_tree(DOCK_TREE, GOAL)
        assert capsys.readouterr().err == ""  # quietly: one banner per monitor
        client.start_recording()
        steps(runner, 5)
        dock_uuid, main, dock_names, dock_uids = served(client)
        assert main == DOCK_ROOT and client.request("S").tree_uuid == dock_uuid
        staging = dock_names[STAGING]
        following = client.statuses()
        assert set(following) == dock_uids and following[staging] == RUNNING and following[1] == RUNNING
        assert set(client.blackboards(DOCK_ROOT, "no-such-tree")) == {DOCK_ROOT}
        assert (staging, RUNNING) in [(uid, s) for _t, uid, s in client.transitions()]

        # the goal ends: the same tree stays served, halted as BT.CPP halts one
        runner.stop_tree()
        steps(runner, 2)
        assert served(client)[:2] == (dock_uuid, DOCK_ROOT)
        halted = client.statuses()
        assert halted[staging] == halted[1] == IDLE_FROM + RUNNING
        halt = [(uid, s) for _t, uid, s in client.transitions()]
        assert (staging, IDLE) in halt and (1, IDLE) in halt

        # the next goal, another tree: a new UUID, so Groot2 asks again and gets it
        runner.start_tree(EXPLORE_TREE)
        steps(runner, 2)
        explore_uuid, main, _names, explore_uids = served(client)
        assert main == EXPLORE_ROOT and explore_uuid != dock_uuid
        exploring = client.statuses()
        assert set(exploring) == explore_uids and exploring[1] == RUNNING
        assert client.request("S").tree_uuid == explore_uuid
        assert set(client.blackboards(EXPLORE_ROOT, DOCK_ROOT)) == {EXPLORE_ROOT}

        # preempted by a goal before its transitions were fetched: they were the old tree's UIDs, dropped
        steps(runner, 1)
        runner.start_tree(DOCK_TREE, GOAL)
        assert client.transitions() == []
        again_uuid, main, _names, uids = served(client)
        assert main == DOCK_ROOT and uids == dock_uids and again_uuid not in (dock_uuid, explore_uuid)
        assert set(client.statuses().values()) == {IDLE}  # not ticked yet
        steps(runner, 1)
        assert client.statuses()[staging] == RUNNING
        assert capsys.readouterr().err == ""
    finally:
        client.close()
        runner.close()


def test_a_btlog_holds_the_first_goal_tree_to_its_halt(tmp_path, caplog):
    writer = BtLogWriter(tmp_path / "run.btlog")
    runner = goal_runner(writer)
    try:
        steps(runner, 2)
        runner.start_tree(DOCK_TREE, GOAL)
        steps(runner, 3)
        with caplog.at_level(logging.WARNING):
            runner.stop_tree()
            runner.start_tree(EXPLORE_TREE)
            steps(runner, 3)
        assert caplog.text.count("a .btlog holds one tree") == 1
        runner.finish(None)
    finally:
        runner.close()
    log = read_btlog(tmp_path / "run.btlog")
    root = ET.fromstring(log.xml)
    assert root.find("BehaviorTree").get("ID") == DOCK_ROOT
    staging = int(root.find(f".//*[@name='{STAGING}']").get("_uid"))
    changes = [(t.uid, t.status) for t in log.transitions]
    assert changes.index((staging, RUNNING)) < changes.index((staging, IDLE))  # ran, then halted
    assert changes[-1] == (1, IDLE)  # the halt reaches the root last; nothing of the next tree follows
    assert not log.torn
