"""BT.CPP's own suite, translated: where each translated TEST is marked (the summary line CI prints is
suite_summary.py's).

A test marked ``btcpp("Suite.Name", kind="tree"|"script")`` (btcpp_harness.TEST / SCRIPT) is one BT.CPP TEST
(tree) or one assertion of script_parser_test.cpp (script; a TEST's assertions are its parametrized cases).
Each item carries its marker in ``user_properties``, which travel with its reports to wherever they are counted
(another process, under pytest-xdist).
"""

from __future__ import annotations

import pytest

from tests.trees.btcpp.suite_summary import PROPERTY


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        mark = item.get_closest_marker("btcpp")
        if mark is not None:
            item.user_properties.append((PROPERTY, [mark.args[0], mark.kwargs.get("kind", "tree")]))
