"""Bad tree files with the shipped behaviours (issue 9, bad-input matrix: trees).

Each is one TreeError line naming the file, the line and the element, and what was expected, raised
before anything is built.

Already covered in test_loader.py (with test-only leaves): malformed XML, an empty file, unknown
tags and ports, wrong port types, unknown and recursive subtrees, missing and cyclic includes, and the
BT.CPP structure rules.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from mission.app.runner import TreeRunner
from mission.cli import main
from mission.core.config import MissionConfig, PerceptionConfig, TargetSpec
from mission.core.errors import TreeError
from mission.trees.loader import check_targets, validate_tree
from mission.trees.xml_source import MAX_DEPTH

V4 = '<root BTCPP_format="4">\n  <BehaviorTree ID="T">\n    {node}\n  </BehaviorTree>\n</root>\n'


def tree_file(tmp_path: Path, content: str | bytes, name: str = "bad.xml") -> Path:
    path = tmp_path / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    return path


def error_of(path: Path) -> str:
    with pytest.raises(TreeError) as err:
        validate_tree(path)
    message = str(err.value)
    assert "\n" not in message
    return message


BILLION_LAUGHS = (
    '<?xml version="1.0"?>\n<!DOCTYPE lolz [<!ENTITY lol "lol">'
    + "".join(f'<!ENTITY lol{i} "{f"&lol{i - 1};" * 10 if i > 1 else "&lol;" * 10}">' for i in range(1, 8))
    + ']>\n<root BTCPP_format="4"><BehaviorTree ID="T"><Sequence name="&lol7;"><Explore/></Sequence>'
    "</BehaviorTree></root>\n"
)

CASES = {
    # name: (file content, message after "<path>:")
    "binary file": (b"\x89PNG\r\n\x1a\n\x00\x00", "1: malformed XML: not well-formed (invalid token) (column 1)"),
    "latin-1 text": (
        V4.format(node="<Sequence>caf\xe9</Sequence>").encode("latin-1"),
        "3: malformed XML: not well-formed (invalid token) (column 18)",
    ),
    "plain text": ("explore, then dock\n", "1: malformed XML: syntax error (column 1)"),
    "entity expansion bomb": (BILLION_LAUGHS, "3: malformed XML: limit on input amplification factor"),
    "misspelt shipped node": (
        V4.format(node='<FollowTaget target="target"/>'),
        "3: <FollowTaget>: unknown node 'FollowTaget' (did you mean FollowTarget?)",
    ),
    "NaN port": (
        V4.format(node='<Explore timeout_s="nan"/>'),
        "3: <Explore>: port timeout_s expects a finite float, got 'nan'",
    ),
    "infinite port": (
        V4.format(node='<SearchSweep duration_s="inf"/>'),
        "3: <SearchSweep>: port duration_s expects a finite float, got 'inf'",
    ),
    "subtree that is itself": (
        V4.format(node='<SubTree ID="T"/>'),
        '3: <SubTree ID="T">: recursive subtree: T → T; a tree cannot contain itself',
    ),
    "subtree without ID": (V4.format(node="<SubTree/>"), '3: <SubTree>: missing ID; expected <SubTree ID="TreeName"/>'),
    "subtree that does not exist": (
        V4.format(node='<SubTree ID="Dock"/>'),
        "3: <SubTree ID=\"Dock\">: unknown subtree 'Dock'; trees defined: T",
    ),
    "include without path": (
        '<root BTCPP_format="4">\n  <include/>\n  <BehaviorTree ID="T"><Explore/></BehaviorTree>\n</root>\n',
        '2: <include>: missing path; expected <include path="other.xml"/>',
    ),
    "one of two trees without ID": (
        '<root BTCPP_format="4">\n  <BehaviorTree><Explore/></BehaviorTree>\n  <BehaviorTree ID="T"><Explore/>'
        "</BehaviorTree>\n</root>\n",
        '2: <BehaviorTree>: missing ID; a file with several trees must name each: <BehaviorTree ID="Name">',
    ),
    "no trees": ('<root BTCPP_format="4">\n</root>\n', "1: <root>: the file defines 0 trees (none)"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_bad_tree_file_is_one_line_naming_file_line_and_what_was_expected(tmp_path, case):
    content, tail = CASES[case]
    path = tree_file(tmp_path, content)
    assert error_of(path).startswith(f"{path.resolve()}:{tail}")


def test_absurd_nesting_is_an_error_at_the_element_not_a_recursion_error(tmp_path):
    depth = 3000
    node = "<Sequence>\n" * depth + "<Explore/>" + "\n</Sequence>" * depth
    path = tree_file(tmp_path, V4.format(node=node))
    deepest = 3 + MAX_DEPTH - 2  # line of the first element MAX_DEPTH deep (root and BehaviorTree are 2)
    assert error_of(path) == (
        f"{path.resolve()}:{deepest}: <Sequence>: nested {MAX_DEPTH} elements deep; expected at most {MAX_DEPTH} "
        "(split the tree into <SubTree>s)"
    )


def test_nesting_within_the_limit_loads(tmp_path):
    depth = MAX_DEPTH - 5
    node = "<Sequence>" * depth + "<Explore/>" + "</Sequence>" * depth
    validate_tree(tree_file(tmp_path, V4.format(node=node)))


def test_a_directory_is_not_a_tree_file(tmp_path):
    folder = tmp_path / "mission.xml"
    folder.mkdir()
    assert error_of(folder).startswith(f"{folder}: tree file not found; expected a path to a BehaviorTree.CPP v4")


# -- a tree and the config's targets ------------------------------------------------------------------------


def test_a_target_port_naming_no_configured_target_is_an_error_at_its_line(tmp_path):
    path = tree_file(tmp_path, V4.format(node='<Sequence><IsTargetVisible target="targte"/><FollowTarget/></Sequence>'))
    with pytest.raises(TreeError) as err:
        check_targets(path, ["target", "dock"])
    assert str(err.value) == (
        f"{path.resolve()}:3: <IsTargetVisible>: target 'targte' is not a perception target; "
        "expected one of perception.targets: dock, target"
    )


def test_a_defaulted_target_port_is_checked_too_and_says_it_is_the_default(tmp_path):
    path = tree_file(tmp_path, V4.format(node="<Explore/>"))  # Explore's target defaults to "dock"
    with pytest.raises(TreeError, match=r":3: <Explore>: target 'dock' \(the port's default\) is not a perception"):
        check_targets(path, ["target"])


def test_the_runner_checks_targets_before_creating_sources_or_touching_the_world(tmp_path):
    path = tree_file(tmp_path, V4.format(node='<FollowTarget target="person"/>'))
    config = MissionConfig(perception=PerceptionConfig(targets={"target": TargetSpec(marker_id=7)}))
    runner = TreeRunner(config, world=None, tree=str(path))  # type: ignore[arg-type]
    with pytest.raises(TreeError, match="target 'person' is not a perception target"):
        runner.setup()
    assert runner.sources == []


@pytest.mark.parametrize("fmt", ["svg", "png", "html", "dot"])
def test_mission_viz_into_a_place_that_cannot_be_written_is_one_line(tmp_path, capsys, fmt):
    blocker = tmp_path / "not_a_dir"
    blocker.write_text("")
    out = blocker / f"tree.{fmt}"
    assert main(["viz", "follow.xml", "--format", fmt, "-o", str(out)]) == 2
    [line] = capsys.readouterr().err.splitlines()
    assert line == f"mission: error: {out}: cannot write (Not a directory)"
