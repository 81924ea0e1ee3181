"""Shared fixtures. Every test gets a clean py_trees blackboard so keys never leak between tests."""

from __future__ import annotations

import py_trees
import pytest

# BT.CPP suite's summary line: a plugin of the whole run, so that under pytest-xdist the controller, which
# collects nothing and so never loads tests/trees/btcpp/conftest.py, still counts the workers' reports.
pytest_plugins = ("tests.trees.btcpp.suite_summary",)


@pytest.fixture(autouse=True)
def clean_blackboard():
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()
