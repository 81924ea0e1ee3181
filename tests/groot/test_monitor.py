"""Groot2 live monitoring (`mission run --groot`): a real run watched through the Groot2 side of the protocol.

The client (tests/helpers/groot2_client.py) packs and checks every header itself over real ZeroMQ sockets on
127.0.0.1; the run is the real runner on a real tree with real ArUco perception (tests/helpers/viz_world.py):
FOLLOW while the marker is seen, then SEARCH, then the tree fails when the short sweep times out.
"""

from __future__ import annotations

import struct
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

import pytest
import zmq

from mission.app.runner import TreeRunner
from mission.core.config import MissionConfig
from mission.core.errors import MissionError
from mission.groot.publisher import Groot2Publisher
from tests.helpers.groot2_client import Groot2Client, ProtocolError
from tests.helpers.viz_world import SUBTREE_WATCH, MarkerWorld, step

# BT.CPP's numbering of SUBTREE_WATCH: depth first from 1, the SubTree before the tree it opens
COORDINATOR, SUBTREE, FOLLOW, VISIBLE, FOLLOW_TARGET, SWEEP = range(1, 7)
IDLE, RUNNING, SUCCESS, FAILURE = 0, 1, 2, 3


@pytest.fixture()
def watched(tmp_path):
    """A set-up run of SUBTREE_WATCH with a publisher on a free port, and a client connected to it."""
    tree = tmp_path / "watch.xml"
    tree.write_text(SUBTREE_WATCH)
    publisher = Groot2Publisher(0, quiet=True)
    world = MarkerWorld(visible_ticks=3)
    runner = TreeRunner(MissionConfig(), world, str(tree), observers=[publisher])
    runner.setup()
    client = Groot2Client(publisher.port)
    try:
        yield runner, world, client, publisher
    finally:
        client.close()
        runner.close()


def test_full_tree_is_the_file_with_bt_cpp_uids_and_the_palette(watched):
    _runner, _world, client, _publisher = watched
    root = ET.fromstring(client.full_tree())
    trees = root.findall("BehaviorTree")
    assert [(t.get("ID"), t.get("_fullpath")) for t in trees] == [("Watch", ""), ("FollowWhileSeen", "follow")]
    main = [(el.tag, el.get("name"), el.get("_uid")) for el in trees[0].iter() if el.tag != "BehaviorTree"]
    assert main == [("ReactiveFallback", "coordinator", "1"), ("SubTree", "follow", "2"), ("SearchSweep", None, "6")]
    assert trees[0].find(".//SubTree").get("_fullpath") == "follow"
    inner = [(el.tag, el.get("_uid"), dict(el.attrib)) for el in trees[1].iter() if el.tag != "BehaviorTree"]
    assert [(tag, uid) for tag, uid, _ in inner] == [
        ("ReactiveSequence", "3"),
        ("IsTargetVisible", "4"),
        ("FollowTarget", "5"),
    ]
    assert inner[1][2]["max_misses"] == "0"  # attributes as the file wrote them
    model = root.find("TreeNodesModel/Action[@ID='FollowTarget']")
    assert model is not None
    assert {p.get("name") for p in model.findall("input_port")} >= {"target", "offset_m", "window", "rate_hz"}


def test_status_follows_the_run_tick_by_tick(watched):
    runner, world, client, _publisher = watched
    assert set(client.statuses().values()) == {IDLE}  # nothing ticked yet
    step(runner, world, 3)  # the marker is seen: FOLLOW
    following = client.statuses()
    assert list(following) == [1, 2, 6, 3, 4, 5]  # instance by instance, as BT.CPP lists them
    assert following[FOLLOW_TARGET] == RUNNING
    assert following[VISIBLE] == 10 + SUCCESS  # succeeded, then reset by its ReactiveSequence, as in BT.CPP
    assert following[SUBTREE] == following[FOLLOW] == following[COORDINATOR] == RUNNING
    assert following[SWEEP] == IDLE
    step(runner, world, 2)  # the marker is gone: the subtree fails, SEARCH sweeps
    searching = client.statuses()
    assert searching[SWEEP] == RUNNING
    assert searching[SUBTREE] == 10 + FAILURE  # failed, then reset by the ReactiveFallback ticking the sweep
    assert searching[FOLLOW] == 10 + FAILURE  # reset when its SubTree finished: IDLE after FAILURE
    assert searching[FOLLOW_TARGET] == 10 + RUNNING  # halted while running
    step(runner, world, 3)  # the sweep times out: the tree fails
    assert client.statuses()[COORDINATOR] == 10 + FAILURE  # finished, so reset: IDLE after FAILURE


def test_blackboard_reply_is_msgpack_of_each_requested_instance(watched):
    runner, world, client, _publisher = watched
    step(runner, world, 2)
    dump = client.blackboards("Watch", "follow", "no-such-tree")
    assert set(dump) == {"Watch", "follow"}
    main = dump["Watch"]
    assert main["/mission/state"] == "FOLLOW"
    track = main["/target/tracks"]["target"]
    assert track["__type"] == "TargetTrack" and track["visible"] is True
    assert len(track["pose_map"]) == 4  # a 4×4 matrix is small enough to send as numbers
    frame = main["/perception/frame"]
    assert frame["__type"] == "Frame" and frame["image"] == "ndarray 240×320×3 uint8"  # summarised, not sent


def test_recording_returns_the_transitions_since_it_started(watched):
    runner, world, client, _publisher = watched
    started = client.start_recording()
    assert abs(started / 1e6 - time.time()) < 5  # wall-clock µs since the epoch
    step(runner, world, 1)
    first = client.transitions()
    assert [(uid, status) for _t, uid, status in first][:3] == [
        (COORDINATOR, RUNNING),
        (SUBTREE, RUNNING),
        (FOLLOW, RUNNING),
    ]
    assert client.transitions() == []  # each transition is handed over once


