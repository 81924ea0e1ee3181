"""Groot2 logs (`mission run --btlog FILE`): BT.CPP's FileLogger2 format written from a real run, read back
by `mission viz --log`, and compared with what BehaviorTree.CPP itself writes for the same tree.

The BT.CPP facts below were recorded on a development machine from BehaviorTree.CPP 4.10.0 (built from
its source; nothing of it is in this repository): its Groot2Publisher's FULLTREE reply and the .btlogs its
FileLogger2 wrote for BTCPP_TREE after one ``tickOnce()`` and for the two scripted trees, tick by tick.
"""

from __future__ import annotations

import logging
import struct
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import py_trees
import pytest

from mission.app.runner import TreeRunner
from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import port
from mission.cli import main
from mission.core.config import MissionConfig
from mission.core.errors import MissionError
from mission.groot.btlog import MAGIC, BtLogWriter, is_btlog, read_btlog
from mission.groot.uids import uid_tree
from mission.viz.btlog_view import read_btlog_ticks
from tests.helpers.viz_world import SUBTREE_WATCH, MarkerWorld

# Built-ins only, so BT.CPP runs it with no node of ours: a subtree used twice, one of them named.
BTCPP_TREE = """<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <Sequence name="top">
      <SubTree ID="Leg" name="first"/>
      <Fallback>
        <AlwaysFailure/>
        <SubTree ID="Leg"/>
      </Fallback>
      <Inverter><AlwaysFailure name="nope"/></Inverter>
    </Sequence>
  </BehaviorTree>
  <BehaviorTree ID="Leg">
    <Sequence>
      <AlwaysSuccess name="step"/>
      <ForceSuccess><AlwaysFailure/></ForceSuccess>
    </Sequence>
  </BehaviorTree>
</root>
"""
# BT.CPP 4.10 FULLTREE for BTCPP_TREE: (tree ID, _fullpath) of each instance, then (tag, _uid) in document order
BTCPP_INSTANCES = [("Main", ""), ("Leg", "first"), ("Leg", "Leg::9")]
BTCPP_UIDS = [
    [("Sequence", 1), ("SubTree", 2), ("Fallback", 7), ("AlwaysFailure", 8), ("SubTree", 9), ("Inverter", 14),
     ("AlwaysFailure", 15)],
    [("Sequence", 3), ("AlwaysSuccess", 4), ("ForceSuccess", 5), ("AlwaysFailure", 6)],
    [("Sequence", 10), ("AlwaysSuccess", 11), ("ForceSuccess", 12), ("AlwaysFailure", 13)],
]  # fmt: skip
BTCPP_SUBTREE_PATHS = {2: "first", 9: "Leg::9"}
# BT.CPP 4.10 FileLogger2 transitions for one tickOnce() of BTCPP_TREE: (µs since start, uid, status)
BTCPP_TRANSITIONS = [
    (3195, 1, 1), (3203, 2, 1), (3203, 3, 1), (3205, 4, 2), (3206, 5, 1), (3207, 6, 3), (3209, 6, 0),
    (3209, 5, 2), (3210, 4, 0), (3211, 5, 0), (3211, 3, 2), (3211, 3, 0), (3211, 2, 2), (3212, 7, 1),
    (3212, 8, 3), (3213, 9, 1), (3213, 10, 1), (3213, 11, 2), (3214, 12, 1), (3214, 13, 3), (3214, 13, 0),
    (3214, 12, 2), (3214, 11, 0), (3215, 12, 0), (3215, 10, 2), (3215, 10, 0), (3215, 9, 2), (3215, 8, 0),
    (3215, 9, 0), (3215, 7, 2), (3216, 14, 1), (3216, 15, 3), (3217, 15, 0), (3217, 14, 2), (3217, 2, 0),
    (3217, 7, 0), (3217, 14, 0), (3217, 1, 2), (3217, 1, 0),
]  # fmt: skip


