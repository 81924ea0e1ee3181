"""Bad mission config files (issue 9, bad-input matrix: malformed, unknown-key and wrong-type YAML).

Each stops start-up with one line naming the file, the line or dotted key, and what was expected; through
`mission run` that line is all stderr says and the exit code is 2, before any world is started.

Already covered in test_config.py: an empty file, a missing file, an unknown key, a wrong type, an
out-of-range value, unbalanced brackets and a top-level list; in tests/perception/test_plugins_registry.py a bad plugin
param through `mission run`.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from mission.app.runner import TreeRunner
from mission.cli import main
from mission.core.config import MissionConfig, load_config
from mission.core.errors import ConfigError, TreeError

CASES = {
    # name: (file content, the message after "<file>: ")
    "duplicate section": (
        "run: {tick_hz: 5}\nperception: {policy: all}\nrun: {tick_hz: 30}\n",
        "line 3: invalid YAML: duplicate key 'run' (first given at line 1)",
    ),
    "duplicate nested key": (
        "perception:\n  sources:\n    - plugin: aruco\n      plugin: apriltag\n",
        "line 4: invalid YAML: duplicate key 'plugin' (first given at line 3)",
    ),
    "tab indentation": (
        "run:\n\ttick_hz: 5\n",
        "line 2: invalid YAML: found character '\\t' that cannot start any token",
    ),
    "python object tag": (
        '!!python/object/apply:os.system ["true"]\n',
        "line 1: invalid YAML: could not determine a constructor for the tag "
        "'tag:yaml.org,2002:python/object/apply:os.system'",
    ),
    "NaN rate": ("run: {tick_hz: .nan}\n", "run.tick_hz: input should be a finite number, got nan"),
    "infinite rate": ("run: {tick_hz: .inf}\n", "run.tick_hz: input should be a finite number, got inf"),
    "sources not a list": (
        "perception:\n  sources: aruco\n",
        "perception.sources: input should be a valid list, got 'aruco'",
    ),
    "source without plugin": (
        "perception:\n  sources:\n    - {name: front}\n",
        "perception.sources[0].plugin: required key is missing",
    ),
    "unknown key in the second source": (
        "perception:\n  sources:\n    - plugin: aruco\n    - plugin: apriltag\n      param: {}\n",
        "perception.sources[1].param: unknown key (did you mean params?)",
    ),
    "target not a mapping": (
        "perception:\n  targets:\n    target: 7\n",
        "perception.targets.target: input should be a valid dictionary or instance of TargetSpec, got 7",
    ),
    "target id not an int": (
        "perception:\n  targets:\n    target: {marker_id: seven}\n",
        "perception.targets.target.marker_id: input should be a valid integer, unable to parse string as an integer, "
        "got 'seven'",
    ),
    "target of an unconfigured source": (
        "perception:\n  targets:\n    target: {marker_id: 7, source: vlm}\n",
        "perception.targets.target.source: no perception source named 'vlm'; configured sources: aruco",
    ),
    "two targets alike": (
        "perception:\n  targets:\n    target: {marker_id: 7}\n    person: {marker_id: 7}\n",
        "perception.targets.person: looks exactly like target 'target'; expected a marker_id, label or source that "
        "tells them apart",
    ),
    "negative marker id": (
        "perception:\n  targets:\n    target: {marker_id: -1}\n",
        "perception.targets.target.marker_id: input should be greater than or equal to 0, got -1",
    ),
    "unknown policy": (
        "perception: {policy: best}\n",
        "perception.policy: input should be 'all' or 'hybrid', got 'best'",
    ),
    "sim not a mapping": ("sim: [1, 2]\n", "sim: input should be a valid dictionary, got [1, 2]"),
    "a scalar file": ("42\n", "expected a mapping, got int"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_bad_config_is_one_line_naming_the_file_and_where(tmp_path, case):
    text, tail = CASES[case]
    path = tmp_path / "robot.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert str(err.value) == f"{path}: {tail}"


def test_a_binary_file_is_named_with_why_it_cannot_be_read(tmp_path):
    path = tmp_path / "robot.yaml"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\x00\xff")
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert str(err.value).startswith(f"{path}: cannot read: 'utf-8' codec can't decode byte 0x89")


def test_a_directory_is_not_a_config_file(tmp_path):
    with pytest.raises(ConfigError) as err:
        load_config(tmp_path)
    assert str(err.value) == f"{tmp_path}: not a file"


def test_a_named_source_satisfies_a_target_that_names_it(tmp_path):
    path = tmp_path / "robot.yaml"
    path.write_text(
        "perception:\n  sources:\n    - {plugin: aruco, name: front}\n"
        "  targets:\n    target: {marker_id: 7, source: front}\n"
    )
    assert load_config(path).perception.targets["target"].source == "front"


def test_a_tree_the_config_names_that_does_not_exist_names_the_config_file_and_key(tmp_path):
    path = tmp_path / "robot.yaml"
    path.write_text("tree: folow.xml\n")
    runner = TreeRunner(load_config(path), world=None, config_file=path)  # type: ignore[arg-type]
    with pytest.raises(TreeError) as err:
        runner.setup()  # fails on the tree, before the (absent) world is touched
    assert str(err.value).startswith(f"{path}: tree: folow.xml: tree file not found; expected a path to a ")
    shipped = str(err.value).split("or a shipped tree: ", 1)[1].split(", ")
    assert {"dock.xml", "follow.xml", "mission.xml"} <= set(shipped)  # what the user could have meant


@pytest.mark.parametrize(
    ("text", "tail"),
    [
        ("run: {tick_hz: 5}\nrun: {tick_hz: 6}\n", "line 2: invalid YAML: duplicate key 'run' (first given at line 1)"),
        ("perception:\n  sources:\n    - plugin: arucoo\n",
         "perception.sources[0].plugin: unknown perception plugin 'arucoo'; "
         "known plugins: apriltag, aruco, external_pose, vlm, vlm_stub"),
        ("tree: nowhere.xml\n", "tree: nowhere.xml: tree file not found"),
        ("perception:\n  targets:\n    target: {marker_id: 7, source: vlm}\n",
         "perception.targets.target.source: no perception source named 'vlm'"),
    ],
)  # fmt: skip
def test_mission_run_with_a_bad_config_exits_2_with_only_that_line(tmp_path, capsys, text, tail):
    path = tmp_path / "robot.yaml"
    path.write_text(text)
    assert main(["run", "--config", str(path), "--quiet", "--max-duration", "1"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    [line] = captured.err.splitlines()
    assert line.startswith(f"mission: error: {path}: {tail}")


def test_defaults_are_still_a_valid_config():
    assert MissionConfig().run.tick_hz == 15.0 and Path(MissionConfig().tree).suffix == ".xml"


SEVERAL = """\
run:
  tick_hzz: 10
