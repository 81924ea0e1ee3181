"""Properties of the tree loader (trees/loader.py) over generated files: random bytes, text and element
soup are a one-line TreeError naming the file, never another exception; generated valid trees of the
shipped behaviours and BT.CPP built-ins validate, describe and build node for node."""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import py_trees
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mission.core.errors import TreeError
from mission.trees.factory import shipped_factory
from mission.trees.loader import describe_tree, load_tree, validate_tree

SETTINGS = settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def tree_file(directory: Path, data: str | bytes) -> Path:
    path = directory / "generated.xml"
    if isinstance(data, bytes):
        path.write_bytes(data)
    else:
        path.write_text(data, encoding="utf-8")
    return path


def only_tree_errors(path: Path) -> None:
    try:
        validate_tree(path)
    except TreeError as err:
        message = str(err)
        assert message.startswith(str(path.resolve())) and "\n" not in message, message


@SETTINGS
@given(data=st.binary(max_size=300))
def test_random_bytes_are_a_tree_error_naming_the_file(tmp_path, data):
    only_tree_errors(tree_file(tmp_path, data))


TAGS = [
    "root",
    "BehaviorTree",
    "Sequence",
    "Fallback",
    "Inverter",
    "SubTree",
    "include",
    "Explore",
    "PerceiveTargets",
    "Parallel",
    "Timeout",
    "AlwaysSuccess",
    "Nope",
    "TreeNodesModel",
]
ATTRS = ["ID", "BTCPP_format", "main_tree_to_execute", "path", "target", "msec", "name", "timeout_s", "x"]
VALUES = ["4", "3", "T", "target", "", "-1", "nan", "1e9", "{bb}", "../x.xml", "0", "Sequence"]


@st.composite
def element_soup(draw: st.DrawFn, depth: int = 0) -> str:
    tag = draw(st.sampled_from(TAGS))
    attrs = draw(st.dictionaries(st.sampled_from(ATTRS), st.sampled_from(VALUES), max_size=3))
    text = "".join(f" {k}={quoteattr(v)}" for k, v in attrs.items())
    children = draw(st.lists(element_soup(depth + 1), max_size=3)) if depth < 4 else []
    return f"<{tag}{text}>{''.join(children)}</{tag}>" if children else f"<{tag}{text}/>"


@SETTINGS
@given(body=element_soup())
def test_any_soup_of_tree_elements_is_a_tree_error_naming_the_file_or_a_valid_tree(tmp_path, body):
    only_tree_errors(tree_file(tmp_path, body))


@SETTINGS
@given(body=element_soup())
def test_the_same_soup_inside_a_v4_root_is_a_tree_error_or_a_valid_tree(tmp_path, body):
    only_tree_errors(tree_file(tmp_path, f'<root BTCPP_format="4"><BehaviorTree ID="T">{body}</BehaviorTree></root>'))


# -- valid trees ---------------------------------------------------------------------------------------------

LEAVES = {
    "AlwaysSuccess": {},
    "AlwaysFailure": {},
    "PerceiveTargets": {},
    "IsTargetVisible": {"target": st.sampled_from(["target", "dock"]), "max_misses": st.integers(0, 10)},
    "IsLineOfSightBlocked": {"target": st.just("target"), "min_misses": st.integers(1, 10)},
    "HoldLastGoal": {"timeout_s": st.floats(0.1, 30), "offset_m": st.floats(0.0, 2.0)},
    "SearchSweep": {"duration_s": st.floats(1, 120), "angular_speed": st.floats(0.1, 1.5)},
    "FollowTarget": {"offset_m": st.floats(0.1, 2.0), "window": st.integers(1, 10), "rate_hz": st.floats(0.5, 20)},
}
CONTROLS = ["Sequence", "ReactiveSequence", "Fallback", "ReactiveFallback"]
DECORATORS = {  # their ports are all required
    "Inverter": {},
    "ForceSuccess": {},
    "ForceFailure": {},
    "RetryUntilSuccessful": {"num_attempts": st.integers(1, 5)},
    "Repeat": {"num_cycles": st.integers(1, 5)},
    "Timeout": {"msec": st.integers(1, 10_000)},
}


def _attrs(draw: st.DrawFn, ports: dict[str, st.SearchStrategy], *, required: bool = False) -> str:
    """Some of the optional ports, or all of the required ones, with valid values."""
    chosen = sorted(ports) if required else draw(st.lists(st.sampled_from(sorted(ports)), unique=True)) if ports else []
    return "".join(f' {name}="{draw(ports[name])}"' for name in chosen)


@st.composite
def valid_node(draw: st.DrawFn, depth: int = 0) -> tuple[str, int]:
    """(XML of a valid node, how many nodes it has)."""
    kind = draw(st.sampled_from(["leaf"] if depth >= 4 else ["leaf", "leaf", "control", "decorator", "parallel"]))
    if kind == "leaf":
        tag = draw(st.sampled_from(sorted(LEAVES)))
        return f"<{tag}{_attrs(draw, LEAVES[tag])}/>", 1
    if kind == "decorator":
        tag = draw(st.sampled_from(sorted(DECORATORS)))
        child, n = draw(valid_node(depth + 1))
        return f"<{tag}{_attrs(draw, DECORATORS[tag], required=True)}>{child}</{tag}>", n + 1
    children = draw(st.lists(valid_node(depth + 1), min_size=1, max_size=3))
    xml = "".join(c for c, _ in children)
    total = 1 + sum(n for _, n in children)
    if kind == "parallel":
        k = len(children)
        ok = draw(st.sampled_from([-1, *range(1, k + 1)]))
        fail = draw(st.sampled_from([-1, *range(1, k + 1)]))
        return f'<Parallel success_count="{ok}" failure_count="{fail}">{xml}</Parallel>', total
    tag = draw(st.sampled_from(CONTROLS))
    return f'<{tag} name="n{depth}">{xml}</{tag}>', total


def count(node: py_trees.behaviour.Behaviour) -> int:
    return 1 + sum(count(c) for c in node.children)


@SETTINGS
@given(node=valid_node())
def test_a_generated_valid_tree_validates_describes_and_builds_node_for_node(tmp_path, node):
    xml, n = node
    path = tree_file(tmp_path, f'<root BTCPP_format="4">\n  <BehaviorTree ID="Gen">{xml}</BehaviorTree>\n</root>\n')
    validate_tree(path)
    desc = describe_tree(path)
    assert sum(1 for _ in desc.walk()) == n + 1  # + the BehaviorTree itself
    root = load_tree(path, shipped_factory())
    assert isinstance(root, py_trees.behaviour.Behaviour) and count(root) == n