# Scripted leaves, the same in BT.CPP (C++ nodes written for the recording) and here: <Act script="R,R,S"/>
# returns RUNNING, RUNNING, SUCCESS on its 1st, 2nd, 3rd tick since it started (then the last letter
# again) and starts over when halted; <Flag script="S,F"/> returns the letter of the tree's tick number.
SCRIPTED_REACTIVE = """<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <ReactiveFallback name="root">
      <SubTree ID="FollowTree" name="follow"/>
      <Sequence name="search">
        <Act name="turn" script="R,S"/>
        <Act name="wait" script="R,R,F"/>
      </Sequence>
    </ReactiveFallback>
  </BehaviorTree>
  <BehaviorTree ID="FollowTree">
    <ReactiveSequence name="seen">
      <Flag name="visible" script="S,S,S,F,F,F,F,S,S,F,F,F,F,F"/>
      <Act name="chase" script="R"/>
    </ReactiveSequence>
  </BehaviorTree>
</root>
"""
SCRIPTED_PARALLEL = """<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <Sequence name="root">
      <Parallel success_count="2" failure_count="1">
        <Act name="a" script="R,R,S"/>
        <Act name="b" script="R,S"/>
        <Act name="c" script="R,R,R,R,R"/>
      </Parallel>
      <Fallback>
        <Inverter><Act name="d" script="S"/></Inverter>
        <ForceFailure><Act name="e" script="R,S"/></ForceFailure>
        <ReactiveSequence>
          <Flag name="f" script="S"/>
          <Act name="g" script="R,R,S"/>
        </ReactiveSequence>
      </Fallback>
    </Sequence>
  </BehaviorTree>
</root>
"""
# BT.CPP 4.10 FileLogger2 (uid, status) transitions of the two trees ticked with tickOnce() until they finished
BTCPP_SCRIPTED = {
    "reactive": [
        (1, 1), (2, 1), (3, 1), (4, 2), (5, 1), (4, 0), (4, 2), (4, 0), (4, 2), (4, 0), (4, 3), (4, 0), (5, 0),
        (3, 3), (3, 0), (2, 3), (6, 1), (7, 1), (2, 0), (2, 1), (3, 1), (4, 3), (4, 0), (3, 3), (3, 0), (2, 3),
        (7, 2), (8, 1), (2, 0), (2, 1), (3, 1), (4, 3), (4, 0), (3, 3), (3, 0), (2, 3), (2, 0), (2, 1), (3, 1),
        (4, 3), (4, 0), (3, 3), (3, 0), (2, 3), (8, 3), (7, 0), (8, 0), (6, 3), (2, 0), (6, 0), (1, 3), (1, 0),
    ],
    "parallel": [
        (1, 1), (2, 1), (3, 1), (4, 1), (5, 1), (4, 2), (3, 2), (3, 0), (4, 0), (5, 0), (2, 2), (6, 1), (7, 1),
        (8, 2), (8, 0), (7, 3), (9, 1), (10, 1), (10, 2), (10, 0), (9, 3), (11, 1), (12, 2), (13, 1), (12, 0),
        (12, 2), (12, 0), (12, 2), (13, 2), (12, 0), (13, 0), (11, 2), (7, 0), (9, 0), (11, 0), (6, 2), (2, 0),
        (6, 0), (1, 2), (1, 0),
    ],
}  # fmt: skip
_LETTERS = {
    "R": py_trees.common.Status.RUNNING,
    "S": py_trees.common.Status.SUCCESS,
    "F": py_trees.common.Status.FAILURE,
}


class Act(MissionLeaf):
    """The letter of `script` for this tick since the action started."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        script: str = port("R", "R, S or F per tick since the start, comma-separated")

    NODE_TYPE = "Action"

    def initialise(self) -> None:
        self.count = 0

    def update(self) -> py_trees.common.Status:
        letters = self.params.script.split(",")
        letter = letters[min(self.count, len(letters) - 1)]
        self.count += 1
        self.feedback_message = f"tick {self.count}: {letter}"
        return _LETTERS[letter]


class Flag(MissionLeaf):
    """The letter of `script` for the tree's tick number (the world's clock in 0.1 s steps)."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        script: str = port("S", "S or F per tick of the tree, comma-separated")

    NODE_TYPE = "Condition"

    def update(self) -> py_trees.common.Status:
        letters = self.params.script.split(",")
        letter = letters[min(round(float(self.now()) / 0.1), len(letters) - 1)]
        self.feedback_message = letter
        return _LETTERS[letter]


