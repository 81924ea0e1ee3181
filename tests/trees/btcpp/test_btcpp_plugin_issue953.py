"""BehaviorTree.CPP 4.10 tests/gtest_plugin_issue953.cpp: every TEST loads a C++ plugin.

The fixture loads plugin_issue953.so with ``factory.registerFromPlugin``; its Issue953Action reads an input port
of a C++ type (Issue953Type) whose ``convertFromString`` exists only inside the plugin, which is what issue
#953 is about (the converter stored in PortInfo). The project registers Python behaviours and has no plugins
(docs/btcpp.md: "Not supported: … C++ plugins"); its port types are str, int, float, bool and Pose2D.
"""

from __future__ import annotations

_PLUGIN = (
    "loads a C++ plugin (factory.registerFromPlugin(plugin_issue953.so)) whose node reads a port of a C++ type "
    "(Issue953Type) converted by the plugin's own convertFromString"
)

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "PluginIssue953Test.GetInputUsesStoredConverter": f"{_PLUGIN}; the value is a constant in the XML",
    "PluginIssue953Test.GetInputFromBlackboardString": f"{_PLUGIN}; the value is a string entry set by a Script",
    "PluginIssue953Test.GetInputViaSubtreeRemapping": f"{_PLUGIN}; the value is a SubTree's constant",
}
