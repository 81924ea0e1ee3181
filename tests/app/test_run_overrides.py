"""`--set KEY=VALUE`: which part of a run a key changes, and that the run is built with the value."""

from __future__ import annotations

import pytest

from mission.app.overrides import parse_setting, run_overrides, split_values
from mission.app.sim_run import check_prepared, prepare_run
from mission.core.errors import ConfigError


@pytest.mark.parametrize(
    ("text", "kind", "values"),
    [
        ("SearchSweep.angular_speed=0.6,1.0", "port", [0.6, 1.0]),
        ("run.tick_hz=10,15", "config", [10, 15]),
        ("perception.targets.dock.marker_id=3", "config", [3]),
        ("camera={width: 320, height: 240},{width: 640}", "scenario", [{"width": 320, "height": 240}, {"width": 640}]),
        ("sim.lighting.image_noise_sigma=0,4", "scenario", [0, 4]),
        ("target.waypoints=[{x: 6, y: 2}, {x: 6, y: 6}]", "scenario", [[{"x": 6, "y": 2}, {"x": 6, "y": 6}]]),
    ],
)
def test_a_keys_first_part_says_what_it_changes_and_values_are_yaml(text, kind, values):
    _, settings = parse_setting(text, many=True)
    assert [s.kind for s in settings] == [kind] * len(values)
    assert [s.value for s in settings] == values


def test_commas_inside_brackets_braces_or_quotes_belong_to_the_value():
    assert split_values("[1, 2],'a,b',{x: 1, y: 2},3") == ["[1, 2]", "'a,b'", "{x: 1, y: 2}", "3"]


def test_the_run_is_prepared_with_every_kind_of_setting():
    overrides = run_overrides(
        [
            "run.tick_hz=10",
            "camera.width=320",
            "sim.camera.height=240",
            "perception.policy=all",
            "PursueLastSeen.look_s=2",
        ]
    )
    run = prepare_run("follow_open", overrides=overrides)
    assert run.config.run.tick_hz == 10 and run.config.perception.policy == "all"
    assert (run.scenario.camera.width, run.scenario.camera.height) == (320, 240)
    assert run.scenario.camera.vfov_deg == 60.0  # a mapping merges: the rest of the section stays
    assert run.tree == "follow.xml"  # the scenario still chooses the tree: a config override sets only its keys
    assert "PursueLastSeen" in check_prepared(run)


def test_a_config_tree_set_on_the_command_line_wins_over_the_scenarios():
    run = prepare_run("follow_open", overrides=run_overrides(["tree=mission.xml"]))
    assert run.tree == "mission.xml"


@pytest.mark.parametrize(
    ("text", "line"),
    [
        ("run.tick_hz=0", "--set: run.tick_hz: input should be greater than 0, got 0"),
        ("camera.width=8", "--set: camera.width: input should be greater than or equal to 16, got 8"),
        ("robot.x=40", "--set: robot: (40, 2) is outside the room"),
    ],
)
def test_a_value_the_schema_refuses_names_the_key_as_given(text, line):
    with pytest.raises(ConfigError) as err:
        prepare_run("follow_open", overrides=run_overrides([text]))
    assert str(err.value).startswith(line)


def test_a_key_given_twice_or_without_a_value_is_an_error():
    with pytest.raises(ConfigError, match=r"run\.tick_hz: given twice"):
        run_overrides(["run.tick_hz=10", "run.tick_hz=15"])
    with pytest.raises(ConfigError, match=r"expected KEY=VALUE, got 'run\.tick_hz'"):
        run_overrides(["run.tick_hz"])


def test_the_report_trees_show_a_port_as_the_run_set_it_not_as_the_file_writes_it():
    import py_trees

    from mission.trees.factory import shipped_factory
    from mission.trees.loader import load_tree, resolve_tree_path
    from mission.viz.probe import static_tree

    factory = shipped_factory()
    factory.set_port("SearchBelief", "timeout_s", 7.5)  # follow.xml writes timeout_s="25"
    root = load_tree("follow.xml", factory)
    py_trees.trees.BehaviourTree(root)
    drawn = static_tree(root, resolve_tree_path("follow.xml"), factory)
    search = next(n for n in drawn.walk() if n.type == "SearchBelief")
    assert search.ports["timeout_s"] == "7.5"