def _run(tmp_path, tree_text: str, ticks: int, name: str = "run.btlog", scripted: bool = False) -> TreeRunner:
    tree = tmp_path / "tree.xml"
    tree.write_text(tree_text)
    world = MarkerWorld(visible_ticks=3)
    runner = TreeRunner(MissionConfig(), world, str(tree), observers=[BtLogWriter(tmp_path / name)])
    if scripted:
        runner.factory.register(Act)
        runner.factory.register(Flag)
    try:
        runner.setup()
        for _ in range(ticks):
            if runner.step().name in ("SUCCESS", "FAILURE"):
                break
            world.advance(world.dt)
        runner.finish(None)
    finally:
        runner.close()
    return runner


def test_uids_and_instance_paths_are_the_ones_bt_cpp_gives(tmp_path):
    (tmp_path / "tree.xml").write_text(BTCPP_TREE)
    numbered = uid_tree(tmp_path / "tree.xml")
    root = ET.fromstring(numbered.xml())
    trees = root.findall("BehaviorTree")
    assert [(t.get("ID"), t.get("_fullpath")) for t in trees] == BTCPP_INSTANCES
    assert [[(el.tag, int(el.get("_uid"))) for el in t.iter() if el.tag != "BehaviorTree"] for t in trees] == BTCPP_UIDS
    assert {int(el.get("_uid")): el.get("_fullpath") for el in root.iter("SubTree")} == BTCPP_SUBTREE_PATHS


def test_a_ticks_transitions_are_the_ones_bt_cpps_file_logger_writes(tmp_path):
    """The same tree ticked once: the same transitions in the same order."""
    _run(tmp_path, BTCPP_TREE, ticks=1)
    ours = [(t.uid, t.status) for t in read_btlog(tmp_path / "run.btlog").transitions]
    assert ours == [(uid, status) for _t, uid, status in BTCPP_TRANSITIONS]


@pytest.mark.parametrize(("tree", "name"), [(SCRIPTED_REACTIVE, "reactive"), (SCRIPTED_PARALLEL, "parallel")])
def test_running_halted_and_reactive_nodes_log_as_bt_cpp_logs_them(tmp_path, tree, name):
    """Leaves that run for several ticks, conditions re-checked by reactive controls, a subtree that fails
    and is re-entered, a Parallel, decorators: tick after tick, the transitions BT.CPP writes."""
    _run(tmp_path, tree, ticks=14, scripted=True)
    ours = [(t.uid, t.status) for t in read_btlog(tmp_path / "run.btlog").transitions]
    assert ours == BTCPP_SCRIPTED[name]


def test_a_real_run_writes_a_file_logger2_log_that_reads_back(tmp_path):
    before = time.time()
    _run(tmp_path, SUBTREE_WATCH, ticks=20)
    path = tmp_path / "run.btlog"
    data = path.read_bytes()
    assert data.startswith(b"BTCPP4-FileLogger2\x01") and is_btlog(path)
    (size,) = struct.unpack_from("<i", data, 19)
    xml = data[23 : 23 + size].decode()
    (start_us,) = struct.unpack_from("<q", data, 23 + size)
    assert (len(data) - 23 - size - 8) % 9 == 0  # 9 bytes per transition to the end
    assert before - 1 < start_us / 1e6 < time.time() + 1
    log = read_btlog(path)
    assert log.xml == xml == uid_tree(tmp_path / "tree.xml").xml(TreeRunner(MissionConfig(), MarkerWorld()).factory)
    stamps = [t.t_us for t in log.transitions]
    assert stamps == sorted(stamps) and stamps[0] == 0
    assert {s % 100_000 for s in stamps} == {0}  # one stamp per tick: the run's clock (0.1 s steps), in µs
    statuses = {uid: [t.status for t in log.transitions if t.uid == uid] for uid in range(1, 7)}
    assert statuses[5][:1] == [1]  # FollowTarget RUNNING first …
    assert statuses[6][-2:] == [3, 0]  # … the sweep failed at the end, and was reset as the root finished
    assert statuses[1][-2:] == [3, 0]  # the root failed; BT.CPP leaves a finished root IDLE
    assert not log.torn


