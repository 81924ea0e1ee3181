"""The translation covers BT.CPP's whole suite: every TEST is translated or skipped with its C++-only reason."""

from __future__ import annotations

import importlib
from pathlib import Path

from tests.trees.btcpp.btcpp_tests import BTCPP_TESTS, SOURCE
from tests.trees.btcpp.suite_summary import skipped_tests

HERE = Path(__file__).parent


def translated() -> dict[str, set[str]]:
    """module stem → the "Suite.Name" of its tests marked btcpp."""
    out: dict[str, set[str]] = {}
    for path in sorted(HERE.glob("test_btcpp_*.py")):
        module = importlib.import_module(f"{__package__}.{path.stem}")
        names = set()
        for value in vars(module).values():
            for mark in getattr(value, "pytestmark", []):
                if mark.name == "btcpp":
                    names.add(mark.args[0])
        out[path.stem] = names
    return out


def test_the_suite_comes_from_a_named_bt_cpp_release():
    assert SOURCE["tag"].startswith("4.") and len(SOURCE["commit"]) == 40


def test_every_bt_cpp_test_is_translated_or_skipped_with_a_reason():
    done = set().union(*translated().values())
    skipped = skipped_tests()
    for file, tests in BTCPP_TESTS.items():
        for test in tests:
            assert (test in done) != (test in skipped), f"{file}: {test} must be translated or skipped, not both"
            if test in skipped:
                assert len(skipped[test]) > 10, f"{file}: {test}: say why it is C++ only"
    known = {t for tests in BTCPP_TESTS.values() for t in tests}
    assert not (done | set(skipped)) - known, "a translated or skipped name that BT.CPP's suite does not have"
