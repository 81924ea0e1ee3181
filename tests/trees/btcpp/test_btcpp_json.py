"""BehaviorTree.CPP 4.10 tests/gtest_json.cpp, translated (XML verbatim; see btcpp_harness.py).

Every TEST exercises ``BT::JsonExporter`` on C++ types (nlohmann::json), without XML: nothing to
translate.
"""

from __future__ import annotations

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "JsonTest.TwoWaysConversion": (
        "tests BT::JsonExporter C++ type registry (Pose3D, Vector3D, Quaternion to/from nlohmann::json), no XML"
    ),
    "JsonTest.CustomTime": (
        "tests BT::JsonExporter with a C++ custom type (TestTypes::Time) and nlohmann::json, no XML"
    ),
    "JsonTest.ConvertFromString": "tests BT::convertFromString<Vector3D> of a json: string into a C++ struct, no XML",
    "JsonTest.BlackboardInOut": (
        "tests ExportBlackboardToJSON/ImportBlackboardFromJSON with C++ types (Vector3D) on a bare Blackboard, no XML"
    ),
    "JsonTest.VectorInteger": "tests BT::JsonExporter of std::vector<int> (nlohmann::json), no XML",
    "JsonTest.VectorSring": "tests BT::JsonExporter of std::vector<std::string> (nlohmann::json), no XML",
    "JsonTest.VectorOfCustomTypes": (
        "tests BT::JsonExporter of std::vector<TestTypes::Pose3D> (nlohmann::json), no XML"
    ),
}
