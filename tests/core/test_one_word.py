"""One word for one idea: marker size is `marker_size_m`, corner refinement is `corner_refinement`, the target's
label is `label`, in every source, scenario and config. The spellings of the release before still load, for one
release, with one warning naming the new key; giving both spellings is an error. Plugins of every kind register
one way: an entry point (core/plugins.py), VLM clients included."""

from __future__ import annotations

import logging
import re
import textwrap
from pathlib import Path

import pytest

from mission.cli import main
from mission.core import config as config_module
from mission.core import plugins
from mission.core.config import SourceConfig, load_config
from mission.core.errors import ConfigError
from mission.perception_plugins import registry
from mission.perception_plugins.apriltag import AprilTagSource
from mission.perception_plugins.aruco import ArucoParams
from mission.perception_plugins.vlm.source import VlmSource
from mission.ros.node import PARAMETERS
from mission.sim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def fresh_warnings(monkeypatch, caplog):
    """Each deprecated key warns once per process; a test sees its own first warning."""
    monkeypatch.setattr(config_module, "_warned", set())
    caplog.set_level(logging.WARNING, logger="mission.core.config")
    return caplog


def deprecations(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if "deprecated" in r.getMessage()]


def test_the_apriltag_source_reads_its_old_keys_as_the_new_ones_and_says_which(fresh_warnings):
    old = AprilTagSource({"tag_size_m": 0.2, "refine_edges": False, "tags": {7: {"name": "box", "size_m": 0.1}}})
    new = AprilTagSource(
        {"marker_size_m": 0.2, "corner_refinement": "none", "tags": {7: {"name": "box", "marker_size_m": 0.1}}}
    )
    assert old.params == new.params
    assert (old.marker_size(7), old.marker_size(3)) == (0.1, 0.2)
    assert deprecations(fresh_warnings) == [
        "config key 'tag_size_m' is deprecated: use 'marker_size_m' (AprilTagParams; the old key is read until "
        "the next release)",
        "config key 'refine_edges' is deprecated: use 'corner_refinement' (AprilTagParams; the old key is read "
        "until the next release)",
        "config key 'size_m' is deprecated: use 'marker_size_m' (TagSpec; the old key is read until the next release)",
    ]


def test_a_deprecated_key_warns_once_per_run_not_once_per_source(fresh_warnings):
    for _ in range(3):
        AprilTagSource({"tag_size_m": 0.2})
    assert len(deprecations(fresh_warnings)) == 1


def test_the_vlm_source_reads_target_label_as_label(fresh_warnings, tmp_path):
    src = VlmSource({"target_label": "blue ball", "state_file": str(tmp_path / "q.json")}, name="vlm")
    assert src.params.label == "blue ball"
    src.close()
    [message] = deprecations(fresh_warnings)
    assert "'target_label' is deprecated: use 'label'" in message


def test_a_scenario_with_the_old_marker_size_key_loads_as_with_the_new_one(fresh_warnings, tmp_path):
    shipped = (ROOT / "sim" / "scenarios" / "explore_dock.yaml").read_text()
    assert "marker_size_m: 0.15" in shipped
    old = tmp_path / "old.yaml"
    old.write_text(shipped.replace("marker_size_m: 0.15", "size_m: 0.15"))
    assert load_scenario(str(old)) == load_scenario("explore_dock")
    assert "'size_m' is deprecated: use 'marker_size_m' (DockSpec;" in deprecations(fresh_warnings)[0]


def test_giving_both_spellings_is_one_line_naming_the_file_and_the_key(tmp_path):
    config = tmp_path / "robot.yaml"
    config.write_text(
        textwrap.dedent("""\
        perception:
          sources:
            - plugin: apriltag
              params: {tag_size_m: 0.2, marker_size_m: 0.2}
    """)
    )
    with pytest.raises(ConfigError) as err:
        registry.create_all(load_config(config).perception.sources, file=str(config))
    assert str(err.value) == (
        f"{config}: perception.sources[0].params: 'tag_size_m' is the old spelling of 'marker_size_m'; "
        "give only 'marker_size_m'"
    )


