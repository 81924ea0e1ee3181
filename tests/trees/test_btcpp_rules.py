"""Every shipped tree file keeps the load rules of real BehaviorTree.CPP 4.10, checked statically.

Read with the standard library's XML parser, independently of our loader: what BT.CPP's XMLParser
(src/xml_parsing.cpp) refuses when it loads a file whose leaves are registered from the file's own
``<TreeNodesModel>`` (as a C++ host, or Groot2, does with nodes it does not have). Real BT.CPP was run on these
files on a development machine; this test keeps them that way.
"""

from __future__ import annotations

import re
from pathlib import Path
from xml.etree import ElementTree

import pytest

from mission.trees.builtins import BUILTIN_IDS
from mission.trees.factory import shipped_factory
from mission.trees.loader import TREES_DIR

#: BT.CPP 4.10's built-in node IDs (src/bt_factory.cpp)
BTCPP_BUILTINS = {
    "Fallback",
    "AsyncFallback",
    "Sequence",
    "AsyncSequence",
    "SequenceWithMemory",
    "Parallel",
    "ParallelAll",
    "ReactiveSequence",
    "ReactiveFallback",
    "IfThenElse",
    "WhileDoElse",
    "TryCatch",
    "Inverter",
    "RetryUntilSuccessful",
    "KeepRunningUntilFailure",
    "Repeat",
    "Timeout",
    "Delay",
    "RunOnce",
    "ForceSuccess",
    "ForceFailure",
    "AlwaysSuccess",
    "AlwaysFailure",
    "Script",
    "ScriptCondition",
    "SetBlackboard",
    "Sleep",
    "UnsetBlackboard",
    "SubTree",
    "Precondition",
    "Switch2",
    "Switch3",
    "Switch4",
    "Switch5",
    "Switch6",
    "LoopInt",
    "LoopBool",
    "LoopDouble",
    "LoopString",
    "WasEntryUpdated",
    "SkipUnlessUpdated",
    "WaitValueUpdate",
}
#: the ports of the built-ins the shipped files use (BT.CPP's providedPorts)
BUILTIN_PORTS = {
    "RetryUntilSuccessful": {"num_attempts"},
    "Repeat": {"num_cycles"},
    "Timeout": {"msec"},
    "Parallel": {"success_count", "failure_count"},
    "Script": {"code"},
    "ScriptCondition": {"code"},
    "Precondition": {"if", "else"},
    "Delay": {"delay_msec"},
    "Sleep": {"msec"},
    "RunOnce": {"then_skip"},
}
KIND_TAGS = {"Action", "Condition", "Control", "Decorator", "SubTree"}
RESERVED = {
    "name",
    "ID",
    "_autoremap",
    "_failureIf",
    "_successIf",
    "_skipIf",
    "_while",
    "_onSuccess",
    "_onFailure",
    "_onHalted",
    "_post",
    "_description",
    "_uid",
}
FORBIDDEN = re.compile(r"[ \t\n\r<>&\"'/\\:*?|.]")

FILES = sorted(TREES_DIR.glob("*.xml")) + sorted((TREES_DIR / "examples").glob("*.xml"))


def models(root: ElementTree.Element) -> dict[str, tuple[str, dict[str, str]]]:
    """The file's TreeNodesModel: ID → (kind, {port: direction})."""
    out = {}
    for model in root.find("TreeNodesModel") or []:
        ports = {p.get("name", ""): p.tag.removesuffix("_port") for p in model if p.tag.endswith("_port")}
        out[model.get("ID", "")] = (model.tag, ports)
    return out


def nodes(element: ElementTree.Element):
    for child in element:
        yield child
        yield from nodes(child)


def test_our_built_ins_are_bt_cpps():
    assert set(BUILTIN_IDS) == BTCPP_BUILTINS


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(TREES_DIR)))
def test_a_shipped_file_keeps_bt_cpps_load_rules(path: Path):
    root = ElementTree.parse(path).getroot()
    assert root.tag == "root" and root.get("BTCPP_format") == "4"
    assert len(root.findall("TreeNodesModel")) == 1, "BT.CPP reads exactly one <TreeNodesModel>"
    model = models(root)
    registered = BTCPP_BUILTINS | {tag for tag, (kind, _) in model.items() if kind != "SubTree"}
    trees = {tree.get("ID") for tree in root.findall("BehaviorTree")}
    for tree in root.findall("BehaviorTree"):
        tree_id = tree.get("ID", "")
        # 4.6.2+: "The attribute [ID] of tag <BehaviorTree> must not use the name of a registered Node"
        assert tree_id not in registered, f"tree {tree_id} has the name of a node"
        assert not FORBIDDEN.search(tree_id) and tree_id not in ("Root", "root")
        assert len(tree) == 1, f"<BehaviorTree ID={tree_id}> must have exactly 1 child"
        for node in nodes(tree):
            node_type = node.get("ID", "") if node.tag in KIND_TAGS else node.tag
            if node.tag == "SubTree":
                assert node_type not in registered, f"SubTree {node_type} has the name of a node"
                assert len(node) == 0, "<SubTree> should not have any child"
                continue
            assert node_type in registered, f"{path.name}: {node_type} is neither a built-in nor in the model"
            ports = model[node_type][1] if node_type in model else dict.fromkeys(BUILTIN_PORTS.get(node_type, ()), "")
            for attr, value in node.attrib.items():
                if attr in RESERVED or (node.tag in KIND_TAGS and attr == "ID"):
                    continue
                # "a port with name [x] is found in the XML but not in the providedPorts()"
                assert attr in ports, f"{path.name}: <{node_type}> has no port {attr}"
                if ports[attr] == "output":
                    assert value.startswith("{") and value.endswith("}"), f"output {attr} must be a {{key}}"
    for tree_id in {n.get("ID") for tree in root.findall("BehaviorTree") for n in nodes(tree) if n.tag == "SubTree"}:
        assert tree_id in trees or any(inc.get("path") for inc in root.findall("include")), tree_id


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(TREES_DIR)))
def test_a_shipped_files_model_describes_every_registered_behaviour_as_declared(path: Path):
    """Groot2 and a C++ host see our behaviours' ports, outputs included, exactly as the Python declares them."""
    model = models(ElementTree.parse(path).getroot())
    for node in shipped_factory().behaviours():
        kind, ports = model[node.tag]
        assert kind == node.kind
        assert ports == {name: port.direction for name, port in node.ports.items()}
