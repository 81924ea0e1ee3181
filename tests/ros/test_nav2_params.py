"""A Nav2 user's docking_server / following_server params, read by Nav2's names with Nav2's defaults and
meanings (issue 32): the dock database from `docks` or `dock_database`, dock types from `dock_plugins`, the
staging pose `staging_x_offset` along the docked heading, a dock id not in the database unknown."""

from __future__ import annotations

import math
import textwrap

import pytest

from mission.core.errors import ConfigError
from mission.ros.nav2_params import (
    DockingParams,
    FollowingParams,
    docking_params,
    following_params,
    read_params_file,
)

# As a Nav2 user writes it (the shape of nav2_bringup's docking_server section)
NAV2_DOCKING = """\
docking_server:
  ros__parameters:
    controller_frequency: 50.0
    initial_perception_timeout: 5.0
    wait_charge_timeout: 5.0
    dock_approach_timeout: 30.0
    undock_linear_tolerance: 0.05
    undock_angular_tolerance: 0.1
    max_retries: 2
    base_frame: "base_link"
    fixed_frame: "odom"
    dock_backwards: false
    dock_prestaging_tolerance: 0.5

    dock_plugins: ['simple_charging_dock']
    simple_charging_dock:
      plugin: 'opennav_docking::SimpleChargingDock'
      docking_threshold: 0.05
      staging_x_offset: -0.7
      use_external_detection_pose: true
      use_battery_status: false
      use_stall_detection: false
      external_detection_timeout: 1.0
      external_detection_translation_x: -0.18
      external_detection_translation_y: 0.0
      external_detection_rotation_roll: -1.57
      external_detection_rotation_pitch: -1.57
      external_detection_rotation_yaw: 0.0
      filter_coef: 0.1

    docks: ['home_dock', 'lab_dock']
    home_dock:
      type: 'simple_charging_dock'
      frame: map
      pose: [0.0, 4.0, 1.5708]
    lab_dock:
      type: 'simple_charging_dock'
      pose: [5.0, 0.0, 0]
      id: "7"

    controller:
      k_phi: 3.0
      k_delta: 2.0
      v_linear_min: 0.15
      v_linear_max: 0.15
"""


