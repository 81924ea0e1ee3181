"""The interface packages scripts/build_ros builds (ros/tf2_msgs, ros/nav2_msgs) are Jazzy's, hash for hash.

A ROS 2 publisher and subscriber (or action client and server) only match when their type hashes agree,
so the node can talk to a real Nav2 only if our nav2_msgs hashes equal a real install's. Three witnesses:

* the hash rosidl wrote into the colcon build (``install/<pkg>/share/<pkg>/…/<Name>.json``);
* our own computation from the definition text (tests/helpers/type_hash.py), checked first against messages of the
  ros-jazzy-* wheels, whose hashes the ROS build farm computed;
* the hashes of a colcon build of nav2_msgs 1.4.0 published in a public workspace: 1.4.0's definitions of
  these types have the same fields as the Jazzy branch (it only adds error-code constants, which a type
  hash does not cover), and every type they reference hashes the same there as in our Jazzy wheels.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.helpers.ros_env import INSTALL, ROOT, build_ros
from tests.helpers.type_hash import Field, parse_fields, type_hash

pytestmark = pytest.mark.ros

VENV_SHARE = ROOT / ".venv" / "share"

# nav2_msgs 1.4.0 built with colcon (rosidl_generator_c's __description.c), as published in a public workspace
REFERENCE = {
    "nav2_msgs/action/NavigateToPose": "a56dba8a3234a1215e610180dc703ae25bbf406dded8b54887891c9732857eab",
    "nav2_msgs/action/NavigateToPose_Goal": "22a9dffbd6733011220460bd52edbc7843c8fc86282d40bc7ad3ca176a9dec10",
    "nav2_msgs/action/NavigateToPose_Result": "ddbff7fc6d1e51d774d5defdb8398a57cb23fa8709355002d676408bb4860b85",
    "nav2_msgs/action/NavigateToPose_Feedback": "9ebc544c7d41bd8c6060b191bf9f5e4ddca6c2f61ee9e04fcb62ed5d67218a33",
    "nav2_msgs/action/NavigateToPose_FeedbackMessage":
        "9d1f6fa2eb975ce733b419ac2e97b134d8ff92b6478b6559feed9a50bdfd82b3",
    "nav2_msgs/action/NavigateToPose_SendGoal": "a4fcb3bee1bf32e21a0e541a943b221aa0826996e2c98f079b47022b256f48b5",
    "nav2_msgs/action/NavigateToPose_GetResult": "c407920357d566771e8882b4ef4d1f1a84ee922d609920ccd57faa6d6e391dc5",
    "nav2_msgs/msg/BehaviorTreeLog": "9335ecb688a4f61b7eb82a7c10f23eea5f4e8bbdb7edfa048e3539aa928f51b7",
    "nav2_msgs/msg/BehaviorTreeStatusChange": "54c5a8cc559e5eefc90b9c23a9f81c1b326c97c036d10baa556bac3ef07113c6",
}  # fmt: skip


def _share_dirs() -> list[Path]:
    return [INSTALL / "tf2_msgs" / "share", INSTALL / "nav2_msgs" / "share", VENV_SHARE]


def _interface_file(pkg: str, kind: str, name: str) -> Path:
    for share in _share_dirs():
        path = share / pkg / kind / f"{name}.{kind}"
        if path.is_file():
            return path
    raise FileNotFoundError(f"{pkg}/{kind}/{name}.{kind} in none of {_share_dirs()}")


def definitions(type_name: str) -> list[Field]:
    """The fields of a message, or of an action's Goal / Result / Feedback / FeedbackMessage."""
    pkg, kind, name = type_name.split("/")
    if kind == "msg":
        return parse_fields(_interface_file(pkg, "msg", name).read_text(), pkg)
    action, _, part = name.rpartition("_")
    if part == "FeedbackMessage":  # what rosidl adds for an action's feedback topic
        return [
            Field("goal_id", 1, nested_type_name="unique_identifier_msgs/msg/UUID"),
            Field("feedback", 1, nested_type_name=f"{pkg}/action/{action}_Feedback"),
        ]
    sections = _interface_file(pkg, "action", action).read_text().split("\n---")
    return parse_fields(sections[("Goal", "Result", "Feedback").index(part)], pkg)


def built_hashes(json_file: Path) -> dict[str, str]:
    """type name → hash (without the RIHS01_ prefix) as rosidl wrote them into a built package."""
    data = json.loads(json_file.read_text())
    return {h["type_name"]: h["hash_string"].removeprefix("RIHS01_") for h in data["type_hashes"]}


@pytest.fixture(scope="module", autouse=True)
def built():
    build_ros()


@pytest.mark.parametrize(
    "type_name",
    [
        "geometry_msgs/msg/PoseStamped",
        "sensor_msgs/msg/CameraInfo",
        "nav_msgs/msg/Odometry",
        "sensor_msgs/msg/LaserScan",
    ],
)
def test_our_hash_computation_agrees_with_the_build_farm_on_jazzy_wheel_messages(type_name):
    pkg, _, name = type_name.split("/")
    farm = built_hashes(VENV_SHARE / pkg / "msg" / f"{name}.json")[type_name]
    assert type_hash(type_name, definitions) == f"RIHS01_{farm}"


@pytest.mark.parametrize("type_name", sorted(REFERENCE))
def test_built_nav2_msgs_types_have_jazzy_type_hashes(type_name):
    pkg, kind, name = type_name.split("/")
    top = name.split("_")[0]
    built = built_hashes(INSTALL / pkg / "share" / pkg / kind / f"{top}.json")
    assert built[type_name] == REFERENCE[type_name]
    if not name.endswith(("SendGoal", "GetResult")) and name != "NavigateToPose":  # services: rosidl-made types
        assert type_hash(type_name, definitions) == f"RIHS01_{REFERENCE[type_name]}"


def test_built_tf2_msgs_has_the_hash_computed_from_its_definition():
    built = built_hashes(INSTALL / "tf2_msgs" / "share" / "tf2_msgs" / "msg" / "TFMessage.json")
    assert type_hash("tf2_msgs/msg/TFMessage", definitions) == f"RIHS01_{built['tf2_msgs/msg/TFMessage']}"


def test_the_definitions_in_the_repo_are_what_was_built():
    for rel in ("action/NavigateToPose.action", "msg/BehaviorTreeLog.msg", "msg/BehaviorTreeStatusChange.msg"):
        built = INSTALL / "nav2_msgs" / "share" / "nav2_msgs" / rel
        assert (ROOT / "ros" / "nav2_msgs" / rel).read_text() == built.read_text()
