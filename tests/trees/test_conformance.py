"""The loader's trees tick as BehaviorTree.CPP's do: golden traces recorded from the real BT.CPP, replayed.

tests/trees/golden/btcpp/conformance.json holds trees of scripted leaves and what BT.CPP 4.10 did with them tick by
tick (how it was recorded is in the file: Tree::tickOnce(), every node's executeTick result, every leaf tick
and halt in order, every node's status and every blackboard after each tick). Here the same XML is loaded by
our loader with leaves that follow the same scripts, and each tick must produce the same events in the same
order, the same statuses and the same blackboard entries. A case BT.CPP refused to load must be refused too.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import py_trees
import pytest
from py_trees.common import Status

from mission.behaviours.ports import PortsDeclared, port
from mission.core.errors import TreeError
from mission.trees import scopes
from mission.trees.execution import TreeRuntime, result_name
from mission.trees.factory import BehaviourFactory
from mission.trees.loader import describe_tree, load_tree

GOLDEN = json.loads((Path(__file__).parent / "golden" / "btcpp" / "conformance.json").read_text())
CASES = {case["name"]: case for case in GOLDEN["cases"]}


class _Scripted(py_trees.behaviour.Behaviour, PortsDeclared):
    """The recording's scripted leaf: one status per tick from `script`, events as the recording names them."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        script: str = port("S", "statuses per tick: S, F, R (the last repeats)")
        value: str = port("", "read and recorded at every tick, when the tree sets it")
        out: int = port(doc="the number of ticks so far", direction="output")

    CODES: ClassVar[dict[str, Status]] = {"S": Status.SUCCESS, "F": Status.FAILURE, "R": Status.RUNNING}

    def __init__(self, name: str, **ports: Any) -> None:
        super().__init__(name)
        self.params = self.bind_params(ports)
        self.count = 0

    def update(self) -> Status:
        script = self.params.script
        status = self.CODES[script[min(self.count, len(script) - 1)]]
        self.count += 1
        event: list[Any] = ["tick", self.bt.uid, status.name]
        if "value" in self.bt.ports.written:
            event.append(self.params.value)
        self.set_output("out", self.count)
        self.bt.tree.emit(*event)
        self.feedback_message = f"tick {self.count}: {status.name}"
        return status


class Act(_Scripted):
    """An action: halting it is recorded."""

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID:
            self.bt.tree.emit("halt", self.bt.uid)


class Cond(_Scripted):
    """A condition (never halted: it never runs)."""

    NODE_TYPE = "Condition"


def factory(enums: dict[str, int]) -> BehaviourFactory:
    made = BehaviourFactory()
    made.register(Act)
    made.register(Cond)
    for name, value in enums.items():
        made.register_enum(name, value)
    return made


def statuses(root: py_trees.behaviour.Behaviour) -> dict[str, str]:
    """Every XML node's BT.CPP status by UID (a flattened SubTree is a layer of its tree's root)."""
    out = {}
    for node in root.iterate():
        for layer in node.bt.layers:
            out[str(layer.uid)] = result_name(layer.status)
    return out


def tree_entries() -> dict[str, Any]:
    storage = py_trees.blackboard.Blackboard.storage
    return {path: value for path, value in storage.items() if path.startswith(scopes.NAMESPACE + "/")}


def expected_entries(blackboards: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """BT.CPP's blackboards (instance path → own entries) as our entries; empty (declared) entries are absent."""
    out = {}
    for instance, entries in blackboards.items():
        for key, value in entries.items():
            if value is not None:
                path = f"{scopes.NAMESPACE}/{key}" if instance == "" else f"{scopes.NAMESPACE}/{instance}/{key}"
                out[path] = value
    return out


def same_value(ours: Any, theirs: Any) -> bool:
    if isinstance(theirs, float) or isinstance(ours, float):
        return isinstance(ours, (int, float)) and math.isclose(float(ours), float(theirs), abs_tol=1e-9)
    return bool(ours == theirs)


def load(case: dict[str, Any], tmp_path: Path, runtime: TreeRuntime | None = None) -> py_trees.behaviour.Behaviour:
    path = tmp_path / f"{case['name']}.xml"
    path.write_text(case["xml"])
    return load_tree(path, factory(case.get("enums", {})), runtime)


def test_the_traces_come_from_a_named_bt_cpp_release_and_cover_the_node_library():
    assert GOLDEN["source"]["version"].startswith("4.") and len(GOLDEN["source"]["commit"]) == 40
    assert len(CASES) >= 25
    used = " ".join(case["xml"] for case in CASES.values())
    for node in (
        "Parallel",
        "ParallelAll",
        "ReactiveSequence",
        "ReactiveFallback",
        "SequenceWithMemory",
        "IfThenElse",
        "WhileDoElse",
        "TryCatch",
        "Switch3",
        "RetryUntilSuccessful",
        "Repeat",
        "KeepRunningUntilFailure",
        "RunOnce",
        "Timeout",
        "Precondition",
        "Script",
        "ScriptCondition",
        "SetBlackboard",
        "UnsetBlackboard",
        "LoopInt",
        "LoopString",
        "WasEntryUpdated",
        "SkipUnlessUpdated",
        "_skipIf",
        "_while",
        "_onHalted",
        "_autoremap",
        "{@",
    ):
        assert node in used, f"no golden trace uses {node}"


@pytest.mark.parametrize("name", [n for n, c in CASES.items() if "load_error" not in c])
def test_our_nodes_are_numbered_as_bt_cpp_numbers_them(name, tmp_path):
    case = CASES[name]
    path = tmp_path / "t.xml"
    path.write_text(case["xml"])
    ours = [
        [d.uid, d.tag, d.name]
        for d in describe_tree(path, factory(case.get("enums", {}))).walk()
        if d.tag != "BehaviorTree"
    ]
    assert ours == [[uid, registration, instance] for uid, registration, instance, _path in case["nodes"]]


@pytest.mark.parametrize("name", list(CASES))
def test_a_tree_ticks_as_bt_cpp_ticked_it(name, tmp_path):
    case = CASES[name]
    if "load_error" in case:
        with pytest.raises(TreeError):
            load(case, tmp_path)
        return
    events: list[tuple[Any, ...]] = []
    root = load(case, tmp_path, TreeRuntime(observer=events.append))
    tree = py_trees.trees.BehaviourTree(root)
    for number, expected in enumerate(case["trace"], start=1):
        events.clear()
        tree.tick()
        where = f"{name}, tick {number}"
        assert [list(e) for e in events] == expected["events"], where
        assert result_name(root.bt.result) == expected["result"], where
        assert statuses(root) == expected["status"], where
        ours, theirs = tree_entries(), expected_entries(expected["blackboard"])
        assert set(ours) == set(theirs), where
        for path, value in theirs.items():
            assert same_value(ours[path], value), f"{where}: {path} is {ours[path]!r}, BT.CPP has {value!r}"
