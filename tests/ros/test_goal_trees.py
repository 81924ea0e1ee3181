"""The node's tree outputs in a run whose trees come and go (issue 32: an action server's goals).

A real run in the simulation (tests/helpers/goal_runs.py) starts with no tree; the test starts a goal tree,
stops it, starts another and preempts it, stepping the real loop between. The publishers (mission/ros/outputs.py)
sit on an rclpy node in this process; a second node (RosClient) receives what they send over the shared-memory
DDS profile, as a Nav2 panel or a late `ros2 topic echo` would: /behavior_tree, /behavior_tree_log,
/mission/tree, /mission/status.
"""

from __future__ import annotations

import json
import time

import pytest
from std_msgs.msg import String

from mission.ros.messages import RclpyMessages
from mission.ros.outputs import BehaviorTreeLogPublisher, StatusPublisher, TreePublisher
from mission.ros.ros_adapter import LATCHED, RELIABLE
from mission.ros.tf_support import load_nav2
from tests.helpers.goal_runs import DOCK_ROOT, DOCK_TREE, EXPLORE_ROOT, EXPLORE_TREE, GOAL, STAGING, goal_runner, steps
from tests.helpers.ros_env import RosClient, build_ros, clean_shm, wait_for

pytestmark = pytest.mark.ros

XML, LOG, TREE, STATUS = "/behavior_tree", "/behavior_tree_log", "/mission/tree", "/mission/status"


class Outputs:
    """The node side (the three tree publishers on one node) and a client subscribed to what they send."""

    def __init__(self) -> None:
        self.nav2 = load_nav2()
        assert self.nav2.ok, self.nav2.detail
        self.node = RosClient("mission_tree_outputs")
        msgs = RclpyMessages()
        n = self.node.node
        self.observers = [
            BehaviorTreeLogPublisher(n, msgs, self.nav2, time.time),
            TreePublisher(n, msgs),
            StatusPublisher(n, msgs),
        ]
        self.client = RosClient("tree_watcher")
        self.client.subscribe(self.nav2.get("msg", "BehaviorTreeLog"), LOG, RELIABLE)
        for topic in (XML, TREE, STATUS):
            self.client.subscribe(String, topic, LATCHED)
        for topic in (XML, LOG, TREE, STATUS):
            wait_for(lambda t=topic: self.node.node.count_subscribers(t) > 0, 10, f"the client on {topic}")

    def received(self, topic: str, count: int) -> list:
        """The messages on `topic` once there are at least `count`."""
        wait_for(lambda: len(self.client.messages(topic)) >= count, 5, f"{count} message(s) on {topic}")
        return self.client.messages(topic)

    def statuses(self, count: int) -> list[dict]:
        return [json.loads(m.data) for m in self.received(STATUS, count)]

    def trees(self, count: int) -> list[dict | None]:
        return [json.loads(m.data)["tree"] for m in self.received(TREE, count)]

    def close(self) -> None:
        self.client.close()
        self.node.close()


def events(log) -> list[tuple[str, str, str]]:
    return [(e.node_name, e.previous_status, e.current_status) for e in log.event_log]


@pytest.fixture()
def outputs():
    build_ros()  # nav2_msgs (BehaviorTreeLog) from ros/: cached, about a second when nothing changed
    out = Outputs()
    try:
        yield out
    finally:
        out.close()
        clean_shm()


def test_the_tree_topics_follow_goal_trees_from_none_to_each_and_back(outputs):
    out = outputs
    runner = goal_runner(*out.observers)
    try:
        # no goal: nothing ticks and nothing breaks; no tree XML, no log
        steps(runner, 3)
        assert out.statuses(1)[-1] | {"tick": 0, "clock": 0} == {
            "state": "",
            "status": "INVALID",
            "reason": "",
            "fault": "",
            "tree": None,
            "tick": 0,
            "clock": 0,
        }
        assert out.trees(1) == [None]
        assert out.client.messages(XML) == [] and out.client.messages(LOG) == []

        # a goal: its XML (latched), its snapshot at once, its first log from IDLE
        runner.start_tree(DOCK_TREE, GOAL)
        assert 'main_tree_to_execute="DockRobot"' in out.received(XML, 1)[0].data
        assert out.trees(2)[-1]["name"] == DOCK_ROOT  # before any tick of it: not held back by the 2 Hz limit
        steps(runner, 3)
        first = events(out.received(LOG, 1)[0])
        assert all(previous == "IDLE" for _name, previous, _now in first)
        assert (DOCK_ROOT, "IDLE", "RUNNING") in first and (STAGING, "IDLE", "RUNNING") in first
        assert ("Script", "IDLE", "SUCCESS") in first
        assert out.statuses(2)[-1]["tree"] == DOCK_TREE and out.statuses(2)[-1]["status"] == "RUNNING"

        # the goal ends: the halt is logged, the snapshot has no tree, the status names none
        logs = len(out.client.messages(LOG))
        runner.stop_tree()
        halt = events(out.received(LOG, logs + 1)[-1])
        assert (STAGING, "RUNNING", "IDLE") in halt and (DOCK_ROOT, "RUNNING", "IDLE") in halt
        assert out.trees(3)[-1] is None
        steps(runner, 2)
        assert out.statuses(3)[-1]["tree"] is None
        assert len(out.client.messages(LOG)) == logs + 1  # no tree, no log

        # the next goal, another tree: its XML, its snapshot, its first log from IDLE (nothing of the last tree's)
        runner.start_tree(EXPLORE_TREE)
        assert 'main_tree_to_execute="ExploreDock"' in out.received(XML, 2)[-1].data
        assert out.trees(4)[-1]["name"] == EXPLORE_ROOT
        steps(runner, 2)
        first = events(out.received(LOG, logs + 2)[logs + 1])
        assert all(previous == "IDLE" for _name, previous, _now in first) and (EXPLORE_ROOT, "IDLE", "RUNNING") in first
        assert out.statuses(4)[-1]["tree"] == EXPLORE_TREE

        # preempted by a goal: the old tree's halt, then the new tree's first log from IDLE again
        logs = len(out.client.messages(LOG))
        runner.start_tree(DOCK_TREE, GOAL)
        steps(runner, 1)
        halt, first = (events(m) for m in out.received(LOG, logs + 2)[logs:])
        assert (EXPLORE_ROOT, "RUNNING", "IDLE") in halt
        assert all(previous == "IDLE" for _name, previous, _now in first)
        assert ("Script", "IDLE", "SUCCESS") in first  # py_trees keeps a halted Script's SUCCESS: not "no change"
        assert out.trees(5)[-1]["name"] == DOCK_ROOT

        # a client that joins now gets the tree that runs (latched), not the first one
        late = RosClient("late_watcher")
        try:
            late.subscribe(String, XML, LATCHED)
            wait_for(lambda: late.messages(XML), 5, "the latched /behavior_tree")
            assert [m.data for m in late.messages(XML)] == [out.client.messages(XML)[-1].data]
            assert 'main_tree_to_execute="DockRobot"' in late.messages(XML)[0].data
        finally:
            late.close()
    finally:
        runner.close()
