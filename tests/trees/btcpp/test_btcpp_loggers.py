"""BehaviorTree.CPP 4.10 tests/gtest_loggers.cpp: every TEST is about a C++ logger class.

StdCoutLogger, FileLogger2, MinitraceLogger and SqliteLogger: their settings, the files they write (extension
checks, header, content) and their destructors. The trees ticked (a Sequence of two AlwaysSuccess, a Sleep) are
never asserted on. Our .btlog writer (FileLogger2's format, mission/groot/btlog.py) is tested in
tests/groot/test_btlog.py.
"""

from __future__ import annotations

_COUT = "tests the C++ StdCoutLogger's settings"
_FILE2 = "tests the C++ FileLogger2 class"
_TRACE = "tests the C++ MinitraceLogger class (minitrace JSON file)"
_SQLITE = "tests the C++ SqliteLogger class (SQLite database file)"

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "LoggerTest.StdCoutLogger_Creation": _COUT + ": created, flushed",
    "LoggerTest.StdCoutLogger_Enabled": _COUT + ": setEnabled/enabled",
    "LoggerTest.StdCoutLogger_TransitionToIdle": _COUT + ": enableTransitionToIdle/showsTransitionToIdle",
    "LoggerTest.StdCoutLogger_TimestampType": _COUT + ": setTimestampType",
    "LoggerTest.FileLogger2_Creation": _FILE2 + ": the .btlog file exists and is not empty",
    "LoggerTest.FileLogger2_WrongExtension": _FILE2 + ": its constructor throws for a .txt path",
    "LoggerTest.FileLogger2_FileHeader": _FILE2 + ": the file starts with BTCPP4-FileLogger2",
    "LoggerTest.FileLogger2_MultipleTicks": _FILE2 + ": the file exists after several ticks and halts",
    "LoggerTest.MinitraceLogger_Creation": _TRACE + ": the file exists and is not empty",
    "LoggerTest.MinitraceLogger_JsonContent": _TRACE + ": the file holds traceEvents",
    "LoggerTest.MinitraceLogger_TransitionTypes": _TRACE + ": enableTransitionToIdle, the file exists",
    "LoggerTest.SqliteLogger_Creation_db3": _SQLITE + ": a .db3 file is created",
    "LoggerTest.SqliteLogger_Creation_btdb": _SQLITE + ": a .btdb file is created",
    "LoggerTest.SqliteLogger_WrongExtension": _SQLITE + ": its constructor throws for a .sqlite path",
    "LoggerTest.SqliteLogger_AppendMode": _SQLITE + ": append mode grows the file",
    "LoggerTest.SqliteLogger_NoAppendMode": _SQLITE + ": no-append mode, the file exists",
    "LoggerTest.SqliteLogger_ExtraCallback": _SQLITE + ": setAdditionalCallback is called",
    "LoggerTest.SqliteLogger_ExecSqlStatement": _SQLITE + ": execSqlStatement",
    "LoggerTest.SqliteLogger_MultipleTicks": _SQLITE + ": the file exists after several ticks and halts",
    "LoggerTest.MultipleLoggers": "tests four C++ loggers (StdCout, FileLogger2, Minitrace, Sqlite) on one tree: "
    "their files exist",
    "LoggerTest.LoggerWithAsyncTree": _SQLITE + " on a tree with a Sleep: the file exists",
    "LoggerTest.Logger_EmptyTree": _SQLITE + " on a one-node tree: the file exists",
    "LoggerTest.Logger_DisabledDuringExecution": _SQLITE + ": setEnabled(false) while ticking, the file exists",
}