def test_mission_viz_draws_the_log_at_any_step(tmp_path, capsys):
    _run(tmp_path, SUBTREE_WATCH, ticks=20)
    assert main(["viz", "--log", str(tmp_path / "run.btlog"), "--tick", "1"]) == 0
    first = capsys.readouterr().out
    assert "❏ follow" in first and "● FollowTarget" in first  # the SubTree node, by its name; running
    assert main(["viz", "--log", str(tmp_path / "run.btlog")]) == 0
    last = capsys.readouterr().out
    assert "✘ ? coordinator" in last and "✘ SearchSweep" in last
    assert main(["viz", "--log", str(tmp_path / "run.btlog"), "--format", "html", "-o", str(tmp_path / "r.html")]) == 0
    assert "SearchSweep" in (tmp_path / "r.html").read_text()


def test_a_log_bt_cpp_wrote_is_read_too(tmp_path, capsys):
    """FileLogger2's layout with BT.CPP's own XML style (4-space indent, every node named, SubTrees unnamed)."""
    xml = """<root BTCPP_format="4">
    <BehaviorTree ID="Main" _fullpath="">
        <Sequence name="top" _uid="1">
            <SubTree ID="Leg" _fullpath="first" _uid="2"/>
            <Fallback name="Fallback" _uid="7">
                <AlwaysFailure name="AlwaysFailure" _uid="8"/>
                <SubTree ID="Leg" _fullpath="Leg::9" _uid="9"/>
            </Fallback>
            <Inverter name="Inverter" _uid="14">
                <AlwaysFailure name="nope" _uid="15"/>
            </Inverter>
        </Sequence>
    </BehaviorTree>
""" + "".join(f"""    <BehaviorTree ID="Leg" _fullpath="{path}">
        <Sequence name="Sequence" _uid="{u}">
            <AlwaysSuccess name="step" _uid="{u + 1}"/>
            <ForceSuccess name="ForceSuccess" _uid="{u + 2}">
                <AlwaysFailure name="AlwaysFailure" _uid="{u + 3}"/>
            </ForceSuccess>
        </Sequence>
    </BehaviorTree>
""" for path, u in (("first", 3), ("Leg::9", 10))) + "</root>"  # fmt: skip
    body = b"".join(struct.pack("<Q", t)[:6] + struct.pack("<HB", uid, s) for t, uid, s in BTCPP_TRANSITIONS)
    path = tmp_path / "bt.btlog"
    encoded = xml.encode()
    start = struct.pack("<q", 1_796_154_268_729_122)
    path.write_bytes(MAGIC + b"\x01" + struct.pack("<i", len(encoded)) + encoded + start + body)
    log = read_btlog_ticks(path)
    assert len(log.ticks) == len({t for t, _u, _s in BTCPP_TRANSITIONS})  # one step per distinct timestamp
    assert log.tree().name == "top" and [c.name for c in log.tree().children] == ["first", "Fallback", "Inverter"]
    assert main(["viz", "--log", str(path), "--tick", "10"]) == 0  # at 3213 µs: the second Leg starts
    out = capsys.readouterr().out
    assert "✔ ❏ first" in out and "● ❏ Leg" in out and "✘ AlwaysFailure" in out


def test_bad_logs_are_one_clear_error_and_a_torn_last_record_is_skipped(tmp_path, caplog):
    _run(tmp_path, SUBTREE_WATCH, ticks=20)
    good = (tmp_path / "run.btlog").read_bytes()
    torn = tmp_path / "torn.btlog"
    torn.write_bytes(good[:-4])
    with caplog.at_level(logging.WARNING):
        log = read_btlog(torn)
    assert log.torn and len(log.transitions) == len(read_btlog(tmp_path / "run.btlog").transitions) - 1
    assert "cut off mid-write" in caplog.text
    jsonl = tmp_path / "run.jsonl"
    jsonl.write_text('{"kind": "header"}\n')
    with pytest.raises(MissionError, match=r"run.jsonl: not a Groot2 log; expected a file starting with BTCPP4"):
        read_btlog(jsonl)
    short = tmp_path / "short.btlog"
    short.write_bytes(good[:60])
    with pytest.raises(MissionError, match=r"short.btlog: the log ends inside its tree XML"):
        read_btlog(short)
    with pytest.raises(MissionError, match=r"nothing.btlog: no such log"):
        read_btlog(tmp_path / "nothing.btlog")


def test_btlog_option_wants_the_suffix_groot2_opens(tmp_path, capsys):
    code = main(["run", "--scenario", "explore_dock", "--quiet", "--btlog", str(tmp_path / "run.log")])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--btlog" in err[0] and "expected a file name ending in .btlog" in err[0]
