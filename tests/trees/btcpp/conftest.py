"""BT.CPP's own suite, translated: the summary line CI prints, and where each translated TEST is counted.

A test marked ``btcpp("Suite.Name", kind="tree"|"script")`` (btcpp_harness.TEST / SCRIPT) is one BT.CPP TEST
(tree) or one assertion of script_parser_test.cpp (script; a TEST's assertions are its parametrized cases).
A tree TEST passes when every pytest item of it passed. Each test module's ``SKIPPED`` maps the TESTs of its
BT.CPP file that use only the C++ API to the reason; test_btcpp_coverage.py checks the three add up.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import pytest

_results: dict[str, dict[str, list[bool]]] = {"tree": defaultdict(list), "script": defaultdict(list)}


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "btcpp(test, kind): the translation of a BehaviorTree.CPP TEST")


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    marker = _markers.get(report.nodeid)
    if marker is None:
        return
    test, kind = marker
    if report.when == "call" or report.outcome != "passed":  # the call, or a setup that failed or skipped
        ok = report.when == "call" and report.passed and not hasattr(report, "wasxfail")
        _results[kind][test if kind == "tree" else report.nodeid].append(ok)


_markers: dict[str, tuple[str, str]] = {}


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        mark = item.get_closest_marker("btcpp")
        if mark is not None:
            _markers[item.nodeid] = (mark.args[0], mark.kwargs.get("kind", "tree"))


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