def write(tmp_path, text, name="nav2_params.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_a_nav2_docking_section_reads_as_nav2_reads_it(tmp_path):
    path = write(tmp_path, NAV2_DOCKING)
    p = docking_params(read_params_file(path, "docking_server"), file=str(path))
    assert (p.max_retries, p.undock_angular_tolerance, p.dock_approach_timeout) == (2, 0.1, 30.0)
    [kind] = p.dock_types.values()
    assert (kind.name, kind.staging_x_offset, kind.use_external_detection_pose) == ("simple_charging_dock", -0.7, True)
    assert kind.external_detection_translation_x == -0.18
    assert kind.staging_yaw_offset == 0.0  # not in the file: SimpleChargingDock's default
    home = p.find_dock("home_dock")
    assert (home.x, home.y, home.frame, home.id) == (0.0, 4.0, "map", "")
    lab = p.find_dock("lab_dock")
    assert (lab.frame, lab.id) == ("map", "7")  # frame defaults to map, as in parseDockParams
    assert p.find_dock("kitchen") is None  # the goal's DOCK_NOT_IN_DB


def test_the_staging_pose_lies_staging_x_offset_along_the_docked_heading(tmp_path):
    path = write(tmp_path, NAV2_DOCKING)
    p = docking_params(read_params_file(path, "docking_server"))
    home = p.find_dock("home_dock")  # docked facing +y (yaw 90°) at (0, 4)
    x, y, yaw = home.staging_pose(p.find_type(home.type))
    assert (x, y, yaw) == pytest.approx((0.0, 3.3, 1.5708), abs=1e-4)  # 0.7 m behind it, same heading
    turned = p.dock_types["simple_charging_dock"].__class__("t", staging_x_offset=-1.0, staging_yaw_offset=math.pi)
    assert home.staging_pose(turned) == pytest.approx((0.0, 3.0, 1.5708 - math.pi), abs=1e-4)


def test_defaults_are_nav2s_when_a_section_sets_nothing(tmp_path):
    path = write(tmp_path, "docking_server:\n  ros__parameters: {dock_plugins: [d], docks: []}\n")
    p = docking_params(read_params_file(path, "docking_server"))
    assert (p.max_retries, p.initial_perception_timeout, p.dock_prestaging_tolerance) == (3, 5.0, 0.5)
    assert p.dock_types["d"].staging_x_offset == -0.7 and p.dock_types["d"].docking_threshold == 0.05
    assert following_params({}) == FollowingParams()
    assert FollowingParams().search_angle == pytest.approx(math.pi / 2) and not FollowingParams().search_by_rotating
    assert DockingParams().find_type("") is None  # no dock types at all


def test_the_wildcard_section_applies_and_the_nodes_own_section_wins(tmp_path):
    path = write(
        tmp_path,
        """\
        /**:
          ros__parameters: {max_retries: 5, desired_distance: 1.5}
        following_server:
          ros__parameters: {desired_distance: 0.8, search_by_rotating: true}
    """,
    )
    f = following_params(read_params_file(path, "following_server"))
    assert (f.max_retries, f.desired_distance, f.search_by_rotating) == (5, 0.8, True)


def test_a_dock_database_file_relative_to_the_params_file(tmp_path):
    (tmp_path / "docks.yaml").write_text(
        textwrap.dedent("""\
        docks:
          charger:
            type: ""
            pose: [1.0, 2.0, 3.14159]
            id: "0"
    """)
    )
    path = write(
        tmp_path, "docking_server:\n  ros__parameters:\n    dock_plugins: [only]\n    dock_database: docks.yaml\n"
    )
    p = docking_params(read_params_file(path, "docking_server"), file=str(path))
    charger = p.find_dock("charger")
    assert (charger.x, charger.y, charger.id) == (1.0, 2.0, "0")
    assert p.find_type(charger.type).name == "only"  # '' with a single dock type is that type, as in Nav2


@pytest.mark.parametrize(
    ("edit", "key", "message"),
    [
        (("pose: [0.0, 4.0, 1.5708]", "pose: [0.0, 4.0]"), "home_dock.pose",
         "expected [x, y, yaw], got [0.0, 4.0]"),
        (("type: 'simple_charging_dock'\n      frame: map", "frame: map"), "home_dock.type",
         "expected the dock's 'type'"),
        (("type: 'simple_charging_dock'\n      pose: [5.0", "type: 'charger_v2'\n      pose: [5.0"), "lab_dock.type",
         "dock type 'charger_v2' is not in dock_plugins; known: simple_charging_dock"),
        (("max_retries: 2", "max_retries: two"), "max_retries", "expected a whole number, got 'two'"),
        (("staging_x_offset: -0.7", "staging_x_offset: far"), "simple_charging_dock.staging_x_offset",
         "expected a number, got 'far'"),
    ],
)  # fmt: skip
def test_a_malformed_value_nav2_needs_is_one_line_naming_the_file_and_key(tmp_path, edit, key, message):
    old, new = edit
    assert old in NAV2_DOCKING
    path = write(tmp_path, NAV2_DOCKING.replace(old, new, 1))
    with pytest.raises(ConfigError) as err:
        docking_params(read_params_file(path, "docking_server"), file=str(path))
    assert str(err.value).startswith(f"{path}: {key}: {message}")
    assert "\n" not in str(err.value)


def test_a_near_miss_of_a_known_key_is_a_warning_and_other_keys_are_ignored(tmp_path):
    path = write(tmp_path, NAV2_DOCKING.replace("max_retries: 2", "max_retrys: 2"))
    warnings: list[str] = []
    p = docking_params(read_params_file(path, "docking_server"), warn=warnings.append)
    assert p.max_retries == 3  # the misspelt key set nothing
    assert warnings == ["parameter 'max_retrys' is not one Nav2's server reads (did you mean 'max_retries'?); ignored"]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("amcl:\n  ros__parameters: {}\n",
         "no section for this node: expected '/**' or 'docking_server', found 'amcl'"),
        ("docking_server:\n  max_retries: 3\n", "docking_server: expected 'ros__parameters:' with the parameters"),
        ("docking_server: [\n", "line 2: not YAML"),
    ],
)  # fmt: skip
def test_a_params_file_that_is_not_one_says_why(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as err:
        read_params_file(path, "docking_server")
    assert str(err.value).startswith(f"{path}: {message}")


def test_a_shipped_params_file_is_found_by_name_from_any_directory(tmp_path, monkeypatch):
    from mission.ros.nav2_params import PARAMS_DIR, resolve_params_file

    monkeypatch.chdir(tmp_path)
    assert resolve_params_file("explore_dock") == str(PARAMS_DIR / "explore_dock.yaml")
    assert resolve_params_file("explore_dock.yaml") == str(PARAMS_DIR / "explore_dock.yaml")
    (tmp_path / "explore_dock.yaml").write_text("/**: {ros__parameters: {}}\n")
    assert resolve_params_file("explore_dock.yaml") == "explore_dock.yaml"  # a file here wins
    assert resolve_params_file("nowhere.yaml") == "nowhere.yaml"  # left to read_params_file's error
    docking = docking_params(read_params_file(resolve_params_file("explore_dock"), "docking_server"))
    assert list(docking.docks) == ["home_dock"]
