"""Unknown and broken perception plugins (issue 9, bad-input matrix: plugins).

An unknown name or a plugin that cannot be imported or constructed stops start-up with one line naming
the config file and key; `mission plugins` still lists every other plugin.

Already covered: an unknown --source to `mission detect` (tests/cli/test_detect_cli.py), an unknown plugin without
a file (test_plugins_registry.py), a bad plugin param (every source's own tests), and a source that raises
or returns junk while the tree runs (test_perception_stage.py).
"""

from __future__ import annotations

from importlib.metadata import EntryPoint

import pytest

from mission.cli import main
from mission.core.config import SourceConfig
from mission.core.errors import ConfigError, PluginError
from mission.core.perception import ENTRY_POINT_GROUP
from mission.perception_plugins import registry


class ExplodingSource:
    """A third-party source whose constructor fails its own way (not with a ConfigError)."""

    description = "fails to construct"

    def __init__(self, params: dict, name: str = "exploding") -> None:
        raise RuntimeError("cannot open /dev/npu0:\n  device busy")


@pytest.fixture
def extra_plugins(monkeypatch):
    """Two more installed plugins: one whose module does not exist, one whose constructor raises."""
    shipped = registry._entry_points()

    def with_extras() -> dict[str, EntryPoint]:
        extras = {
            "ghost": EntryPoint("ghost", "no_such_package.source:GhostSource", ENTRY_POINT_GROUP),
            "exploding": EntryPoint("exploding", f"{__name__}:ExplodingSource", ENTRY_POINT_GROUP),
        }
        return {**shipped, **extras}

    monkeypatch.setattr(registry, "_entry_points", with_extras)


def test_an_unknown_plugin_in_a_config_names_the_file_the_key_and_the_known_ones():
    cfgs = [SourceConfig(plugin="aruco"), SourceConfig(plugin="april_tag")]
    with pytest.raises(PluginError) as err:
        registry.create_all(cfgs, file="robot.yaml")
    assert str(err.value) == (
        "robot.yaml: perception.sources[1].plugin: unknown perception plugin 'april_tag'; "
        "known plugins: apriltag, aruco, external_pose, vlm, vlm_stub"
    )


def test_a_plugin_whose_module_is_missing_is_one_line_naming_it(extra_plugins):
    with pytest.raises(PluginError) as err:
        registry.create_all([SourceConfig(plugin="ghost")], file="robot.yaml")
    message = str(err.value)
    assert message.startswith(
        "robot.yaml: perception.sources[0].plugin: perception plugin 'ghost' "
        "(no_such_package.source:GhostSource) failed to load: No module named 'no_such_package'"
    )
    assert "\n" not in message


def test_a_plugin_whose_constructor_raises_is_one_line_not_a_traceback(extra_plugins, tmp_path, capsys):
    with pytest.raises(PluginError) as err:
        registry.create_all([SourceConfig(plugin="exploding")], file="robot.yaml")
    assert str(err.value) == (
        "robot.yaml: perception.sources[0].plugin: perception plugin 'exploding' could not be created: "
        "RuntimeError: cannot open /dev/npu0: device busy"
    )
    config = tmp_path / "robot.yaml"
    config.write_text("perception:\n  sources:\n    - plugin: exploding\n")
    assert main(["run", "--config", str(config), "--quiet", "--max-duration", "1"]) == 2
    [line] = capsys.readouterr().err.splitlines()
    assert line.startswith(f"mission: error: {config}: perception.sources[0].plugin: perception plugin 'exploding'")


def test_sources_made_before_a_failing_one_are_closed(extra_plugins, monkeypatch):
    closed = []
    original = registry.load_class("aruco")

    class Tracked(original):  # the real aruco source, noting when it is closed
        def close(self) -> None:
            closed.append(self.name)
            super().close()

    real_load = registry.load_class
    monkeypatch.setattr(registry, "load_class", lambda name: Tracked if name == "aruco" else real_load(name))
    with pytest.raises(PluginError):
        registry.create_all([SourceConfig(plugin="aruco"), SourceConfig(plugin="exploding")])
    assert closed == ["aruco"]


def test_mission_plugins_lists_the_broken_ones_with_why_and_every_other_one(extra_plugins, capsys):
    assert main(["plugins"]) == 0
    lines = {line.split()[0]: line for line in capsys.readouterr().out.splitlines()}
    assert {"aruco", "apriltag", "vlm", "vlm_stub", "ghost", "exploding"} <= set(lines)
    assert "BROKEN: ModuleNotFoundError: No module named 'no_such_package'" in lines["ghost"]
    assert "BROKEN" not in lines["aruco"] and "BROKEN" not in lines["exploding"]  # importable: listed normally


@pytest.mark.parametrize(
    ("where", "why"),
    [("a directory", "Is a directory"), ("under a file", "Not a directory: {blocker}")],
)
def test_a_vlm_state_file_that_cannot_be_saved_is_a_start_up_error_naming_the_key(tmp_path, where, why):
    """Calls are recorded before they are made: an unsaveable budget would stop every call, silently."""
    blocker = tmp_path / "blocker"
    if where == "a directory":
        state = tmp_path / "quota.json"
        state.mkdir()
    else:
        blocker.write_text("")
        state = blocker / "quota.json"
    cfg = SourceConfig(plugin="vlm", params={"state_file": str(state)})
    with pytest.raises(ConfigError) as err:
        registry.create_all([cfg], file="robot.yaml")
    assert str(err.value) == (
        f"robot.yaml: perception.sources[0].params.state_file: cannot save the call budget to {state} "
        f"({why.format(blocker=blocker)}); expected a writable file path"
    )
    assert not any(p.name.endswith(".probe") for p in tmp_path.rglob("*"))


def test_a_writable_vlm_state_file_is_left_as_it_was_by_the_start_up_check(tmp_path):
    state = tmp_path / "quota.json"
    state.write_text('{"day": "2023-11-14", "calls_today": 3, "last_call": 1.0}')
    [src] = registry.create_all([SourceConfig(plugin="vlm", params={"state_file": str(state)})])
    src.close()
    assert state.read_text() == '{"day": "2023-11-14", "calls_today": 3, "last_call": 1.0}'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["quota.json"]
