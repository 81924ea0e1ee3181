"""`-p serve_port:=N`: the ROS node serves the same live web view as `mission run --serve`, on loopback only."""

from __future__ import annotations

import json
import socket
import urllib.request

import pytest

from tests.helpers.ros_env import ROOT, clean_shm, inet_sockets, installed_env, node_process, wait_for

pytestmark = pytest.mark.ros

MISSION = [str(ROOT / ".venv" / "bin" / "mission")]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _get(url: str) -> bytes | None:
    try:
        with urllib.request.urlopen(url, timeout=2) as r:
            return r.read()
    except OSError:
        return None


def _header_with_tree(url: str) -> dict | None:
    body = _get(url)
    header = json.loads(body) if body else None
    return header if header and header.get("tree") else None


def _names(node: dict) -> list[str]:
    return [node["name"], *(n for c in node.get("children", []) for n in _names(c))]


def test_the_node_serves_the_live_tree_on_loopback_and_its_ticks_advance(tmp_path):
    port = _free_port()
    base = f"http://127.0.0.1:{port}"
    cmd = [*MISSION, "tree", "--ros-args", "-p", "tree:=follow.xml", "-p", f"serve_port:={port}", "-p", "tick_hz:=20"]
    with node_process(cmd, installed_env(), tmp_path / "node.log") as node:
        try:
            # the server answers as soon as it listens; the tree arrives with the node's first tick
            header = wait_for(lambda: _header_with_tree(f"{base}/api/header"), 30, "the live view to show the tree")
            names = _names(header["tree"])
            assert "FollowTarget" in json.dumps(header["tree"]) and len(names) == header["nodes"] > 5
            page = _get(f"{base}/").decode()
            assert "<html" in page.lower()

            def last_tick() -> int:
                records = json.loads(_get(f"{base}/api/history") or b"[]")
                return max((r["tick"] for r in records), default=-1)

            first = wait_for(lambda: last_tick() + 1, 10, "ticks in the live history") - 1
            wait_for(lambda: last_tick() >= first + 10, 10, "ten more ticks")
            # TIME on the page is the run's own time (ROS time is seconds since 1970: not what anyone reads)
            records = json.loads(_get(f"{base}/api/history") or b"[]")
            assert 0.0 <= records[-1]["t"] < 120.0, records[-1]["t"]
            bound = [addr for proto, addr in inet_sockets(node.pid) if proto.startswith("tcp")]
            assert bound and all(addr.startswith("127.0.0.1:") for addr in bound), bound
        except BaseException:
            print(node.log())
            raise
    clean_shm()
