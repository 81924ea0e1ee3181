"""Issue 36: `mission viz` draws any BehaviorTree.CPP v4 file — a Nav2 navigator tree, a team's own C++ nodes —
from the file's TreeNodesModel, a palette (`--nodes-model`), or the file itself; running such a tree is still
refused, naming every node type it does not know.

The trees here are written for these tests in the shape of Nav2's default navigator tree (its node type names
and port names are Nav2's interface); no Nav2 file is copied."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from mission.trees.loader import describe_tree
from mission.trees.node_models import drawing_factory

MISSION = [sys.executable, "-m", "mission"]

NAVIGATOR = """<root BTCPP_format="4" main_tree_to_execute="Navigate">
  <BehaviorTree ID="Navigate">
    <RecoveryNode number_of_retries="6" name="NavigateRecovery">
      <PipelineSequence name="Replanning">
        <RateController hz="1.0">
          <ComputePathToPose goal="{goal}" path="{path}" planner_id="GridBased"/>
        </RateController>
        <FollowPath path="{path}" controller_id="FollowPath"/>
      </PipelineSequence>
      <Sequence name="RecoveryActions">
        <Wait wait_duration="5.0"/>
        <BackUp backup_dist="0.30" backup_speed="0.05"/>
      </Sequence>
    </RecoveryNode>
  </BehaviorTree>
</root>
"""

PALETTE = """<root BTCPP_format="4">
  <TreeNodesModel>
    <Control ID="RecoveryNode"><input_port name="number_of_retries" default="1"/></Control>
    <Control ID="PipelineSequence"/>
    <Decorator ID="RateController"><input_port name="hz" default="10.0"/></Decorator>
    <Action ID="ComputePathToPose">
      <input_port name="goal"/><input_port name="planner_id"/><output_port name="path"/>
    </Action>
    <Action ID="FollowPath"><input_port name="path"/><input_port name="controller_id"/></Action>
    <Action ID="Wait"><input_port name="wait_duration"/></Action>
    <Action ID="BackUp"><input_port name="backup_dist"/><input_port name="backup_speed"/></Action>
  </TreeNodesModel>
</root>
"""


def mission(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*MISSION, *argv], capture_output=True, text=True, timeout=120, env=dict(os.environ))


def test_a_nav2_navigator_tree_is_drawn_and_every_foreign_node_is_named_once(tmp_path):
    tree = tmp_path / "navigate.xml"
    tree.write_text(NAVIGATOR)
    out = mission("viz", str(tree))
    assert out.returncode == 0, out.stderr
    for name in ("NavigateRecovery", "Replanning", "ComputePathToPose", "planner_id=GridBased", "BackUp"):
        assert name in out.stdout
    notes = [line for line in out.stderr.splitlines() if line.startswith("mission viz:")]
    assert len(notes) == 1 and "7 node type(s) drawn from models, not runnable here" in notes[0]
    assert "(guessed from the file)" in notes[0] and "Traceback" not in out.stderr


def test_a_palette_gives_the_kinds_and_ports_the_file_does_not_say(tmp_path):
    tree, palette = tmp_path / "navigate.xml", tmp_path / "nav2_tree_nodes.xml"
    tree.write_text(NAVIGATOR)
    palette.write_text(PALETTE)
    factory, models = drawing_factory(tree, [palette])
    assert {m.source for m in models} == {"nav2_tree_nodes.xml"}
    root = describe_tree(tree, factory).children[0]  # RecoveryNode
    assert (root.tag, root.kind) == ("RecoveryNode", "Control")
    rate = root.children[0].children[0]
    assert (rate.tag, rate.kind) == ("RateController", "Decorator")
    assert "not runnable here" in rate.manifest.doc and rate.manifest.runnable is False
    svg = tmp_path / "navigate.svg"
    out = mission("viz", str(tree), "--nodes-model", str(palette), "--format", "svg", "-o", str(svg))
    assert out.returncode == 0, out.stderr
    assert "RateController" in svg.read_text() and "(nav2_tree_nodes.xml)" in out.stderr


def test_the_files_own_tree_nodes_model_is_used_without_a_palette(tmp_path):
    tree = tmp_path / "own.xml"
    tree.write_text(NAVIGATOR.replace("</root>", PALETTE.split('<root BTCPP_format="4">')[1]))
    _, models = drawing_factory(tree)
    assert {m.source for m in models} == {"the file's TreeNodesModel"}
    assert {m.tag: m.kind for m in models}["PipelineSequence"] == "Control"


def test_running_a_foreign_tree_is_refused_naming_every_unknown_node(tmp_path):
    tree = tmp_path / "navigate.xml"
    tree.write_text(NAVIGATOR)
    out = mission("run", "--scenario", "explore_dock", "--tree", str(tree), "--max-duration", "1")
    assert out.returncode == 2
    line = out.stderr.strip().splitlines()[-1]
    assert "7 unknown node types: RecoveryNode (line 3), PipelineSequence (line 4)" in line
    assert "BackUp (line 12)" in line and "`mission viz` draws such a tree" in line


def test_a_palette_that_is_not_there_is_one_line_naming_it(tmp_path):
    tree = tmp_path / "navigate.xml"
    tree.write_text(NAVIGATOR)
    out = mission("viz", str(tree), "--nodes-model", str(tmp_path / "missing.xml"))
    assert out.returncode == 2
    assert (
        out.stderr.strip()
        .splitlines()[-1]
        .endswith(
            f"--nodes-model {tmp_path / 'missing.xml'}: no such file; expected a BT.CPP file with a <TreeNodesModel>"
        )
    )
    assert Path(tree).read_text() == NAVIGATOR
