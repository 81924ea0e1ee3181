"""The interface packages scripts/build_ros builds (ros/tf2_msgs, ros/nav2_msgs) are Jazzy's, hash for hash.

A ROS 2 publisher and subscriber (or action client and server) only match when their type hashes agree,
so the node can talk to a real Nav2 only if our nav2_msgs hashes equal a real install's. Three witnesses:

* the hash rosidl wrote into the colcon build (``install/<pkg>/share/<pkg>/…/<Name>.json``);
* our own computation from the definition text (tests/helpers/type_hash.py), checked first against messages of the
  ros-jazzy-* wheels, whose hashes the ROS build farm computed;
* the hashes of colcon builds of nav2_msgs published in public workspaces (1.4.0 for NavigateToPose and the
  BehaviorTreeLog messages; DockRobot, UndockRobot, FollowObject from two more): their definitions of these
  types have the same fields as the Jazzy branch (newer ones only add error-code constants, which a type hash
  does not cover), and every type they reference hashes the same there as in our Jazzy wheels.
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
    # the actions the node serves (issue 32), as rosidl built them in two public workspaces
    # (rosidl_generator_c's __description.c): DockRobot and UndockRobot in thomasankara/hive_ws2 @ a983b6c8,
    # FollowObject in PlutoXXIV/repoams @ b0fbf203; their Goal / Result / Feedback fields are the Jazzy branch's
    "nav2_msgs/action/DockRobot": "d4398769495d327a0cba210e3cf1055ac742ec8a3eccc683f88b1c730b1d6405",
    "nav2_msgs/action/DockRobot_Goal": "771fae864909c42683a444d493e806a2e709af4678a21091e64edbe16e3223bc",
    "nav2_msgs/action/DockRobot_Result": "09208d89bb7477854fc834f4ceced1e963890614c5e0821121b2a97ddb7be5eb",
    "nav2_msgs/action/DockRobot_Feedback": "b23f877ad7013aae4ad83a1330e83a62a1397594839126331a843a8852dcc8e8",
    "nav2_msgs/action/DockRobot_SendGoal": "9e60155a1fb741109942c5c7dc21ae0e0db771eaf55d0cfc768bae57a95f3454",
    "nav2_msgs/action/DockRobot_GetResult": "3e83e8a6eefb3ebe244cd0384418f43d22ffb1f3263fd7b978af8164591c50b3",
    "nav2_msgs/action/DockRobot_FeedbackMessage": "16db0109537f6d74013ed7e6fa51f21c6dcc0a0355cef3be4db4401e971bbe81",
    "nav2_msgs/action/UndockRobot": "fe446bf5f84bbdc08b5a1123365e3c9b1e522e50a412d64c36995f808df915a2",
    "nav2_msgs/action/UndockRobot_Goal": "4161041de8368e5140d3a4af41d24a8756e30e42249e022e258a30a0e1781ccb",
    "nav2_msgs/action/UndockRobot_Result": "df25b55a44a1b73a03fe7f32c7ba0984dd077e5315cad6f25c7354ff5de6b310",
    "nav2_msgs/action/UndockRobot_Feedback": "cafb11296f8495bfdf9a773d2cdc226a906a67b466c1670a23e645334aa85996",
    "nav2_msgs/action/UndockRobot_SendGoal": "9c412dec37b7dad67b754dd860cdb03787c0924f01d4cd2b5c16506726b17dc3",
    "nav2_msgs/action/UndockRobot_GetResult": "116641408dd0a5bbb7f0cb61d4519061884c7fcc70ca78b0f89779459cf04263",
    "nav2_msgs/action/UndockRobot_FeedbackMessage": "e2204b39a6cd5f0563392b37a5945130d186c5df1c457fcb23ba72b3ff02eed1",
    "nav2_msgs/action/FollowObject": "4d6e71c4308e19ff8ab8d1a2f48ff27f8d1e24456280c3d0f716893f76b5494d",
    "nav2_msgs/action/FollowObject_Goal": "9df7fb19fc953c0723ead5597fe3ed34c0edcc4d76f2bd9ccc8a48bc0bd85e7a",
    "nav2_msgs/action/FollowObject_Result": "bee30321cc542d5bf5579a785d86bae2db5aea40797252eadcf183ea36875ae0",
    "nav2_msgs/action/FollowObject_Feedback": "4d58bd5c9ea9248dec74ba7cc95f2e3ebeb44af9b02d6fa1ee30f0f6a17b7839",
    "nav2_msgs/action/FollowObject_SendGoal": "be8d4b9e9009767046743b47297c12d1487359a022888b04a72781cf029244d9",
    "nav2_msgs/action/FollowObject_GetResult": "c185b60e2fb1198b2d388eca8bb6502f324e58d1364cd883376043558e60f5a1",
    "nav2_msgs/action/FollowObject_FeedbackMessage": "0711fd141e723cc523724763fff0657e02d5e5292415ef1b19780e89308e8a23",
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
    if "_" in name and not name.endswith(("SendGoal", "GetResult")):  # the action and its services: rosidl-made
        assert type_hash(type_name, definitions) == f"RIHS01_{REFERENCE[type_name]}"


def test_built_tf2_msgs_has_the_hash_computed_from_its_definition():
    built = built_hashes(INSTALL / "tf2_msgs" / "share" / "tf2_msgs" / "msg" / "TFMessage.json")
    assert type_hash("tf2_msgs/msg/TFMessage", definitions) == f"RIHS01_{built['tf2_msgs/msg/TFMessage']}"


def test_the_definitions_in_the_repo_are_what_was_built():
    actions = [f"action/{a}.action" for a in ("NavigateToPose", "DockRobot", "UndockRobot", "FollowObject")]
    for rel in (*actions, "msg/BehaviorTreeLog.msg", "msg/BehaviorTreeStatusChange.msg"):
        built = INSTALL / "nav2_msgs" / "share" / "nav2_msgs" / rel
        assert (ROOT / "ros" / "nav2_msgs" / rel).read_text() == built.read_text()
