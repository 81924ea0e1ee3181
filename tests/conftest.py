"""Shared fixtures. Every test gets a clean py_trees blackboard so keys never leak between tests."""

from __future__ import annotations

import py_trees
import pytest


@pytest.fixture(autouse=True)
def clean_blackboard():
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()
