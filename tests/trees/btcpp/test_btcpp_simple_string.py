"""BehaviorTree.CPP 4.10 tests/gtest_simple_string.cpp, translated (XML verbatim; see btcpp_harness.py).

Every TEST exercises the C++ class ``SafeAny::SimpleString`` (small-string optimisation, copy/move
semantics), without XML: nothing to translate.
"""

from __future__ import annotations

_WHY = "tests the C++ class SafeAny::SimpleString (construction, SOO storage, copy/move, comparison), no XML"

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    name: _WHY
    for name in (
        "SimpleStringTest.DefaultConstructor",
        "SimpleStringTest.EmptyString",
        "SimpleStringTest.ConstructFromCString",
        "SimpleStringTest.ConstructFromCStringWithSize",
        "SimpleStringTest.ConstructFromStdString",
        "SimpleStringTest.ConstructFromStringView",
        "SimpleStringTest.SOOBoundaryExact",
        "SimpleStringTest.SOOBoundaryExceeded",
        "SimpleStringTest.LongString",
        "SimpleStringTest.CopyConstructorSOO",
        "SimpleStringTest.CopyConstructorNonSOO",
        "SimpleStringTest.CopyAssignmentSOO",
        "SimpleStringTest.CopyAssignmentToDefault",
        "SimpleStringTest.SelfCopyAssignment",
        "SimpleStringTest.CopyAssignmentNonSOO",
        "SimpleStringTest.MoveConstructor",
        "SimpleStringTest.MoveConstructorNonSOO",
        "SimpleStringTest.MoveAssignment",
        "SimpleStringTest.MoveAssignmentToDefault",
        "SimpleStringTest.SelfMoveAssignment",
        "SimpleStringTest.MoveAssignmentNonSOO",
        "SimpleStringTest.ToStdString",
        "SimpleStringTest.ToStdStringEmpty",
        "SimpleStringTest.ToStdStringView",
        "SimpleStringTest.ToStdStringViewEmpty",
        "SimpleStringTest.EqualityOperator",
        "SimpleStringTest.InequalityOperator",
        "SimpleStringTest.LessThanOperator",
        "SimpleStringTest.GreaterThanOperator",
        "SimpleStringTest.LessEqualOperator",
        "SimpleStringTest.GreaterEqualOperator",
        "SimpleStringTest.ComparisonNonSOO",
        "SimpleStringTest.EmptyStringComparison",
        "SimpleStringTest.SizeOfSimpleString",
        "SimpleStringTest.AssignmentSOOToNonSOO",
        "SimpleStringTest.AssignmentNonSOOToSOO",
        "SimpleStringTest.VeryLongString",
        "SimpleStringTest.ReassignSOOToNonSOO",
        "SimpleStringTest.ReassignNonSOOToSOO",
        "SimpleStringTest.ReassignNonSOOToNonSOO",
        "SimpleStringTest.SingleCharacter",
        "SimpleStringTest.CapacityMinus1",
        "SimpleStringTest.CapacityPlus1",
        "SimpleStringTest.NullTerminatedSOO",
        "SimpleStringTest.NullTerminatedNonSOO",
        "SimpleStringTest.CopyEmptyString",
        "SimpleStringTest.MoveEmptyString",
        "SimpleStringTest.SizeTooLarge",
    )
}
