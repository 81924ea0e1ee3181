"""Issue 36, a new user's first hour: no silent traps, and failures that say why.

Each test is a scenario a new user meets, run for real (the `mission` command in a subprocess, a real
simulation), and asserts on what the user sees: the result line, a warning, the exit status."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from mission.app.sim_run import prepare_run

MISSION = [sys.executable, "-m", "mission"]


def mission(*argv: str, cwd: Path | None = None, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*MISSION, *argv], capture_output=True, text=True, timeout=timeout, cwd=cwd, env=dict(os.environ)
    )


# -- 1. your own config does not blind the simulated robot ----------------------------------------------------


def test_a_config_of_your_own_still_sees_the_simulated_markers(tmp_path):
    """A user's config that only sets the tick rate docks in explore_dock, as the run without --config does."""
    config = tmp_path / "mine.yaml"
    config.write_text("run: {tick_hz: 15}\n")
    result = mission("run", "--scenario", "explore_dock", "--config", str(config), "--quiet")
    assert result.returncode == 0, result.stdout + result.stderr
    assert result.stdout.startswith("SUCCESS: explore_dock seed 0: docked within tolerance"), result.stdout
    assert "warning" not in result.stderr, result.stderr


@pytest.mark.parametrize("text", ["", "run: {tick_hz: 15}\n", "perception: {policy: all}\n"])
def test_an_empty_or_partial_config_perceives_what_the_default_run_perceives(tmp_path, text):
    config = tmp_path / "mine.yaml"
    config.write_text(text)
    default = prepare_run("mission_full").config.perception
    mine = prepare_run("mission_full", config_file=config).config.perception
    assert mine.sources == default.sources and mine.targets == default.targets


def test_a_source_named_like_the_sims_keeps_the_params_it_does_not_set(tmp_path):
    config = tmp_path / "mine.yaml"
    config.write_text("perception:\n  sources:\n    - plugin: aruco\n      params: {corner_refinement: none}\n")
    (source,) = prepare_run("mission_full", config_file=config).config.perception.sources
    assert source.params["dictionary"] == "DICT_APRILTAG_36h11"
    assert source.params["marker_sizes"] == {0: 0.15, 7: 0.20}
    assert source.params["corner_refinement"] == "none"


def test_a_target_renamed_by_the_user_replaces_the_sims(tmp_path):
    config = tmp_path / "mine.yaml"
    config.write_text("perception:\n  targets:\n    box: {marker_id: 7}\n")
    targets = prepare_run("mission_full", config_file=config).config.perception.targets
    assert set(targets) == {"box", "dock"}


def test_a_dictionary_that_cannot_read_the_sims_markers_is_one_warning_line(tmp_path):
    config = tmp_path / "mine.yaml"
    config.write_text("perception:\n  sources:\n    - plugin: aruco\n      params: {dictionary: DICT_4X4_50}\n")
    result = mission("run", "--scenario", "explore_dock", "--config", str(config), "--quiet", "--max-duration", "1")
    warnings = [line for line in result.stderr.splitlines() if "warning" in line]
    assert len(warnings) == 1, result.stderr
    assert str(config) in warnings[0] and "DICT_4X4_50" in warnings[0] and "DICT_APRILTAG_36h11" in warnings[0]
    assert "never be seen" in warnings[0]


def test_the_shipped_configs_agree_with_the_sim(tmp_path):
    for name in ("sim_aruco.yaml", "sim_apriltag.yaml", "sim_vlm.yaml"):
        path = Path(prepare_run("mission_full").config_path).parent / name
        assert prepare_run("mission_full", config_file=path).warnings == [], name


# -- 2. failures that say why ----------------------------------------------------------------------------------

UNWRITTEN_ENTRY_TREE = """<?xml version="1.0" encoding="UTF-8"?>
<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <Sequence name="main">
      <IsTargetVisible name="see it" target="{tgt}" max_misses="4"/>
    </Sequence>
  </BehaviorTree>
</root>
"""


