"""`-p groot_port:=N`: the ROS node serves Groot2's live monitor, as `mission run --groot` does, on loopback only."""

from __future__ import annotations

import socket
import xml.etree.ElementTree as ET

import pytest

from tests.helpers.groot2_client import Groot2Client, ProtocolError
from tests.helpers.ros_env import (
    ROOT,
    FakeCamera,
    FakeOdometry,
    RosClient,
    blank_image,
    clean_shm,
    inet_sockets,
    installed_env,
    node_process,
    wait_for,
)

pytestmark = pytest.mark.ros

MISSION = [str(ROOT / ".venv" / "bin" / "mission")]


def _free_pair() -> int:
    for _ in range(50):
        with socket.socket() as a, socket.socket() as b:
            a.bind(("127.0.0.1", 0))
            port = int(a.getsockname()[1])
            try:
                b.bind(("127.0.0.1", port + 1))
            except OSError:
                continue
            return port
    raise RuntimeError("no free pair of ports")


def test_the_node_answers_groot2_with_its_tree_and_live_statuses(tmp_path):
    port = _free_pair()
    cmd = [*MISSION, "tree", "--ros-args", "-p", "tree:=follow.xml", "-p", f"groot_port:={port}", "-p", "tick_hz:=20"]
    with node_process(cmd, installed_env(), tmp_path / "node.log") as node:
        client = Groot2Client(port, timeout_s=30.0)  # ZeroMQ delivers the request once the node listens
        robot = RosClient()  # a camera that sees nothing and a base standing still: the tree may run
        camera, _odom = FakeCamera(robot), FakeOdometry(robot)
        camera.scene = lambda stamp: (blank_image(stamp), None)
        try:

            def full_tree() -> str | None:
                try:
                    return client.full_tree()
                except ProtocolError:  # listening already, the tree not built yet: "the run has not started"
                    return None

            root = ET.fromstring(wait_for(full_tree, 30, "the tree from the node's Groot2 monitor", poll=0.1))
            tags = [el.tag for el in root.iter() if el.get("_uid")]
            assert "FollowTarget" in tags and root.find("TreeNodesModel/Action[@ID='FollowTarget']") is not None
            # the camera sees no marker: the target is never seen, so the coordinator searches — RUNNING, every tick
            statuses = wait_for(lambda: (s := client.statuses()) and 1 in s.values() and s, 10, "a RUNNING node")
            assert sorted(statuses) == list(range(1, len(tags) + 1))
            bound = [addr for proto, addr in inet_sockets(node.pid) if proto.startswith("tcp")]
            assert {f"127.0.0.1:{port}", f"127.0.0.1:{port + 1}"} <= set(bound), bound
            assert all(addr.startswith("127.0.0.1:") for addr in bound), bound
        except BaseException:
            print(node.log())
            raise
        finally:
            camera.scene = None
            robot.close()
            client.close()
    clean_shm()
