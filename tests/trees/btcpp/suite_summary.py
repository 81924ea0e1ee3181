"""The ``BT.CPP suite:`` line at the end of a test run: how many of BehaviorTree.CPP's own TESTs pass translated.

A tree TEST passes when every pytest item of it passed; a script assertion is one item. Each item's TEST comes
with its reports (``user_properties``, set by tests/trees/btcpp/conftest.py), so the count is the same in one
process and under pytest-xdist, whose controller sees only the workers' reports. Each test module's
``SKIPPED`` maps the TESTs of its BT.CPP file that use only the C++ API to the reason; test_btcpp_coverage.py
checks the three add up.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import pytest

PROPERTY = "btcpp"  # the user property holding [the BT.CPP TEST's name, "tree" or "script"]

_results: dict[str, dict[str, list[bool]]] = {"tree": defaultdict(list), "script": defaultdict(list)}


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    marker = dict(report.user_properties).get(PROPERTY)
    if marker is None:
        return
    test, kind = marker
    if report.when == "call" or report.outcome != "passed":  # the call, or a setup that failed or skipped
        ok = report.when == "call" and report.passed and not hasattr(report, "wasxfail")
        _results[kind][test if kind == "tree" else report.nodeid].append(ok)


def skipped_tests() -> dict[str, str]:
    """Every test module's SKIPPED, together ("Suite.Name" → why it cannot be translated)."""
    import importlib
    from pathlib import Path

    out: dict[str, str] = {}
    for path in sorted(Path(__file__).parent.glob("test_btcpp_*.py")):
        module = importlib.import_module(f"{__package__}.{path.stem}")
        out.update(getattr(module, "SKIPPED", {}))
    return out


def pytest_terminal_summary(terminalreporter: Any) -> None:
    if not (_results["tree"] or _results["script"]):
        return
    scripts = _results["script"]
    trees = _results["tree"]
    s_pass = sum(all(v) for v in scripts.values())
    t_pass = sum(all(v) for v in trees.values())
    terminalreporter.write_line(
        f"BT.CPP suite: {s_pass}/{len(scripts)} script assertions, {t_pass}/{len(trees)} tree TESTs, "
        f"{len(skipped_tests())} skipped (C++ only)"
    )
