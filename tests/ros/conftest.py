"""Fixtures of the ROS tests."""

from __future__ import annotations

import pytest

from mission.ros.tf_support import load_nav2
from tests.helpers.nav2_servers import FakeNav2Servers
from tests.helpers.ros_env import build_ros


@pytest.fixture(scope="module")
def nav2():
    """nav2_msgs, built by scripts/build_ros (the tests' interface classes)."""
    build_ros()
    interfaces = load_nav2()
    assert interfaces.ok, interfaces.detail
    return interfaces


@pytest.fixture(scope="module")
def fake(nav2):
    """The three fake action servers, for a module's tests."""
    servers = FakeNav2Servers(nav2)
    yield servers
    servers.close()
