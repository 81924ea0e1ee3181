"""A scenario names the config it runs with (its `config` key), so `mission run --scenario vlm_discovery`, a
sweep and a bench run it with the VLM without being told; a `--config` given still wins."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from mission.app.shipped import shipped_config
from mission.app.sim_run import prepare_run
from mission.core.errors import ConfigError
from mission.sim.scenario import scenario_path


def plugins(run) -> list[str]:
    return [s.plugin for s in run.config.perception.sources]


def test_vlm_discovery_runs_with_the_vlm_when_no_config_is_given():
    run = prepare_run("vlm_discovery")
    assert run.config_path == shipped_config("sim_vlm.yaml")
    assert "vlm" in plugins(run) and run.config.perception.policy == "hybrid"


def test_a_scenario_without_a_config_key_runs_with_the_shipped_sim_config():
    assert "vlm" not in plugins(prepare_run("follow_open"))


def test_a_config_given_on_the_command_line_wins_over_the_scenarios():
    run = prepare_run("vlm_discovery", config_file=shipped_config("sim_aruco.yaml"))
    assert plugins(run) == ["aruco"]


def test_a_config_file_beside_the_scenario_is_found_by_its_name(tmp_path: Path):
    scenario = yaml.safe_load(scenario_path("follow_open").read_text())
    (tmp_path / "slow_ticks.yaml").write_text("run: {tick_hz: 10}\n")
    path = tmp_path / "mine.yaml"
    path.write_text(yaml.safe_dump({**scenario, "config": "slow_ticks.yaml"}))
    run = prepare_run(str(path))
    assert run.config_path == tmp_path / "slow_ticks.yaml" and run.config.run.tick_hz == 10


def test_a_config_that_is_neither_beside_the_scenario_nor_shipped_names_the_file_and_key(tmp_path: Path):
    scenario = yaml.safe_load(scenario_path("follow_open").read_text())
    path = tmp_path / "mine.yaml"
    path.write_text(yaml.safe_dump({**scenario, "config": "sim_vml.yaml"}))
    with pytest.raises(ConfigError) as err:
        prepare_run(str(path))
    assert str(err.value).startswith(f"{path}: config: 'sim_vml.yaml' is neither a file beside the scenario nor a")
    assert "sim_vlm.yaml" in str(err.value)
