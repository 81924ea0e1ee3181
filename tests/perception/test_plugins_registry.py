"""Plugins are discovered through entry points; an unknown name lists the known ones."""

from __future__ import annotations

import pytest

from mission.cli import main
from mission.core.config import SourceConfig
from mission.core.errors import PluginError
from mission.perception_plugins import registry


def test_shipped_plugins_are_registered():
    assert {"aruco", "apriltag", "vlm", "vlm_stub"} <= set(registry.known_names())


def test_unknown_plugin_lists_known_ones():
    with pytest.raises(PluginError, match=r"unknown perception plugin 'arucoo'; known plugins: .*aruco"):
        registry.create(SourceConfig(plugin="arucoo"))


def test_mission_plugins_prints_one_line_each(capsys):
    assert main(["plugins"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    names = [line.split()[0] for line in lines]
    assert {"aruco", "apriltag", "vlm", "vlm_stub"} <= set(names)
    assert not any("BROKEN" in line for line in lines)


def test_a_bad_plugin_param_in_a_config_file_is_one_line_naming_the_file_and_key(tmp_path, capsys):
    config = tmp_path / "robot.yaml"
    config.write_text("perception:\n  sources:\n    - plugin: aruco\n      params: {marker_size_m: -1}\n")
    assert main(["run", "--config", str(config), "--quiet", "--max-duration", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        f"mission: error: {config}: perception.sources[0].params.marker_size_m: input should be greater than 0, got -1"
    )
