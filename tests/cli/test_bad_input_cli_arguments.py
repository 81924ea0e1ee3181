"""Command-line numbers a user can get wrong: one usage line naming the argument and what it takes, exit 2,
and nothing started (a NaN duration would never end; a negative one 'succeeded' after 0 s)."""

from __future__ import annotations

import pytest

from mission.cli import main


@pytest.mark.parametrize(
    ("argv", "argument", "expected"),
    [
        (["run", "--scenario", "explore_dock", "--max-duration", "nan"], "--max-duration", "finite number > 0"),
        (["run", "--scenario", "explore_dock", "--max-duration", "inf"], "--max-duration", "finite number > 0"),
        (["run", "--scenario", "explore_dock", "--max-duration", "-5"], "--max-duration", "finite number > 0"),
        (["run", "--scenario", "explore_dock", "--max-duration", "0"], "--max-duration", "finite number > 0"),
        (["run", "--scenario", "explore_dock", "--max-duration", "soon"], "--max-duration", "finite number > 0"),
        (["run", "--scenario", "explore_dock", "--seed", "-3"], "--seed", "whole number ≥ 0"),
        (["run", "--scenario", "explore_dock", "--seed", "1.5"], "--seed", "whole number ≥ 0"),
        (["run", "--scenario", "explore_dock", "--serve", "--port", "-1"], "--port", "whole number 0–65535"),
        (["run", "--scenario", "explore_dock", "--serve", "--port", "99999"], "--port", "whole number 0–65535"),
        (["run", "--scenario", "explore_dock", "--serve", "--port", "65536"], "--port", "whole number 0–65535"),
        (["run", "--scenario", "explore_dock", "--serve", "--port", "http"], "--port", "whole number 0–65535"),
        (["viz", "mission.xml", "--log", "run.jsonl", "--tick", "-2"], "--tick", "whole number ≥ 0"),
        (["replay", "some.bag", "--rate", "nan"], "--rate", "finite number ≥ 0"),
        (["task", "follow", "--frame", "person", "--max-duration", "-1"], "--max-duration", "finite number ≥ 0"),
        (["task", "follow", "--frame", "person", "--max-duration", "inf"], "--max-duration", "finite number ≥ 0"),
        (["task", "dock", "--id", "home", "--server-timeout", "0"], "--server-timeout", "finite number > 0"),
        (["task", "dock", "--id", "home", "--max-staging-time", "-5"], "--max-staging-time", "finite number ≥ 0"),
        (["task", "dock", "--pose", "1", "nan", "0"], "--pose", "a finite number"),
        (["task", "dock", "--pose", "1", "two", "0"], "--pose", "a finite number"),
        (["task", "undock", "--max-undocking-time", "soon"], "--max-undocking-time", "finite number ≥ 0"),
    ],
)
def test_a_bad_number_is_one_usage_line_naming_the_argument(capsys, argv, argument, expected):
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"argument {argument}:" in err and expected in err, err


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["task"], "the following arguments are required: ACTION"),
        (["task", "park"], "argument ACTION: invalid choice: 'park'"),
        (["task", "dock"], "one of the arguments --id --pose is required"),
        (["task", "dock", "--id", "home", "--pose", "1", "2", "0"], "argument --pose: not allowed with argument --id"),
        (["task", "dock", "--pose", "1", "2"], "argument --pose: expected 3 arguments"),
        (["task", "follow"], "one of the arguments --topic --frame is required"),
        (["task", "follow", "--topic", "/p", "--frame", "f"], "argument --frame: not allowed with argument --topic"),
    ],
)
def test_a_task_needs_one_target_and_says_which(capsys, argv, expected):
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert expected in err, err


def test_a_dock_by_id_takes_no_type_or_frame_and_nothing_is_sent(capsys):
    """A dock in the server's database has its own type and frame: --type / --frame beside --id would be ignored by
    the server, so they are refused before any ROS is started."""
    assert main(["task", "dock", "--id", "home", "--type", "charging_dock", "--frame", "odom"]) == 2
    captured = capsys.readouterr()
    assert captured.err.strip() == (
        "mission task dock: error: --type and --frame go with --pose "
        "(a dock in the database has its own type and frame)"
    )
    assert captured.out == ""
