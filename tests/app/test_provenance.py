"""A run's provenance (mission.app.provenance.run_provenance): what a report records so that the run can be
told apart from others and redone — the resolved config, the tree and config files with their digests, the
perception plugins with the distribution and version providing each, the seed, Python and the key packages.

Real files, real installed metadata: a third-party plugin is a real (tiny) distribution on sys.path.
"""

from __future__ import annotations

import hashlib
import json
import platform
import subprocess
from importlib import metadata
from pathlib import Path

import pytest

from mission.app import provenance
from mission.app.provenance import run_provenance
from mission.core.config import MissionConfig, load_config

ROOT = Path(__file__).resolve().parents[2]
TREES = ROOT / "trees"

CONFIG = """\
tree: mission.xml
perception:
  sources:
    - {plugin: aruco, name: front, params: {marker_size_m: 0.15}}
    - {plugin: apriltag}
run: {tick_hz: 20}
"""


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def config_file(tmp_path) -> Path:
    path = tmp_path / "robot.yaml"
    path.write_text(CONFIG)
    return path


def test_a_run_records_the_resolved_config_the_files_the_seed_and_the_scenario(config_file):
    config = load_config(config_file)
    record = run_provenance(
        config, tree_file=TREES / "mission.xml", seed=7, config_file=config_file, scenario="explore_dock"
    )
    assert json.loads(json.dumps(record)) == record  # plain JSON data, as report.json holds it
    assert MissionConfig.model_validate(record["config"]) == config  # every default filled in, and it reads back
    assert record["config"]["run"]["tick_hz"] == 20 and record["config"]["perception"]["policy"] == "hybrid"
    assert record["config_file"] == {"path": str(config_file.resolve()), "sha256": _sha256(config_file)}
    assert (record["seed"], record["scenario"]) == (7, "explore_dock")
    assert record["python"]["version"] == platform.python_version()


def test_the_built_in_defaults_have_no_config_file():
    record = run_provenance(MissionConfig(), tree_file="mission.xml", seed=0)
    assert record["config_file"] is None and record["config"] == MissionConfig().model_dump(mode="json")


def test_the_tree_is_recorded_with_every_file_it_includes():
    record = run_provenance(MissionConfig(), tree_file="mission.xml", seed=0)  # a shipped tree's name
    tree = record["tree_file"]
    assert tree["path"] == str((TREES / "mission.xml").resolve()) and tree["sha256"] == _sha256(TREES / "mission.xml")
    included = {Path(f["path"]).name: f["sha256"] for f in tree["includes"]}
    assert set(included) == {"explore.xml", "dock.xml", "follow.xml"}
    assert included["dock.xml"] == _sha256(TREES / "dock.xml")


def test_each_plugin_names_the_distribution_and_version_that_provide_it(config_file):
    record = run_provenance(load_config(config_file), tree_file="mission.xml", seed=0)
    assert record["perception_plugins"] == [
        {
            "name": "front",
            "plugin": "aruco",
            "entry_point": "mission.perception_plugins.aruco:ArucoSource",
            "distribution": "mission",
            "version": metadata.version("mission"),
        },
        {
            "name": "apriltag",
            "plugin": "apriltag",
            "entry_point": "mission.perception_plugins.apriltag:AprilTagSource",
            "distribution": "mission",
            "version": metadata.version("mission"),
        },
    ]


def test_a_third_party_plugin_names_its_own_distribution(tmp_path, monkeypatch):
    info = tmp_path / "acme_vision-2.3.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: acme-vision\nVersion: 2.3.1\n")
    (info / "entry_points.txt").write_text("[mission.perception_plugins]\nacme = acme_vision.source:AcmeSource\n")
    monkeypatch.syspath_prepend(str(tmp_path))  # installed, as pip would put it in site-packages
    config = MissionConfig.model_validate({"perception": {"sources": [{"plugin": "acme"}, {"plugin": "aruco"}]}})
    acme, aruco = run_provenance(config, tree_file="mission.xml", seed=0)["perception_plugins"]
    assert acme == {
        "name": "acme",
        "plugin": "acme",
        "entry_point": "acme_vision.source:AcmeSource",
        "distribution": "acme-vision",
        "version": "2.3.1",
    }
    assert aruco["distribution"] == "mission"


def test_a_plugin_that_is_not_installed_is_recorded_without_a_distribution():
    config = MissionConfig.model_validate({"perception": {"sources": [{"plugin": "uninstalled_thing"}]}})
    [plugin] = run_provenance(config, tree_file="mission.xml", seed=0)["perception_plugins"]
    assert plugin == {
        "name": "uninstalled_thing",
        "plugin": "uninstalled_thing",
        "entry_point": None,
        "distribution": None,
        "version": None,
    }


def test_the_key_packages_are_the_installed_versions():
    packages = run_provenance(MissionConfig(), tree_file="mission.xml", seed=0)["packages"]
    assert set(packages) == {"mission", "py_trees", "numpy", "opencv", "pybullet", "pydantic", "rclpy"}
    for key in ("mission", "py_trees", "numpy", "pybullet", "pydantic"):
        assert packages[key] == {"distribution": key, "version": metadata.version(key)}
    import cv2

    assert packages["opencv"]["version"].startswith(cv2.__version__)  # the wheel adds a build number
    assert metadata.version(packages["opencv"]["distribution"]) == packages["opencv"]["version"]


def test_a_package_that_is_absent_or_installed_without_pip_metadata_never_fails(tmp_path, monkeypatch):
    # a source-built module that is loaded, and a ROS-installed one (share/<name>/package.xml), neither with
    # pip metadata; and one that is not there at all
    (tmp_path / "built_cv.py").write_text("__version__ = '4.10.0-dev'\n")
    site = tmp_path / "opt" / "ros" / "lib" / "python3" / "site-packages"
    (site / "ros_client").mkdir(parents=True)
    (site / "ros_client" / "__init__.py").write_text("raise ImportError('never imported to ask its version')\n")
    (tmp_path / "opt" / "ros" / "share" / "ros_client").mkdir(parents=True)
    (tmp_path / "opt" / "ros" / "share" / "ros_client" / "package.xml").write_text(
        "<package format='3'><name>ros_client</name><version>7.1.5</version></package>\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.syspath_prepend(str(site))
    __import__("built_cv")
    monkeypatch.setattr(
        provenance,
        "KEY_PACKAGES",
        {
            "opencv": (("no-such-opencv-wheel",), "built_cv"),
            "rclpy": (("no-such-rclpy-wheel",), "ros_client"),
            "absent": (("no-such-distribution",), "no_such_module"),
        },
    )
    packages = run_provenance(MissionConfig(), tree_file="mission.xml", seed=0)["packages"]
    assert packages == {
        "opencv": {"distribution": None, "version": "4.10.0-dev"},
        "rclpy": {"distribution": None, "version": "7.1.5"},
        "absent": None,
    }


def test_a_run_from_a_git_checkout_records_the_commit():
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True, check=False)
    if head.returncode != 0:
        pytest.skip("not a git checkout")
    source = run_provenance(MissionConfig(), tree_file="mission.xml", seed=0)["source"]
    assert source["commit"] == head.stdout.strip() and isinstance(source["dirty"], bool)
