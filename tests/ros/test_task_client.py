"""TaskClient (mission/ros/task_client.py): Nav2's docking and following actions with nav2_simple_commander's calls,
over real rclpy and the shared-memory DDS profile, against fake servers written from the .action definitions
(tests/helpers/nav2_servers.py) that stand in for the ones being written.

The goals must carry what BasicNavigator (navigation2, nav2_simple_commander/robot_navigator.py) puts in them, and
isTaskComplete / getFeedback / getResult / getTaskError / cancelTask must mean what they mean there; where this
client differs (no waiting for ever, every feedback message, the whole result) the tests say so.
"""

from __future__ import annotations

import math
import time

import pytest
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import PoseStamped

from mission.ros.task_client import RunningTask, ServerUnavailable, TaskClient, TaskResult
from tests.helpers.nav2_servers import FakeNav2Servers, Script
from tests.helpers.ros_env import wait_for

pytestmark = pytest.mark.ros


@pytest.fixture(scope="module")
def client(servers):
    """One client for the module's goals, as a script keeps one (discovery once: it can take 2–3 s here)."""
    received = []
    with TaskClient(server_timeout_s=10.0, on_feedback=received.append) as nav:
        nav.received = received
        yield nav


@pytest.fixture
def nav(client, servers):
    for name in servers.scripts:
        servers.scripts[name] = lambda goal: Script()
    client.received.clear()
    return client


@pytest.fixture
def feedback(nav):
    """Every feedback message the client passed on during the test."""
    return nav.received


@pytest.fixture
def types(nav2):
    return {name: nav2.get("action", name) for name in ("DockRobot", "UndockRobot", "FollowObject")}


@pytest.fixture(scope="module")
def servers(fake):
    return fake


def complete(nav: TaskClient, timeout: float = 5.0) -> TaskResult:
    """Poll isTaskComplete as a BasicNavigator script does; the TaskResult."""
    deadline = time.monotonic() + timeout
    while not nav.isTaskComplete():
        assert time.monotonic() < deadline, f"the task did not complete in {timeout} s"
    return nav.getResult()


def test_dock_by_id_sends_basic_navigators_goal_and_reports_every_feedback_state_and_success(
    nav, servers, types, feedback
):
    fb = types["DockRobot"].Feedback
    states = [fb.NAV_TO_STAGING_POSE, fb.INITIAL_PERCEPTION, fb.CONTROLLING]
    servers.scripts["dock_robot"] = lambda goal: Script(
        feedback=[{"state": s} for s in states], result={"success": True, "num_retries": 0}, period_s=0.02
    )
    assert nav.dockRobotByID("home_dock") is RunningTask.DOCK_ROBOT
    assert complete(nav) is TaskResult.SUCCEEDED
    goal = servers.received("dock_robot")[-1].goal
    assert (goal.use_dock_id, goal.dock_id, goal.navigate_to_staging_pose) == (True, "home_dock", True)
    assert (goal.dock_type, goal.max_staging_time) == ("", 1000.0)  # left at the message's defaults
    assert [f.state for f in feedback] == states  # each message, also those between two polls
    assert nav.getFeedback().state == fb.CONTROLLING
    assert nav.getTaskError() == (0, "")
    assert (nav.last_result.error_name, nav.last_result.num_retries) == ("NONE", 0)
    assert nav.isTaskComplete() and nav.getResult() is TaskResult.SUCCEEDED  # asking again changes nothing


def test_dock_by_id_without_navigating_to_staging_and_with_a_staging_time(nav, servers):
    assert nav.dockRobotByID("home_dock", nav_to_dock=False, max_staging_time=45.0) is RunningTask.DOCK_ROBOT
    complete(nav)
    goal = servers.received("dock_robot")[-1].goal
    assert (goal.use_dock_id, goal.navigate_to_staging_pose, goal.max_staging_time) == (True, False, 45.0)


def test_dock_by_pose_sends_the_pose_its_frame_and_the_dock_type(nav, servers):
    pose = PoseStamped()
    pose.header.frame_id = "odom"
    pose.pose.position.x, pose.pose.position.y = 1.5, -2.0
    pose.pose.orientation.z, pose.pose.orientation.w = math.sin(0.4), math.cos(0.4)
    assert nav.dockRobotByPose(pose, "charging_dock", nav_to_dock=False) is RunningTask.DOCK_ROBOT
    assert complete(nav) is TaskResult.SUCCEEDED
    goal = servers.received("dock_robot")[-1].goal
    assert (goal.use_dock_id, goal.dock_id, goal.dock_type) == (False, "", "charging_dock")
    assert goal.navigate_to_staging_pose is False
    assert goal.dock_pose.header.frame_id == "odom"
    assert (goal.dock_pose.pose.position.x, goal.dock_pose.pose.position.y) == (1.5, -2.0)
    assert goal.dock_pose.pose.orientation.z == pytest.approx(math.sin(0.4))
    nav.dockRobotByPose(pose)  # Nav2's defaults: no type (the server has one), navigate to staging
    complete(nav)
    goal = servers.received("dock_robot")[-1].goal
    assert (goal.dock_type, goal.navigate_to_staging_pose) == ("", True)


