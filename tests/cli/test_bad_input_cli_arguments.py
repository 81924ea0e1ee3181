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
    ],
)
def test_a_bad_number_is_one_usage_line_naming_the_argument(capsys, argv, argument, expected):
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"argument {argument}:" in err and expected in err, err
