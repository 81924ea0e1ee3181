"""Scenario files: every shipped one loads, and a bad one stops with one line naming the file and key."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from mission.core.errors import ConfigError
from mission.sim.scenario import load_scenario, scenario_from_dict, shipped_scenarios
from mission.sim.scenario_overrides import apply_overrides

ORIGINAL = ["explore_dock", "follow_occlusion", "follow_open", "mission_full", "search_corner", "vlm_discovery"]
# issue 15: worlds where turning in place cannot find the target again
SEARCH_WORLDS = ["aisle", "hide_and_wait", "moving_occluder", "target_gone", "two_rooms"]
SHIPPED = sorted(ORIGINAL + SEARCH_WORLDS)


def write(tmp_path: Path, data: dict) -> str:
    path = tmp_path / "scenario.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


def test_the_shipped_scenarios_load_by_name_with_tag36h11_markers() -> None:
    assert shipped_scenarios() == SHIPPED
    for name in SHIPPED:
        sc = load_scenario(name)
        assert sc.name == name
        assert sc.duration_s <= (150 if name == "target_gone" else 90)
        assert name in SEARCH_WORLDS or sc.room.size == (8.0, 8.0)
        if sc.target is not None:
            assert sc.target.color[0] > 0.7 > sc.target.color[1]  # red
            markers = {(m.dictionary, m.id, m.marker_size_m) for m in sc.target.markers}
            assert markers == {("DICT_APRILTAG_36h11", 7, 0.20)}
        if sc.dock is not None:
            assert (sc.dock.dictionary, sc.dock.id, sc.dock.marker_size_m) == ("DICT_APRILTAG_36h11", 0, 0.15)


def test_each_scenario_names_a_default_tree_and_success_criteria() -> None:
    expected = {
        "follow_open": ("follow.xml", "follow"),
        "follow_occlusion": ("follow.xml", "follow"),
        "search_corner": ("follow.xml", "follow"),
        "explore_dock": ("explore_dock.xml", "dock"),
        "mission_full": ("mission.xml", "mission"),
        "vlm_discovery": ("discover_follow.xml", "follow"),
    }
    for name, (tree, kind) in expected.items():
        sc = load_scenario(name)
        assert (sc.tree, sc.success.kind) == (tree, kind)


def test_a_scenario_path_loads_like_a_name(tmp_path: Path) -> None:
    path = write(tmp_path, {"name": "mine", "robot": {"x": 2.0, "y": 2.0}})
    sc = load_scenario(path)
    assert (sc.name, sc.robot.x, sc.camera.width, sc.map.resolution) == ("mine", 2.0, 640, 0.05)


def test_an_unknown_scenario_name_lists_the_shipped_ones() -> None:
    with pytest.raises(ConfigError) as err:
        load_scenario("follow_closed")
    msg = str(err.value)
    assert "unknown scenario 'follow_closed'" in msg
    for name in SHIPPED:
        assert name in msg


def test_an_unknown_key_names_the_file_and_the_dotted_key(tmp_path: Path) -> None:
    path = write(tmp_path, {"name": "x", "camera": {"widht": 320}})
    with pytest.raises(ConfigError) as err:
        load_scenario(path)
    assert str(err.value) == f"{path}: camera.widht: unknown key (did you mean width?)"


def test_a_wrong_value_names_the_key_and_what_was_expected(tmp_path: Path) -> None:
    path = write(tmp_path, {"name": "x", "camera": {"renderer": "vulkan"}})
    with pytest.raises(ConfigError) as err:
        load_scenario(path)
    assert str(err.value).startswith(f"{path}: camera.renderer: ")
    assert "'tiny' or 'egl'" in str(err.value)


def test_a_robot_starting_inside_an_obstacle_is_rejected(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        {
            "name": "x",
            "robot": {"x": 3.0, "y": 3.0},
            "obstacles": [{"name": "pillar", "shape": "cylinder", "x": 3.1, "y": 3.0, "radius": 0.3}],
        },
    )
    with pytest.raises(ConfigError) as err:
        load_scenario(path)
    assert str(err.value).startswith(f"{path}: robot: (3, 3) is inside pillar")


def test_a_waypoint_outside_the_room_names_the_waypoint() -> None:
    data = {"name": "x", "target": {"x": 3.0, "y": 3.0, "waypoints": [{"x": 4.0, "y": 3.0}, {"x": 9.5, "y": 3.0}]}}
    with pytest.raises(ConfigError) as err:
        scenario_from_dict(data, file="s.yaml")
    assert str(err.value).startswith("s.yaml: target.waypoints[1]: (9.5, 3) is outside the room")


def test_a_target_starting_inside_an_unknown_obstacle_is_rejected() -> None:
    data = {
        "name": "x",
        "target": {"x": 5.0, "y": 5.0},
        "unknown_obstacles": [{"shape": "box", "x": 5.2, "y": 5.0, "size": [0.5, 0.5, 0.5]}],
    }
    with pytest.raises(ConfigError) as err:
        scenario_from_dict(data)
    assert str(err.value).startswith("target: (5, 5) is inside unknown_obstacles[0]")


def test_a_marker_id_outside_its_dictionary_is_rejected() -> None:
    data = {"name": "x", "dock": {"x": 0.0, "y": 4.0, "yaw_deg": 0, "dictionary": "DICT_4X4_50", "id": 50}}
    with pytest.raises(ConfigError) as err:
        scenario_from_dict(data)
    assert str(err.value) == "dock.id: id 50 is not in DICT_4X4_50 (ids 0..49)"


def test_a_marker_too_big_for_its_face_is_rejected() -> None:
    data = {"name": "x", "target": {"x": 3.0, "y": 3.0, "size": [0.3, 0.3, 0.6], "markers": [{"marker_size_m": 0.25}]}}
    with pytest.raises(ConfigError) as err:
        scenario_from_dict(data)
    assert str(err.value).startswith("target.markers[0].marker_size_m: marker with quiet zone (0.312 m) does not fit")


def test_a_config_sim_section_overrides_scenario_keys_and_names_its_own_bad_keys() -> None:
    base = load_scenario("follow_open")
    sc = apply_overrides(base, {"camera": {"renderer": "egl", "width": 320, "height": 240}}, file="run.yaml")
    assert (sc.camera.renderer, sc.camera.width, sc.camera.height, sc.camera.rate_hz) == ("egl", 320, 240, 15.0)
    assert sc.target == base.target  # untouched sections stay as they were
    with pytest.raises(ConfigError) as err:
        apply_overrides(base, {"camera": {"widht": 320}}, file="run.yaml")
    assert str(err.value) == "run.yaml: sim.camera.widht: unknown key (did you mean width?)"
    with pytest.raises(ConfigError) as err:
        apply_overrides(base, {"robot": {"x": 50.0}}, file="run.yaml")
    assert str(err.value).startswith("run.yaml: sim.robot: (50, 2) is outside the room")