@pytest.mark.parametrize(
    ("code", "name", "message", "retries"),
    [
        (901, "DOCK_NOT_IN_DB", "dock 'x' is not in the database", 0),
        (904, "FAILED_TO_DETECT_DOCK", "no dock detection for 1.0 s", 3),
    ],
)
def test_a_failed_dock_is_failed_with_the_servers_error_code_by_name(nav, servers, types, code, name, message, retries):
    assert getattr(types["DockRobot"].Result, name) == code  # the names are the .action's constants
    servers.scripts["dock_robot"] = lambda goal: Script(
        outcome="abort", result={"success": False, "error_code": code, "error_msg": message, "num_retries": retries}
    )
    nav.dockRobotByID("x")
    assert complete(nav) is TaskResult.FAILED
    assert nav.getTaskError() == (code, message)
    outcome = nav.last_result
    assert (outcome.error_code, outcome.error_name, outcome.error_msg) == (code, name, message)
    assert (outcome.num_retries, outcome.action, outcome.status) == (retries, "dock_robot", 6)  # 6: ABORTED


def test_undock_sends_the_dock_type_and_its_result_has_no_retries(nav, servers):
    assert nav.undockRobot("charging_dock", max_undocking_time=12.0) is RunningTask.UNDOCK_ROBOT
    assert complete(nav) is TaskResult.SUCCEEDED
    goal = servers.received("undock_robot")[-1].goal
    assert (goal.dock_type, goal.max_undocking_time) == ("charging_dock", 12.0)
    assert nav.last_result.num_retries is None  # UndockRobot's Result has no num_retries
    nav.undockRobot()
    complete(nav)
    goal = servers.received("undock_robot")[-1].goal
    assert (goal.dock_type, goal.max_undocking_time) == ("", 30.0)


def test_follow_by_topic_or_by_frame_sends_one_of_them_and_max_duration(nav, servers, types, feedback):
    fb = types["FollowObject"].Feedback
    servers.scripts["follow_object"] = lambda goal: Script(
        feedback=[{"state": fb.INITIAL_PERCEPTION}, {"state": fb.CONTROLLING}, {"state": fb.STOPPING}],
        result={"total_elapsed_time": Duration(sec=2, nanosec=500_000_000)},
        period_s=0.02,
    )
    assert nav.followObjectByTopic("/person_pose", max_duration=2.5) is RunningTask.FOLLOW_OBJECT
    assert complete(nav) is TaskResult.SUCCEEDED
    goal = servers.received("follow_object")[-1].goal
    assert (goal.pose_topic, goal.tracked_frame) == ("/person_pose", "")
    assert (goal.max_duration.sec, goal.max_duration.nanosec) == (2, 500_000_000)
    assert [f.state for f in feedback] == [fb.INITIAL_PERCEPTION, fb.CONTROLLING, fb.STOPPING]
    assert nav.last_result.elapsed_s == pytest.approx(2.5)
    assert nav.followObjectByFrame("person") is RunningTask.FOLLOW_OBJECT
    complete(nav)
    goal = servers.received("follow_object")[-1].goal
    assert (goal.pose_topic, goal.tracked_frame) == ("", "person")
    assert (goal.max_duration.sec, goal.max_duration.nanosec) == (0, 0)  # 0: follow until canceled or failed


def test_a_lost_object_fails_with_the_following_servers_code(nav, servers):
    servers.scripts["follow_object"] = lambda goal: Script(
        outcome="abort", result={"error_code": 902, "error_msg": "object lost", "num_retries": 3}
    )
    nav.followObjectByFrame("person")
    assert complete(nav) is TaskResult.FAILED
    assert (nav.last_result.error_name, nav.last_result.num_retries) == ("FAILED_TO_DETECT_OBJECT", 3)
    assert nav.getTaskError() == (902, "object lost")


def test_cancel_task_ends_the_goal_canceled(nav, servers, types, feedback):
    servers.scripts["follow_object"] = lambda goal: Script(
        feedback=[{"state": types["FollowObject"].Feedback.CONTROLLING}], outcome="hold"
    )
    nav.followObjectByTopic("/person_pose")
    wait_for(lambda: nav.isTaskComplete(timeout_sec=0.02) or feedback, 5.0, "feedback")
    assert not nav.isTaskComplete()
    assert nav.cancelTask() is True
    assert nav.getFeedback() is None  # cleared by the cancel, as BasicNavigator does
    assert complete(nav) is TaskResult.CANCELED
    seen = servers.received("follow_object")[-1]
    assert (seen.cancel_requested, seen.end) == (True, "canceled")
    assert nav.cancelTask() is False  # nothing runs any more


