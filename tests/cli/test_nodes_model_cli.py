"""`mission nodes-model`: Groot2's palette of every behaviour a run can use, a third-party package's included.

The third-party package is installed for real (a module and its ``.dist-info`` with an
``entry_points.txt``, which is what pip lays down) in a folder on the path of a fresh interpreter, so the
discovery through the ``mission.behaviours`` entry-point group is the one a user gets.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET

import pytest

from mission.core.errors import TreeError
from mission.trees.factory import shipped_factory
from mission.trees.loader import load_tree
from mission.trees.tree_nodes_model import shipped_tree_files

BEACON = '''
"""Acme's behaviours for mission."""
from dataclasses import dataclass

import py_trees

from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import port


class Beacon(MissionLeaf):
    """Blink the beacon `times` times, then succeed."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        times: int = port(3, "how many blinks")
        colour: str = port("amber", "the lamp's colour")

    NODE_TYPE = "Action"

    def update(self):
        self.feedback_message = f"blinking {self.params.colour}"
        return py_trees.common.Status.SUCCESS


class Radio(MissionLeaf):
    """Say `text` on the radio it was registered with."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        text: str = port("hello", "what to say")

    NODE_TYPE = "Action"

    def __init__(self, *, radio, **kwargs):
        super().__init__(**kwargs)
        self.radio = radio

    def update(self):
        self.radio.append(self.params.text)
        self.feedback_message = f"said {self.params.text}"
        return py_trees.common.Status.SUCCESS


def register(factory):
    factory.register(Radio, radio=[])