def test_a_tree_that_fails_names_the_leaf_and_why_in_the_result_line_and_the_report(tmp_path):
    tree = tmp_path / "mine.xml"
    tree.write_text(UNWRITTEN_ENTRY_TREE)
    report = tmp_path / "report"
    result = mission("run", "--scenario", "explore_dock", "--tree", str(tree), "--quiet", "--report", str(report))
    assert result.returncode == 1
    why = "leaf 'see it' (IsTargetVisible) failed: port target: blackboard entry {tgt} was never written"
    assert why in result.stdout, result.stdout
    assert why in (report / "report.json").read_text()
    html = (report / "report.html").read_text()
    assert "blackboard entry {tgt} was never written" in html and "IsTargetVisible" in html


def test_a_run_cut_off_by_max_duration_before_docking_says_so():
    result = mission("run", "--scenario", "mission_full", "--max-duration", "6", "--quiet")
    assert result.returncode == 1
    assert "never docked: --max-duration 6 ended it after 6 s, still in state DOCK" in result.stdout, result.stdout
    assert "out of tolerance" not in result.stdout


@pytest.mark.slow  # a long sim run; the fast suite keeps the other first-hour cases
def test_a_follow_run_that_ends_lost_says_it_ended_lost():
    """follow_occlusion seed 0 loses the target behind the wall at 16.6 s; cut off at 20 s it is still LOST.
    A loss that recent is not counted against the run (it may yet be re-acquired), but it is not hidden."""
    result = mission("run", "--scenario", "follow_occlusion", "--max-duration", "20", "--quiet")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "ended LOST" in result.stdout and "to the end" not in result.stdout, result.stdout


# -- 4. shipped configs are named as shipped trees and scenarios are -----------------------------------------


@pytest.mark.parametrize("name", ["sim_apriltag.yaml", "sim_apriltag"])
def test_a_shipped_config_can_be_named_from_any_directory(tmp_path, name):
    result = mission(
        "run", "--scenario", "explore_dock", "--config", name, "--quiet", "--max-duration", "1", cwd=tmp_path
    )
    assert result.returncode in (0, 1) and "error" not in result.stderr, result.stderr
    assert result.stdout.startswith("FAILURE: explore_dock seed 0:"), result.stdout  # it ran: 1 s is too short


def test_a_config_name_that_is_neither_a_file_nor_shipped_lists_the_shipped_ones(tmp_path):
    result = mission("run", "--config", "sim_apriltg.yaml", "--quiet", cwd=tmp_path)
    assert result.returncode == 2
    [line] = result.stderr.strip().splitlines()
    assert line.startswith("mission: error: sim_apriltg.yaml: file not found; expected a config file or a shipped")
    assert "sim_apriltag.yaml" in line and "sim_aruco.yaml" in line


# -- 5. which plugin ran, how well it docked ------------------------------------------------------------------