def test_shipped_configs_and_scenarios_use_no_deprecated_key(fresh_warnings):
    for path in sorted((ROOT / "mission" / "configs").glob("*.yaml")):
        cfg = load_config(path)
        for source in registry.create_all(cfg.perception.sources, file=str(path)):
            source.close()
    for path in sorted((ROOT / "sim" / "scenarios").glob("*.yaml")):
        load_scenario(str(path))
    assert deprecations(fresh_warnings) == []


def test_every_default_marker_size_and_dictionary_is_the_aruco_sources_own():
    """The ROS node's parameters without a config and a config without sources both use the aruco source's
    defaults; the numbers are written once, in perception_plugins/aruco.py."""
    defaults = ArucoParams()
    assert PARAMETERS["marker_size_m"][0] == defaults.marker_size_m
    assert PARAMETERS["dictionary"][0] == defaults.dictionary
    [source] = load_config(None).perception.sources
    assert source == SourceConfig(plugin="aruco")


# --- one way to register a plugin -------------------------------------------------------------------------


@pytest.fixture
def installed_package(tmp_path, monkeypatch):
    """A third-party package installed the way pip installs one: its module and a dist-info folder with
    entry_points.txt, on sys.path (importlib.metadata finds it as it finds every installed distribution)."""
    site = tmp_path / "site"
    (site / "acme_vlm").mkdir(parents=True)
    (site / "acme_vlm" / "__init__.py").write_text(
        textwrap.dedent('''\
        """A client that always answers the image centre."""
        from mission.perception_plugins.vlm.client import VlmPoint


        class CentreClient:
            def __init__(self, confidence):
                self.confidence = confidence

            def locate(self, image, label):
                return [VlmPoint(500.0, 500.0, self.confidence)]

            def close(self):
                pass


        def acme_client(params, budget):
            """Always the centre of the image (a test double of a remote model)."""
            return CentreClient(params.client_params.get("confidence", 0.9))
    ''')
    )
    info = site / "acme_vlm-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: acme-vlm\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[mission.vlm_clients]\nacme = acme_vlm:acme_client\n")
    monkeypatch.syspath_prepend(str(site))
    return site


def test_an_installed_vlm_client_is_chosen_by_its_entry_point_name(installed_package, tmp_path):
    assert "acme" in plugins.installed(plugins.VLM_CLIENTS)
    src = VlmSource(
        {"client": "acme", "client_params": {"confidence": 0.8}, "state_file": str(tmp_path / "q.json")}, name="vlm"
    )
    assert type(src._client).__name__ == "CentreClient" and src._client.confidence == 0.8
    src.close()


def test_mission_plugins_lists_every_kind_with_the_installed_client(installed_package, capsys):
    assert main(["plugins"]) == 0
    out = capsys.readouterr().out
    assert "mission.vlm_clients (a factory (params, budget) -> VlmClient):" in out
    assert re.search(r"^\s*acme\s+Always the centre of the image \(a test double of a remote model\)\.$", out, re.M)
    assert "mission.behaviours (a Behaviour class declaring its ports, or register(factory)): none installed" in out


def test_an_unknown_client_lists_the_installed_ones_and_where_to_register(tmp_path):
    with pytest.raises(ConfigError) as err:
        VlmSource({"client": "gemni", "state_file": str(tmp_path / "q.json")}, name="vlm")
    assert str(err.value) == (
        "client: unknown VLM client 'gemni'; known clients: gemini, openai, stub "
        "(or register one: entry-point group mission.vlm_clients)"
    )


def test_the_module_colon_class_spelling_still_works_with_a_deprecation_warning(tmp_path):
    with pytest.warns(DeprecationWarning, match="register the client as an entry point of the group"):
        src = VlmSource(
            {"client": "mission.perception_plugins.vlm.stub:ColourShapeClient", "state_file": str(tmp_path / "q.json")},
            name="vlm",
        )
    assert type(src._client).__name__ == "ColourShapeClient"
    src.close()
