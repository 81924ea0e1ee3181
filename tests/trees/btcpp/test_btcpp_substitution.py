"""BehaviorTree.CPP 4.10 tests/gtest_substitution.cpp: every TEST is about the factory's substitution rules.

``factory.addSubstitutionRule(instance_name, rule)`` and ``factory.loadSubstitutionRuleFromJSON(json)`` make
``createTree`` build, in place of every node whose instance name matches, either a ``TestNode`` configured by a
C++ ``TestNodeConfig`` (return_status, return_status_script, async_delay, success/failure/post scripts) or
another registered node type. The TESTs with XML use only built-in nodes, but what they check (the TREE's
result) is made by the substitution: without it the same XML gives other results. The project's factory
(trees/factory.py) has no substitution rules, so nothing here can be translated.
"""

from __future__ import annotations

_RULES_API = "tests factory.substitutionRules() after loadSubstitutionRuleFromJSON (the parsed C++ TestNodeConfig "
_SUBSTITUTION = (
    "the tree's result comes from a substitution rule (factory.addSubstitutionRule / "
    "loadSubstitutionRuleFromJSON replacing a node by instance name at createTree), a C++ factory API "
    "the project's factory does not have"
)

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "Substitution.Parser": _RULES_API + "and string rules); no tree",
    "Substitution.TestNodePostScriptUsesRegisteredEnums": (
        f"{_SUBSTITUTION}: a C++ TestNodeConfig whose post_script uses a scripting enum"
    ),
    "Substitution.TestNodePostScriptReadsStatusNamedBlackboardKey": (
        f"{_SUBSTITUTION}: a C++ TestNodeConfig whose post_script reads an entry named SUCCESS"
    ),
    "Substitution.ParserRejectsMissingReturnStatusAndScript": (
        "tests that loadSubstitutionRuleFromJSON refuses a TestNodeConfig without return_status; no tree"
    ),
    "Substitution.ScriptedReturnStatusFromJson": f"{_SUBSTITUTION}: a JSON TestNodeConfig with return_status_script",
    "Substitution.ScriptedReturnStatusOverridesFixedStatus": (
        f"{_SUBSTITUTION}: a C++ TestNodeConfig's return_status_script over its return_status"
    ),
    "Substitution.ScriptedReturnStatusAsyncSubstitution": (
        f"{_SUBSTITUTION}: a C++ TestNodeConfig with async_delay and return_status_script"
    ),
    "Substitution.ScriptedReturnStatusRejectsIdle": (
        f"{_SUBSTITUTION}: a C++ TestNodeConfig whose return_status_script gives IDLE"
    ),
    "Substitution.SubTreeNodeSubstitution": f"{_SUBSTITUTION}: a <SubTree> node replaced by a C++ TestNodeConfig",
    "Substitution.StringSubstitutionWithSimpleAction_Issue930": (
        f"{_SUBSTITUTION}: a node replaced by another registered action (string rule)"
    ),
    "Substitution.TestNodeConfigAsyncSubstitution_Issue930": (
        f"{_SUBSTITUTION}: a C++ TestNodeConfig with async_delay"
    ),
    "Substitution.JsonStringSubstitution_Issue930": f"{_SUBSTITUTION}: a JSON string rule",
    "Substitution.JsonWithEmptyTestNodeConfigs_Issue930": _RULES_API + "map being empty); no tree",
    "Substitution.JsonWithoutTestNodeConfigs_Issue930": _RULES_API + "map being absent); no tree",
    "Substitution.JsonStringSubstitutionWithDelay_Issue930": (
        f"{_SUBSTITUTION}: a <Script> replaced by a registered action through a JSON string rule"
    ),
    "Substitution.StringSubstitutionRegistrationID_Issue930": f"{_SUBSTITUTION}: a string rule",
}