@pytest.mark.slow  # a long sim run; the fast suite keeps the other first-hour cases
def test_the_result_line_and_report_name_the_perception_plugin_and_the_dock_accuracy(tmp_path):
    report = tmp_path / "report"
    result = mission(
        "run", "--scenario", "explore_dock", "--config", "sim_apriltag.yaml", "--quiet", "--report", str(report)
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "; perception apriltag)" in result.stdout, result.stdout
    html = (report / "report.html").read_text()
    assert "<td>perception</td><td>apriltag</td>" in html
    assert "<td>dock accuracy</td><td>lateral " in html and " cm, distance " in html and "skew " in html


# -- 6. small traps ------------------------------------------------------------------------------------------


def test_tick_hz_true_is_a_config_error_not_1_hz(tmp_path):
    config = tmp_path / "mine.yaml"
    config.write_text("run: {tick_hz: true}\n")
    result = mission("run", "--config", str(config), "--quiet", "--max-duration", "1")
    assert result.returncode == 2
    [line] = result.stderr.strip().splitlines()
    assert line.startswith(f"mission: error: {config}: run.tick_hz: ") and "expected a number, got True" in line


@pytest.mark.parametrize("option", ["--report", "--log", "--record"])
def test_an_empty_output_path_is_a_usage_error_not_ignored(option):
    result = mission("run", "--scenario", "explore_dock", option, "", "--quiet", "--max-duration", "1")
    assert result.returncode == 2 and result.stdout == ""
    assert f"argument {option}: expected a path, got an empty string" in result.stderr.strip().splitlines()[-1]


def test_viz_refuses_to_write_png_bytes_into_an_svg_name(tmp_path):
    result = mission("viz", "mission.xml", "--format", "png", "-o", str(tmp_path / "x.svg"))
    assert result.returncode == 2
    [line] = result.stderr.strip().splitlines()
    assert "x.svg: a .svg name, but --format png writes PNG" in line
    assert not (tmp_path / "x.svg").exists()


def test_mission_version_names_the_installed_version():
    from importlib.metadata import version

    result = mission("--version")
    assert result.returncode == 0
    assert result.stdout.strip() == f"mission {version('mission')}"


def test_max_duration_ends_a_run_at_the_limit_even_when_a_tick_is_longer(tmp_path):
    """At 0.2 Hz a tick is 5 s: --max-duration 3 ran 5 s. The last step now lands on the limit."""
    result = mission(
        "run", "--scenario", "explore_dock", "--set", "run.tick_hz=0.2", "--max-duration", "3", "--quiet", cwd=tmp_path
    )
    assert result.returncode == 1
    assert "(3.0 s simulated in " in result.stdout, result.stdout


@pytest.mark.parametrize("delay_s", [0.2, 0.5])
@pytest.mark.parametrize(("signame", "code"), [("SIGINT", 130), ("SIGTERM", 143)])
def test_a_stop_signal_in_the_first_second_stops_with_its_code_and_no_traceback(delay_s, signame, code):
    """Ctrl-C (130) or a service manager's SIGTERM (143) while the run still starts up: one line, no traceback,
    the shell's code for that signal."""
    import signal
    import time

    proc = subprocess.Popen(
        [sys.executable, "-m", "mission", "run", "--scenario", "follow_open", "--max-duration", "5"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # as from a terminal: a test run started in the background (`scripts/test &`, nohup) has SIGINT ignored,
        # and a child inherits that — Python then never turns Ctrl-C into KeyboardInterrupt, by design
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    time.sleep(delay_s)
    proc.send_signal(getattr(signal, signame))
    _out, err = proc.communicate(timeout=120)
    assert "Traceback" not in err, err
    assert err.strip().splitlines() == [f"mission: {'interrupted' if signame == 'SIGINT' else 'terminated'}"], err
    # A shell sees 128 + the signal either way: the exit code, or the process ended by the signal itself. CPython
    # does the latter when a Ctrl-C went through one of its C-level runs (an extension's import) on the way to
    # our handler — its "unhandled KeyboardInterrupt" flag is then set for good; seen once under load in CI.
    killed = signame == "SIGINT" and proc.returncode == -signal.SIGINT
    assert proc.returncode == code or killed, err


@pytest.mark.parametrize(("stop", "code", "line"), [("int", 130, "interrupted"), ("term", 143, "terminated")])
def test_a_stop_that_lands_in_an_imports_class_body_is_still_a_stop(monkeypatch, capsys, stop, code, line):
    """Python 3.11 wraps what a class attribute's __set_name__ raises in a RuntimeError; a Ctrl-C (or SIGTERM)
    that lands there while a verb's imports run (lark's Transformer, once under a loaded test run) must still end
    as a stop: one line, the shell's code, no traceback."""
    from mission import cli

    class _SignalArrives:
        def __set_name__(self, owner, name):
            raise KeyboardInterrupt if stop == "int" else cli.Terminated

    def importing(argv):
        type("PrepareAnonTerminals", (), {"pattern": _SignalArrives()})  # what an import's class statement does
        return 0

    monkeypatch.setattr(cli, "_main", importing)
    assert cli.main(["run"]) == code
    assert capsys.readouterr().err.strip() == f"mission: {line}"


def test_a_runtime_error_that_no_signal_caused_is_not_taken_for_a_stop(monkeypatch):
    from mission import cli

    def broken(argv):
        raise RuntimeError("a real bug")

    monkeypatch.setattr(cli, "_main", broken)
    with pytest.raises(RuntimeError, match="a real bug"):
        cli.main(["run"])
