"""Groot2's log files: BehaviorTree.CPP's FileLogger2 format (``.btlog``), written during a run and read back.

``mission run --btlog run.btlog`` writes one; Groot2's *Log Replay* opens it, and so does
``mission viz --log run.btlog``. The layout (BT.CPP 4.x ``loggers/bt_file_logger_v2``), little endian:

====================  ==================================================================================
bytes                 what
====================  ==================================================================================
18                    ``BTCPP4-FileLogger2``
1                     format version, 1
4                     int32 N: length of the XML
N                     the tree XML with ``_uid`` attributes (the same text Groot2's monitor is sent)
8                     int64: when logging started, µs since the Unix epoch
9 each, to the end    a transition: 6 bytes µs since that start, uint16 node UID, uint8 status
                      (BT.CPP NodeStatus: 0 IDLE, 1 RUNNING, 2 SUCCESS, 3 FAILURE, 4 SKIPPED)
====================  ==================================================================================

A transition's time is the run's clock (simulated time in the simulation, ROS time on a robot) since
the first tick, so a replay's timeline is the mission's; every transition of one tick has that tick's
time. Transitions are flushed after every tick, so the log of a run that was killed is readable up to
its last tick (a torn last record is skipped when read).
"""

from __future__ import annotations

import logging
import struct
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mission.core.errors import MissionError
from mission.core.files import StreamedFile
from mission.core.observers import RunObserver, Tick
from mission.groot import protocol as p
from mission.groot.transitions import TransitionRecorder, watch_run

if TYPE_CHECKING:
    from mission.core.observers import Run

log = logging.getLogger(__name__)

MAGIC = b"BTCPP4-FileLogger2"
VERSION = 1
SUFFIX = ".btlog"
_XML_SIZE = struct.Struct("<i")
_START = struct.Struct("<q")


def is_btlog(path: str | Path) -> bool:
    """A .btlog by its first bytes (whatever its name), False for anything else or an unreadable file."""
    try:
        with open(path, "rb") as fh:
            return fh.read(len(MAGIC)) == MAGIC
    except OSError:
        return False


def header_bytes(xml: str, start_us: int) -> bytes:
    """Everything before the first transition."""
    data = xml.encode("utf-8")
    return MAGIC + bytes([VERSION]) + _XML_SIZE.pack(len(data)) + data + _START.pack(start_us)