def test_every_reply_echoes_the_request_and_bad_requests_get_error_replies(watched):
    _runner, _world, client, publisher = watched
    reply = client.request("S")
    assert reply.tree_uuid == client.request("T").tree_uuid == publisher.tree_uuid  # one UUID per run
    assert reply.tree_uuid[6] >> 4 == 4 and reply.tree_uuid[8] >> 6 == 2  # an RFC 4122 version-4 UUID
    assert client.raw([b"\x02S\x00"]) == [b"error", b"wrong request header"]
    assert client.raw([struct.pack("<BBI", 2, ord("B"), 1)]) == [b"error", b"must be 2 parts message"]
    assert client.raw([struct.pack("<BBI", 2, ord("?"), 1)]) == [b"error", b"Request not recognized"]
    assert client.request("D").parts == [b"[]"]  # no hooks
    assert client.request("A").parts == []  # "remove all hooks" before Groot2 disconnects: acknowledged
    with pytest.raises(ProtocolError, match="breakpoints and hooks are not supported"):
        client.request("I", b'{"uid": 2, "position": 0}')
    assert client.statuses()  # and it keeps serving


def test_the_monitor_listens_on_loopback_only_and_a_busy_port_is_one_clear_error():
    first = Groot2Publisher(0, quiet=True)
    try:
        ctx = zmq.Context()
        probe = ctx.socket(zmq.REQ)
        probe.setsockopt(zmq.LINGER, 0)
        assert first.address == f"tcp://127.0.0.1:{first.port}"
        with pytest.raises(MissionError) as err:
            Groot2Publisher(first.port + 1, quiet=True)  # its PORT is the first's PORT + 1: taken
        message = str(err.value)
        assert message.startswith(f"--groot {first.port + 1}: cannot listen on 127.0.0.1:{first.port + 1}")
        assert "\n" not in message and "0 for any free pair" in message
        probe.close()
        ctx.term()
    finally:
        first.close()


def test_mission_run_groot_serves_a_simulated_mission_to_the_protocol_client(tmp_path):
    """The whole command: `mission run --groot 0` prints where it listens; Groot2's requests are answered
    while the simulated mission runs (paced to wall-clock time), and the ports close when it ends."""
    cmd = [
        sys.executable,
        "-m",
        "mission",
        "run",
        "--scenario",
        "explore_dock",
        "--max-duration",
        "3",
        "--quiet",
        "--groot",
        "0",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    try:
        port = None
        deadline = time.monotonic() + 60
        while port is None and time.monotonic() < deadline:
            line = proc.stderr.readline()
            if not line:
                break
            if "Groot2 monitor on 127.0.0.1:" in line:
                port = int(line.split("127.0.0.1:")[1].split()[0])
        assert port is not None, "no 'Groot2 monitor on …' line"
        client = Groot2Client(port)
        try:
            root = ET.fromstring(client.full_tree())
            uids = [int(el.get("_uid")) for el in root.iter() if el.get("_uid")]
            assert sorted(uids) == list(range(1, len(uids) + 1))
            seen_running = False
            for _ in range(40):
                statuses = client.statuses()
                assert sorted(statuses) == sorted(uids)
                if RUNNING in statuses.values():
                    seen_running = True
                    break
                time.sleep(0.05)
            assert seen_running
        finally:
            client.close()
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode in (0, 1), err
    assert "explore_dock seed 0" in out


def test_a_built_tree_that_is_not_its_files_is_named_where_they_part(tmp_path):
    """UIDs are matched to py_trees nodes by the file's shape; a tree built otherwise is refused, with the
    element where it differs (the publisher then warns and shows the tree with every node idle)."""
    from mission.groot.uids import BindError, bind, uid_tree
    from mission.trees.loader import load_tree

    tree, other = tmp_path / "watch.xml", tmp_path / "other.xml"
    tree.write_text(SUBTREE_WATCH)
    other.write_text(SUBTREE_WATCH.replace('<SearchSweep duration_s="0.35"/>', "<AlwaysFailure/>"))
    numbered = uid_tree(tree)
    assert sorted(bind(numbered, load_tree(tree))) == [1, 2, 3, 4, 5, 6]
    with pytest.raises(
        BindError,
        match=r"watch.xml:5: <SearchSweep>: expected a node named 'SearchSweep', "
        r"the tree has 'AlwaysFailure'",
    ):
        bind(numbered, load_tree(other))


def test_a_subtree_built_as_a_node_of_its_own_binds_its_own_uid(tmp_path):
    """Should a tree hold a SubTree as a scope node above the subtree's root (instead of flattening it),
    the SubTree's UID is that node and the root's UID the node below it. (The loader flattens SubTrees,
    and its BT.CPP execution layer ticks only the nodes it built, so this is checked on the binding.)"""
    import py_trees

    from mission.groot.uids import bind, uid_tree
    from mission.trees.loader import load_tree

    tree = tmp_path / "watch.xml"
    tree.write_text(SUBTREE_WATCH)
    root = load_tree(tree)
    flat = root.children[0]  # the subtree's root, named after the SubTree ("follow")
    flat.name = "FOLLOW"
    scope = py_trees.decorators.PassThrough(name="follow", child=flat)
    root.replace_child(flat, scope)
    flat.parent = scope  # replace_child unhooked it from the scope that now holds it
    uids = bind(uid_tree(tree), root)
    assert uids[SUBTREE] is scope and uids[FOLLOW] is flat and uids[VISIBLE] is flat.children[0]
