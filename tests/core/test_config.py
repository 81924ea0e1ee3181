"""Config files: a good file gives a validated object; a bad one gives one line naming file and key."""

from __future__ import annotations

import pytest

from mission.core.config import MissionConfig, load_config
from mission.core.errors import ConfigError


def write(tmp_path, text: str):
    p = tmp_path / "config.yaml"
    p.write_text(text)
    return p


def test_empty_file_gives_the_defaults(tmp_path):
    cfg = load_config(write(tmp_path, ""))
    assert cfg == MissionConfig()
    assert cfg.perception.sources[0].plugin == "aruco"


def test_no_file_gives_the_defaults():
    assert load_config(None).run.tick_hz == 15.0


def test_unknown_key_names_file_and_dotted_key(tmp_path):
    p = write(tmp_path, "perception:\n  sources:\n    - plugin: aruco\n      parms: {}\n")
    with pytest.raises(ConfigError) as e:
        load_config(p)
    msg = str(e.value)
    assert msg == f"{p}: perception.sources[0].parms: unknown key (did you mean params?)"
    assert "\n" not in msg


def test_wrong_type_names_key_and_value(tmp_path):
    p = write(tmp_path, "run:\n  tick_hz: fast\n")
    with pytest.raises(ConfigError, match=r"run\.tick_hz: .*got 'fast'"):
        load_config(p)


def test_out_of_range_value_is_rejected(tmp_path):
    with pytest.raises(ConfigError, match=r"run\.tick_hz: input should be greater than 0"):
        load_config(write(tmp_path, "run: {tick_hz: -1}\n"))


def test_missing_file_is_named(tmp_path):
    with pytest.raises(ConfigError, match=r"nope\.yaml: file not found"):
        load_config(tmp_path / "nope.yaml")


def test_malformed_yaml_gives_the_line(tmp_path):
    with pytest.raises(ConfigError, match=r"config\.yaml: line \d+: invalid YAML"):
        load_config(write(tmp_path, "run:\n  tick_hz: [1,\n"))


def test_top_level_list_is_rejected(tmp_path):
    with pytest.raises(ConfigError, match="expected a mapping, got list"):
        load_config(write(tmp_path, "- a\n- b\n"))