'''


def install_acme(site, *, broken: bool = False):
    """Lay down the package `acme_bt` 0.1 as pip would: the module, its metadata and its entry points."""
    (site / "acme_bt").mkdir(parents=True)
    (site / "acme_bt" / "__init__.py").write_text(BEACON)
    info = site / "acme_bt-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: acme-bt\nVersion: 0.1\n")
    points = "[mission.behaviours]\nBeacon = acme_bt:Beacon\nacme = acme_bt:register\n"
    if broken:
        points += "Gone = acme_bt.missing:Gone\n"
    (info / "entry_points.txt").write_text(points)


def mission(args, site=None, cwd=None):
    env = dict(os.environ)
    if site is not None:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(site), env.get("PYTHONPATH", "")) if p)
    return subprocess.run(
        [sys.executable, "-m", "mission", *args], capture_output=True, text=True, env=env, cwd=cwd, timeout=120
    )


def _models(text):
    root = ET.fromstring(text)
    return {el.get("ID"): el for el in root.find("TreeNodesModel")}


def test_the_palette_holds_every_shipped_behaviour_with_ports_and_descriptions():
    result = mission(["nodes-model"])
    assert result.returncode == 0, result.stderr
    models = _models(result.stdout)
    factory = shipped_factory()
    assert sorted(models) == sorted(m.tag for m in factory.behaviours())
    follow = models["FollowTarget"]
    assert follow.tag == "Action"
    ports = {p.get("name"): (p.get("type"), p.get("default")) for p in follow.findall("input_port")}
    assert ports["offset_m"] == ("double", "0.5") and ports["window"] == ("int", "5")
    description = follow.find("MetadataFields/Metadata").get("description")
    assert description.startswith("FOLLOW: keep sending a smoothed approach goal")


def test_an_installed_packages_behaviours_are_in_the_palette(tmp_path):
    site = tmp_path / "site"
    install_acme(site)
    out = tmp_path / "palette.xml"
    result = mission(["nodes-model", "-o", str(out)], site=site)
    assert result.returncode == 0, result.stderr
    assert "TreeNodesModel of 20 behaviours" in result.stderr  # 18 shipped (not the deprecated one) + Beacon + Radio
    models = _models(out.read_text())
    beacon = models["Beacon"]
    assert {p.get("name"): p.get("default") for p in beacon.findall("input_port")} == {"times": "3", "colour": "amber"}
    assert beacon.find("MetadataFields/Metadata").get("description") == "Blink the beacon `times` times, then succeed."
    assert "Radio" in models  # registered by the package's register(factory), with its dependency


def test_into_gives_a_users_tree_its_palette_and_the_tree_still_loads(tmp_path):
    site = tmp_path / "site"
    install_acme(site)
    tree = tmp_path / "patrol.xml"
    tree.write_text(
        textwrap.dedent("""\
        <root BTCPP_format="4" main_tree_to_execute="Patrol">
          <BehaviorTree ID="Patrol">
            <Sequence>
              <Beacon times="2"/>
              <SetMissionState state="DONE"/>
            </Sequence>
          </BehaviorTree>
        </root>
        """)
    )
    result = mission(["nodes-model", "--into", str(tree)], site=site)
    assert result.returncode == 0, result.stderr
    text = tree.read_text()
    assert text.count("<TreeNodesModel>") == 1 and '<Action ID="Beacon">' in text
    again = mission(["nodes-model", "--into", str(tree)], site=site)
    assert again.returncode == 0 and tree.read_text() == text  # replaced, not added twice
    probe = (
        "import sys; sys.path.insert(0, sys.argv[1]); from mission.app.behaviour_plugins import mission_factory;"
        " from mission.trees.loader import load_tree; print(load_tree(sys.argv[2], mission_factory()).name)"
    )
    loaded = subprocess.run(
        [sys.executable, "-c", probe, str(site), str(tree)], capture_output=True, text=True, timeout=60
    )
    assert loaded.returncode == 0 and loaded.stdout.strip() == "Patrol", loaded.stderr
    with pytest.raises(TreeError, match=r"patrol.xml:4: <Beacon>: unknown node 'Beacon'"):
        load_tree(tree, shipped_factory())  # without the package, the same file names what is missing


def test_a_broken_plugin_stops_the_palette_with_one_line_naming_it(tmp_path):
    site = tmp_path / "site"
    install_acme(site, broken=True)
    result = mission(["nodes-model"], site=site)
    assert result.returncode == 2 and result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1
    expected = (
        "mission: error: entry point Gone = 'acme_bt.missing:Gone' (mission.behaviours from acme-bt 0.1): "
        "failed to load: ModuleNotFoundError"
    )
    assert lines[0].startswith(expected)


def test_into_a_file_that_is_not_a_tree_is_refused_and_left_alone(tmp_path):
    path = tmp_path / "notes.xml"
    path.write_text("<notes><n/></notes>\n")
    result = mission(["nodes-model", "--into", str(path)])
    assert result.returncode == 2
    assert "notes.xml: expected a tree file" in result.stderr
    assert path.read_text() == "<notes><n/></notes>\n"
    broken = tmp_path / "broken.xml"
    broken.write_text("<root BTCPP_format='4'>\n<BehaviorTree>\n")
    result = mission(["nodes-model", "--into", str(broken)])
    assert result.returncode == 2 and "broken.xml:3: malformed XML" in result.stderr


def test_the_deprecated_no_op_is_left_out_of_the_palette_yet_an_old_tree_using_it_loads(tmp_path):
    result = mission(["nodes-model"])
    assert "PerceiveTargets" not in _models(result.stdout)
    for path in shipped_tree_files():
        assert "PerceiveTargets" not in path.read_text(), path.name
    old = tmp_path / "old.xml"
    old.write_text(
        textwrap.dedent("""\
        <root BTCPP_format="4" main_tree_to_execute="Old">
          <BehaviorTree ID="Old">
            <Sequence><ForceSuccess><PerceiveTargets/></ForceSuccess><AlwaysSuccess/></Sequence>
          </BehaviorTree>
        </root>
    """)
    )
    root = load_tree(old, shipped_factory())
    root.setup_with_descendants()
    root.tick_once()
    assert root.status.name == "SUCCESS"