class BtLogWriter(RunObserver):
    """Writes every node's status transitions to `path` (a .btlog) from the first tick to the end of the run.

    The file is created (and checked writable) when the writer is made, before the run starts. A .btlog holds
    one tree: in a run whose trees come and go (an action server's goals, ``on_tree``) it is the first tree
    the run has; its log ends when that tree stops or is replaced (with the halt: running nodes to IDLE), and
    later trees are not logged (said once)."""

    def __init__(self, path: str | Path, *, option: str = "--btlog") -> None:
        self.path = Path(path)
        if self.path.suffix != SUFFIX:
            raise MissionError(
                f"{option} {path}: expected a file name ending in {SUFFIX} (Groot2 opens logs by that suffix)"
            )
        self._file = StreamedFile(self.path, option, binary=True, warn=log.warning)
        self._recorder: TransitionRecorder | None = None
        self._tree: Any = None  # the py_trees tree the recorder visits
        self._logged = False  # the header (one tree) is written
        self._t0: float | None = None
        self._last_us = 0
        self.transitions = 0

    def on_start(self, run: Run) -> None:
        if run.tree is not None:  # none: an action server's run before its first goal (on_tree brings it)
            self._watch(run)

    def on_tree(self, run: Run) -> None:
        if not self._logged:
            if run.tree is not None:
                self._watch(run)
            return
        if self._recorder is not None:
            self._recorder.finalise()  # the tree was halted: its running nodes go to IDLE, as in BT.CPP
            self._write_changes(self._last_us)
            self._detach()
            log.warning("--btlog %s: a .btlog holds one tree; the run's later trees are not logged", self.path)

    def _watch(self, run: Run) -> None:
        watched = watch_run(run, "--btlog")
        if watched is None:
            return
        tree, self._recorder = watched
        self._tree = run.tree
        self._logged = True
        self._write(header_bytes(tree.xml(run.factory), time.time_ns() // 1000))

    def _detach(self) -> None:
        if self._recorder is not None and self._tree is not None and self._recorder in self._tree.visitors:
            self._tree.visitors.remove(self._recorder)
        self._recorder, self._tree = None, None

    def on_tick(self, run: Run, tick: Tick) -> None:
        if self._recorder is None:
            return
        if self._t0 is None:
            self._t0 = tick.clock
        # the run's clock, never backwards in the file (ROS time may jump back when a bag loops)
        stamp = max(self._last_us, round((tick.clock - self._t0) * 1e6))
        self._last_us = stamp
        self._write_changes(stamp)

    def _write_changes(self, stamp: int) -> None:
        assert self._recorder is not None
        changes = self._recorder.drain()
        if changes:
            self._write(b"".join(p.pack_transition(stamp, t.uid, t.status) for t in changes))
            self.transitions += len(changes)

    def on_end(self, run: Run, outcome: Any) -> None:
        self._detach()
        self.close()

    def _write(self, data: bytes) -> None:
        self._file.write(data)

    def close(self) -> None:
        self._file.close()


@dataclass(frozen=True)
class LoggedTransition:
    t_us: int  # since the log's start
    uid: int
    status: int


@dataclass
class BtLog:
    """A .btlog read back."""

    path: Path
    xml: str
    start_us: int  # µs since the Unix epoch
    transitions: list[LoggedTransition] = field(default_factory=list)
    torn: bool = False  # the last record was cut off (the run was killed mid-write) and skipped


def read_btlog(path: str | Path) -> BtLog:
    """Read a FileLogger2 file; anything else is a MissionError naming the file and what was expected."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise MissionError(f"{path}: no such log (write one with `mission run --btlog {path}`)") from None
    except OSError as err:
        raise MissionError(f"{path}: cannot read the log ({err.strerror or err})") from None
    if not data.startswith(MAGIC):
        raise MissionError(
            f"{path}: not a Groot2 log; expected a file starting with {MAGIC.decode()} "
            "(BT.CPP FileLogger2, `mission run --btlog`)"
        )
    at = len(MAGIC)
    if len(data) < at + 1 + _XML_SIZE.size:
        raise MissionError(f"{path}: the log ends inside its header ({len(data)} bytes)")
    if data[at] != VERSION:
        raise MissionError(f"{path}: FileLogger2 format version {data[at]}; expected {VERSION}")
    (size,) = _XML_SIZE.unpack_from(data, at + 1)
    at += 1 + _XML_SIZE.size
    if size < 0 or len(data) < at + size + _START.size:
        raise MissionError(
            f"{path}: the log ends inside its tree XML (declared {size} bytes, {max(0, len(data) - at)} present)"
        )
    try:
        xml = data[at : at + size].decode("utf-8")
    except UnicodeDecodeError as err:
        raise MissionError(f"{path}: the tree XML is not UTF-8 ({err.reason} at byte {err.start})") from None
    at += size
    (start_us,) = _START.unpack_from(data, at)
    at += _START.size
    body = data[at:]
    whole = len(body) - len(body) % p.TRANSITION_SIZE
    transitions = [LoggedTransition(*p.unpack_transition(body, i)) for i in range(0, whole, p.TRANSITION_SIZE)]
    log_data = BtLog(path, xml, start_us, transitions, torn=whole != len(body))
    if log_data.torn:
        log.warning(
            "%s: the last transition was cut off mid-write (the run was interrupted); read %d before it",
            path,
            len(transitions),
        )
    return log_data