perception:
  policy: best
  targets:
    target: {marker_idd: 7}
"""


def test_a_config_with_several_problems_lists_every_one_on_its_own_line(tmp_path, capsys):
    path = tmp_path / "robot.yaml"
    path.write_text(SEVERAL)
    assert main(["run", "--config", str(path), "--quiet", "--max-duration", "1"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.splitlines() == [
        f"mission: error: {path}: perception.policy: input should be 'all' or 'hybrid', got 'best'",
        f"mission: error: {path}: perception.targets.target.marker_idd: unknown key (did you mean marker_id?)",
        f"mission: error: {path}: run.tick_hzz: unknown key (did you mean tick_hz?)",
    ]


@pytest.mark.parametrize(
    ("text", "tail"),
    [
        ("run: {tick_hzz: 10}\n", "run.tick_hzz: unknown key (did you mean tick_hz?)"),
        ("perceptoin: {}\n", "perceptoin: unknown key (did you mean perception?)"),
        ("perception:\n  sources:\n    - {plugin: aruco, nmae: front}\n",
         "perception.sources[0].nmae: unknown key (did you mean name?)"),
        ("perception:\n  targets:\n    dock: {lable: charger}\n",
         "perception.targets.dock.lable: unknown key (did you mean label?)"),
        ("run: {colour: red}\n", "run.colour: unknown key"),  # nothing near: no guess
        ('run: {"tick\\nhz": 10}\n', "run.'tick\\nhz': unknown key (did you mean tick_hz?)"),  # still one line
    ],
)  # fmt: skip
def test_an_unknown_key_suggests_the_nearest_key_accepted_at_that_place(tmp_path, text, tail):
    path = tmp_path / "robot.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert str(err.value).splitlines() == [f"{path}: {tail}"]


def test_a_misspelt_plugin_param_suggests_the_plugins_own_param(tmp_path, capsys):
    path = tmp_path / "robot.yaml"
    path.write_text("perception:\n  sources:\n    - plugin: aruco\n      params: {marker_sise_m: 0.1, dictionry: x}\n")
    assert main(["run", "--config", str(path), "--quiet", "--max-duration", "1"]) == 2
    params = f"mission: error: {path}: perception.sources[0].params"
    assert capsys.readouterr().err.splitlines() == [
        f"{params}.marker_sise_m: unknown key (did you mean marker_size_m?)",
        f"{params}.dictionry: unknown key (did you mean dictionary?)",
    ]


def test_every_cross_key_problem_is_listed(tmp_path):
    path = tmp_path / "robot.yaml"
    path.write_text(
        "perception:\n  targets:\n    target: {marker_id: 7, source: vlm}\n    person: {marker_id: 0}\n"
        "    dock: {marker_id: 0}\n"
    )
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert str(err.value).splitlines() == [
        f"{path}: perception.targets.target.source: no perception source named 'vlm'; configured sources: aruco",
        f"{path}: perception.targets.dock: looks exactly like target 'person'; expected a marker_id, label or source "
        "that tells them apart",
    ]
