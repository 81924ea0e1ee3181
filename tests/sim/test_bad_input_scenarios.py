"""Scenario files with impossible geometry (issue 9, bad-input matrix: scenarios).

Each is one ConfigError line naming the file, the dotted key and what is wrong, before pybullet starts;
`mission run --scenario` exits 2 with that line.

Already covered in test_scenario.py: a robot inside an obstacle, a waypoint outside the room, a target
inside an unknown obstacle, a marker id outside its dictionary, a marker too big for its face, and bad
keys in a config's sim: section.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from mission.cli import main
from mission.core.errors import ConfigError
from mission.sim.scenario import load_scenario, scenario_from_dict

CRATE = {"name": "crate", "shape": "box", "x": 4.0, "y": 4.0, "yaw_deg": 45, "size": [1.0, 0.4, 0.5]}

CASES = {
    # name: (scenario keys over {"name": "x"}, "key: message start")
    "robot half inside a wall": (
        {"robot": {"x": 0.1, "y": 3.0}},
        "robot: (0.1, 3) is outside the room [0, 8] × [0, 8] (with 0.22 m clearance)",
    ),
    "robot inside a rotated box": (
        {"robot": {"x": 4.3, "y": 4.3}, "obstacles": [CRATE]},
        "robot: (4.3, 4.3) is inside crate (needs 0.22 m clearance)",
    ),
    "robot grazing a pillar": (
        {"robot": {"x": 2.0, "y": 2.0}, "obstacles": [{"shape": "cylinder", "x": 2.3, "y": 2.0, "radius": 0.15}]},
        "robot: (2, 2) is too close to obstacles[0] (needs 0.22 m clearance)",
    ),
    "target on top of the robot": (
        {"robot": {"x": 2.0, "y": 2.0}, "target": {"x": 2.3, "y": 2.0}},
        "target: target starts on top of the robot",
    ),
    "target waypoint through an obstacle": (
        {"obstacles": [CRATE], "target": {"x": 3.0, "y": 1.0, "waypoints": [{"x": 6, "y": 1}, {"x": 4, "y": 4}]}},
        "target.waypoints[1]: (4, 4) is inside crate",
    ),
    "target waypoint beyond a wall": (
        {"target": {"x": 3.0, "y": 1.0, "waypoints": [{"x": 3.0, "y": -2.0}]}},
        "target.waypoints[0]: (3, -2) is outside the room",
    ),
    "obstacle outside the room": (
        {"obstacles": [{"x": 12.0, "y": 3.0}]},
        "obstacles[0]: (12, 3) is outside the room",
    ),
    "flat box obstacle": (
        {"obstacles": [{"x": 5.0, "y": 5.0, "size": [0.5, 0.0, 1.0]}]},
        "obstacles[0].size: box size must be > 0, got [0.5, 0.0, 1.0]",
    ),
    "room too small": ({"room": {"size": [0.4, 8.0]}}, "room: room size must be > 0.5 m per side, got [0.4, 8.0]"),
    "dock in mid-room": (
        {"dock": {"x": 4.0, "y": 3.0, "yaw_deg": 0}},
        "dock: (4, 3) is 3.00 m from the nearest wall (y = 0); a dock tag hangs on a wall: "
        "expected x in {0, 8} or y in {0, 8} (±0.05 m)",
    ),
    "dock outside the room": ({"dock": {"x": -1.0, "y": 4.0, "yaw_deg": 0}}, "dock: (-1, 4) is outside the room"),
    "dock facing the wall": (
        {"dock": {"x": 8.0, "y": 4.0, "yaw_deg": 0}},
        "dock.yaw_deg: 0° turns the tag 180° away from facing into the room (it hangs on the wall at x = 8); "
        "expected about 180°",
    ),
    "dock facing along the wall": (
        {"dock": {"x": 5.0, "y": 0.0, "yaw_deg": 0}},
        "dock.yaw_deg: 0° turns the tag 90° away from facing into the room (it hangs on the wall at y = 0)",
    ),
    "dock blocked by a shelf": (
        {
            "dock": {"x": 0.0, "y": 4.0, "yaw_deg": 0},
            "obstacles": [{"name": "shelf", "x": 0.3, "y": 4.0, "size": [0.4, 1.2, 1.0]}],
        },
        "dock: no room to dock: the docked robot at (0.47, 4.00), 0.47 m in front of the tag, is inside shelf",
    ),
    "camera far before near": ({"camera": {"near_m": 2.0, "far_m": 1.0}}, "camera.far_m: far_m must be greater"),
    "lidar max before min": (
        {"lidar": {"range_min_m": 5.0, "range_max_m": 4.0}},
        "lidar.range_max_m: range_max_m must be greater than range_min_m",
    ),
    "unknown dock dictionary": (
        {"dock": {"x": 0.0, "y": 4.0, "yaw_deg": 0, "dictionary": "DICT_9X9_50"}},
        "dock.dictionary: unknown dictionary 'DICT_9X9_50'; expected one of DICT_4X4_100, ",
    ),
    "an AprilTag family name where a dictionary goes": (
        {"target": {"markers": [{"dictionary": "tag36h11"}]}},
        "target.markers[0].dictionary: unknown dictionary 'tag36h11'; expected one of ",
    ),
    "target and dock with one code": (
        {"target": {"x": 3.0, "y": 3.0}, "dock": {"x": 0.0, "y": 4.0, "yaw_deg": 0, "id": 7}},
        "target.markers[0].id: id 7 of DICT_APRILTAG_36h11 is also the dock's; expected distinct codes",
    ),
    "NaN robot position": ({"robot": {"x": ".nan"}}, "robot.x: input should be a finite number, got nan"),
}


def scenario_file(tmp_path: Path, keys: dict) -> Path:
    text = yaml.safe_dump({"name": "x", **keys}).replace("'.nan'", ".nan")
    path = tmp_path / "impossible.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("case", list(CASES))
def test_impossible_geometry_is_one_line_naming_the_file_and_key(tmp_path, case):
    keys, tail = CASES[case]
    path = scenario_file(tmp_path, keys)
    with pytest.raises(ConfigError) as err:
        load_scenario(str(path))
    message = str(err.value)
    assert message.startswith(f"{path}: {tail}"), message
    assert "\n" not in message


@pytest.mark.parametrize(
    "dock",
    [
        {"x": 0.0, "y": 4.0, "yaw_deg": 0},
        {"x": 8.0, "y": 4.0, "yaw_deg": 180},
        {"x": 5.0, "y": 0.0, "yaw_deg": 90},
        {"x": 5.0, "y": 8.0, "yaw_deg": -90},
        {"x": 0.03, "y": 6.0, "yaw_deg": 30},  # 3 cm off the wall, 30° off square: still a dock
    ],
)
def test_a_dock_on_any_wall_facing_into_the_room_is_fine(dock):
    assert scenario_from_dict({"name": "x", "dock": dock}).dock is not None


def test_mission_run_with_an_impossible_scenario_exits_2_with_only_that_line(tmp_path, capsys):
    path = scenario_file(tmp_path, CASES["dock in mid-room"][0])
    assert main(["run", "--scenario", str(path), "--quiet", "--max-duration", "1"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    [line] = captured.err.splitlines()
    assert line.startswith(f"mission: error: {path}: dock: (4, 3) is 3.00 m from the nearest wall")