def test_a_cancel_the_server_refuses_leaves_the_goal_running(nav, servers):
    servers.scripts["undock_robot"] = lambda goal: Script(feedback=[{}] * 10, accept_cancel=False, period_s=0.03)
    nav.undockRobot()
    assert nav.cancelTask() is False
    assert "refused to cancel" in nav.getTaskError()[1]
    assert complete(nav) is TaskResult.SUCCEEDED


def test_a_rejected_goal_returns_none_with_an_error(nav, servers):
    servers.scripts["dock_robot"] = lambda goal: Script(accept=False)
    assert nav.dockRobotByID("home_dock") is None
    assert nav.getTaskError() == (999, "dock_robot: the server rejected the goal")  # Result.UNKNOWN, as Nav2
    assert nav.isTaskComplete() and nav.getResult() is TaskResult.UNKNOWN


def test_a_new_goal_replaces_the_watched_one(nav, servers, types, feedback):
    fb = types["FollowObject"].Feedback
    servers.scripts["follow_object"] = lambda goal: Script(
        feedback=[{"state": fb.RETRY if goal.tracked_frame == "old" else fb.CONTROLLING}],
        outcome="hold" if goal.tracked_frame == "old" else "succeed",
    )
    nav.followObjectByFrame("old")
    wait_for(lambda: nav.isTaskComplete(timeout_sec=0.02) or feedback, 5.0, "the first goal's feedback")
    seen_before = len(feedback)
    nav.followObjectByFrame("new")
    assert complete(nav) is TaskResult.SUCCEEDED
    time.sleep(0.1)  # the old goal goes on repeating RETRY: none of it reaches this task
    nav.isTaskComplete()
    assert [f.state for f in feedback[seen_before:]] == [fb.CONTROLLING]
    assert nav.getFeedback().state == fb.CONTROLLING
    assert [s.goal.tracked_frame for s in servers.received("follow_object")[-2:]] == ["old", "new"]


@pytest.mark.parametrize(
    ("send", "action"),
    [
        (lambda nav: nav.dockRobotByID("home_dock"), "nav2_msgs/action/DockRobot"),
        (lambda nav: nav.undockRobot(), "nav2_msgs/action/UndockRobot"),
        (lambda nav: nav.followObjectByTopic("/person_pose"), "nav2_msgs/action/FollowObject"),
    ],
)
def test_no_server_is_one_line_naming_the_action_after_the_timeout_not_a_wait_for_ever(servers, send, action):
    with TaskClient(namespace="nobody", server_timeout_s=0.5) as nav:
        t0 = time.monotonic()
        with pytest.raises(ServerUnavailable) as err:
            send(nav)
        waited = time.monotonic() - t0
        name = {"DockRobot": "dock_robot", "UndockRobot": "undock_robot", "FollowObject": "follow_object"}
        assert str(err.value).startswith(f"/nobody/{name[action.rsplit('/', 1)[1]]}: no {action} action server")
        assert "\n" not in str(err.value)
        assert 0.5 <= waited < 2.0
        assert nav.isTaskComplete()  # nothing was sent


def test_a_server_that_goes_away_mid_goal_ends_the_task_after_the_timeout(nav2, types):
    fake = FakeNav2Servers(nav2, namespace="vanishing", node_name="vanishing_servers")
    fake.scripts["follow_object"] = lambda goal: Script(
        feedback=[{"state": types["FollowObject"].Feedback.CONTROLLING}], outcome="hold"
    )
    try:
        with TaskClient(namespace="vanishing", server_timeout_s=10.0) as nav:  # discovery can take 2–3 s
            nav.followObjectByFrame("person")
            wait_for(lambda: nav.isTaskComplete(timeout_sec=0.02) or nav.getFeedback(), 5.0, "feedback")
            nav.server_timeout_s = 0.5
            fake.vanish("follow_object")
            t0 = time.monotonic()
            assert complete(nav, timeout=5.0) is TaskResult.UNKNOWN
            assert time.monotonic() - t0 >= 0.5
            code, message = nav.getTaskError()
            assert (code, message) == (999, "/vanishing/follow_object: the action server went away during the goal")
            assert nav.last_result.error_name == "UNKNOWN"
    finally:
        fake.close()


def test_destroy_releases_everything_once(servers):
    nav = TaskClient(node_name="destroyed_twice")
    nav.destroy()
    nav.destroy()
    nav.destroyNode()  # BasicNavigator's name: nothing left to do
