"""Groot2 live monitoring of a running mission: BT.CPP's ``Groot2Publisher`` side of the protocol over ZeroMQ.

``mission run --groot [PORT]`` (default 1667, Groot2's own default) or the ROS node's ``groot_port``
attach a :class:`Groot2Publisher`; in Groot2, *Monitor* → connect to 127.0.0.1, port PORT. It binds a
REP socket on PORT and a PUB socket on PORT + 1, on 127.0.0.1 unless told otherwise (reach a robot's
monitor through ``ssh -L 1667:127.0.0.1:1667 -L 1668:127.0.0.1:1668 robot``). Served
(mission.groot.protocol has the bytes):

* FULLTREE — the tree file as the loader read it, expanded per subtree instance, every node with the
  ``_uid`` BT.CPP would give it, and the TreeNodesModel of the runner's factory (mission.groot.uids);
* STATUS — every node's status after the last tick (IDLE after a status as 10 + that status);
* BLACKBOARD — the entries of the blackboard (msgpack of ``{name: {key: value}}``) for each requested
  tree instance (the main tree's ID or a subtree's ``_fullpath``): every instance sees the one store
  the mission's keys live in (mission.groot.blackboard_export);
* TOGGLE_RECORDING / GET_TRANSITIONS — the transitions since recording started (the last 1000), in
  wall-clock µs;
* HOOKS_DUMP (no hooks: ``[]``), REMOVE_ALL_HOOKS and DISABLE_ALL_HOOKS are acknowledged; inserting a
  hook or breakpoint is refused with an error reply (a breakpoint would stop the tick).

A run's tree may come and go (an action server's goals: ``on_tree``). Until the first tree, FULLTREE is an
error reply ("no tree yet"). Each new tree is served with a new tree UUID in every reply header, which is how
Groot2 tells a new tree from the old one and asks for FULLTREE again (as it does when BT.CPP's executor makes
a new publisher for a new tree); transitions recorded for the old tree are dropped. A tree that stops stays
served, halted as BT.CPP halts one: its running nodes IDLE after RUNNING.

The requests are answered on a thread of their own; the tick thread only updates a status buffer under a
lock, so a connected Groot2 costs the tick nothing but the visitor (mission.groot.transitions).
"""

from __future__ import annotations

import collections
import sys
import threading
import time
from typing import TYPE_CHECKING, Any

import msgpack
import zmq

from mission.core.errors import MissionError
from mission.core.observers import RunObserver, Tick
from mission.groot import protocol as p
from mission.groot.blackboard_export import blackboard_entries
from mission.groot.transitions import Transition, TransitionRecorder, watch_run
from mission.groot.uids import UidTree

if TYPE_CHECKING:
    from mission.core.observers import Run


DEFAULT_PORT = 1667  # Groot2's and BT.CPP's default
HOST = "127.0.0.1"
MAX_RECORDED = 1000  # transitions kept between two GET_TRANSITIONS, as BT.CPP keeps
_POLL_MS = 100


def _wall_us() -> int:
    return time.time_ns() // 1000


class Groot2Publisher(RunObserver):
    """Serves Groot2 from the moment it is made (so a busy port fails before the run starts) until the run ends.

    `port` 0 picks a free pair (PORT, PORT + 1); :attr:`port` is the one bound. `option` names the
    setting in error messages (``--groot``, ``-p groot_port``)."""

    def __init__(
        self, port: int = DEFAULT_PORT, host: str = HOST, *, option: str = "--groot", quiet: bool = False
    ) -> None:
        self.host = host
        self.quiet = quiet
        self._ctx = zmq.Context()
        self._server = self._ctx.socket(zmq.REP)
        self._publisher = self._ctx.socket(zmq.PUB)
        for sock in (self._server, self._publisher):
            sock.setsockopt(zmq.LINGER, 0)
            sock.setsockopt(zmq.SNDTIMEO, 1000)
        try:
            self.port = self._bind_pair(port)
        except zmq.ZMQError as err:
            self._close_sockets()
            raise MissionError(
                f"{option} {port}: cannot listen on {host}:{port} and {host}:{port + 1} ({err.strerror}); "
                "expected two free TCP ports (PORT for requests, PORT + 1 for notifications); "
                "give another port, or 0 for any free pair"
            ) from None
        self.tree_uuid = p.new_tree_uuid()
        self._lock = threading.Lock()
        self._xml: bytes | None = None
        self._status = bytearray()
        self._status_at: dict[int, int] = {}  # uid → offset of its status byte in _status
        self._instances: dict[str, str] = {}  # blackboard name Groot2 asks for → instance path
        self._recorder: TransitionRecorder | None = None
        self._tree: Any = None  # the py_trees tree the recorder visits (the run's may have changed since)
        self._run: Run | None = None
        self._recording = False
        self._recording_t0 = 0
        self._recorded: collections.deque[bytes] = collections.deque(maxlen=MAX_RECORDED)
        self._stop = threading.Event()
        self.requests = 0  # answered so far (tests, the log line at the end)
        self._thread = threading.Thread(target=self._serve, name="mission-groot2", daemon=True)
        self._thread.start()

    @property
    def address(self) -> str:
        return f"tcp://{self.host}:{self.port}"

    def _bind_pair(self, port: int) -> int:
        if port:
            self._server.bind(f"tcp://{self.host}:{port}")
            self._publisher.bind(f"tcp://{self.host}:{port + 1}")
            return port
        for _ in range(50):  # any free pair: a random port for requests, then the one above it
            chosen = self._server.bind_to_random_port(f"tcp://{self.host}", min_port=20000, max_port=65000)
            try:
                self._publisher.bind(f"tcp://{self.host}:{chosen + 1}")
                return chosen
            except zmq.ZMQError:
                self._server.unbind(f"tcp://{self.host}:{chosen}")
        raise zmq.ZMQError(zmq.EADDRINUSE, "no free pair of ports found")

    # -- RunObserver ------------------------------------------------------------------------------
    def on_start(self, run: Run) -> None:
        if run.tree is None:  # an action server's run before its first goal: the tree comes with on_tree
            waiting = " (no tree yet: waiting for a goal)"
        else:
            waiting = ""
            self._watch(run, new_uuid=False)
        if not self.quiet:
            print(
                f"mission: Groot2 monitor on {self.host}:{self.port} (Groot2 → Monitor → connect){waiting}",
                file=sys.stderr,
                flush=True,
            )

    def on_tree(self, run: Run) -> None:
        """The old tree is let go (halted, as it was); a new one is served under a new tree UUID."""
        self._unwatch(halted=True)
        if run.tree is not None:
            self._watch(run, new_uuid=True)

    def _watch(self, run: Run, *, new_uuid: bool) -> None:
        watched = watch_run(run, "Groot2 monitor")
        if watched is None:
            return
        tree, recorder = watched
        xml = tree.xml(run.factory).encode("utf-8")
        status, status_at = _status_buffer(tree)
        with self._lock:
            self._xml, self._status, self._status_at = xml, status, status_at
            self._instances = {inst.name: inst.path for inst in tree.instances} | {"": ""}
            self._recorder, self._tree, self._run = recorder, run.tree, run
            if new_uuid:
                self.tree_uuid = p.new_tree_uuid()
                self._recorded.clear()  # the old tree's UIDs: meaningless in the new one

    def _unwatch(self, *, halted: bool) -> None:
        """Detach the recorder from the tree it watches; `halted`: that tree was halted (a goal ended), so its
        running nodes go to IDLE as BT.CPP's haltTree leaves them."""
        recorder, tree = self._recorder, self._tree
        if recorder is None:
            return
        if tree is not None and recorder in tree.visitors:
            tree.visitors.remove(recorder)
        if halted:
            recorder.finalise()
            self._apply(recorder, recorder.drain())
        with self._lock:
            if self._recorder is recorder:
                self._recorder, self._tree = None, None

    def on_tick(self, run: Run, tick: Tick) -> None:
        recorder = self._recorder
        if recorder is not None:
            self._apply(recorder, recorder.drain())

    def _apply(self, recorder: TransitionRecorder, changes: list[Transition]) -> None:
        if not changes:
            return
        now = _wall_us()
        with self._lock:
            if recorder is not self._recorder:  # the tree was replaced meanwhile (another thread)
                return
            for t in changes:
                shown = p.IDLE_FROM + t.previous if t.status == p.IDLE else t.status
                self._status[self._status_at[t.uid]] = shown
                if self._recording:
                    self._recorded.append(p.pack_transition(now - self._recording_t0, t.uid, t.status))

    def on_end(self, run: Run, outcome: Any) -> None:
        self._unwatch(halted=False)
        self.close()

    def close(self) -> None:
        """Stop answering and let go of both ports (idempotent)."""
        if self._stop.is_set():
            return
        self._stop.set()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout=2.0)
        self._close_sockets()

    def _close_sockets(self) -> None:
        self._server.close(linger=0)
        self._publisher.close(linger=0)
        self._ctx.term()

    # -- the request loop -------------------------------------------------------------------------
    def _serve(self) -> None:
        poller = zmq.Poller()
        poller.register(self._server, zmq.POLLIN)
        while not self._stop.is_set():
            try:
                if not poller.poll(_POLL_MS):
                    continue
                request = self._server.recv_multipart()
            except zmq.ZMQError:  # the context is going away
                return
            try:
                reply = self.answer(request)
            except Exception as err:  # a bad request must not end the monitor: say why, keep serving
                reply = [b"error", f"{type(err).__name__}: {err}".encode()]
            try:
                self._server.send_multipart(reply)
                self.requests += 1
            except zmq.ZMQError:
                return

    def answer(self, request: list[bytes]) -> list[bytes]:
        """The reply parts for one request's parts (the protocol, without sockets)."""
        if not request:
            return _error("empty request")
        try:
            header = p.parse_request_header(request[0])
        except ValueError:
            return _error("wrong request header")
        kind = header.type
        if kind in _NEEDS_ARGUMENT and len(request) != 2:
            return _error("must be 2 parts message")
        with self._lock:  # the tree, its statuses and its UUID as one (a new tree may be swapped in meanwhile)
            xml, status, tree_uuid = self._xml, bytes(self._status), self.tree_uuid
        first = p.reply_header(header, tree_uuid)
        if kind == p.FULLTREE:
            if xml is None:
                return _error("no tree yet: the run has not started, or waits for a goal")
            return [first, xml]
        if kind == p.STATUS:
            return [first, status]
        if kind == p.BLACKBOARD:
            return [first, self._blackboards(request[1].decode("utf-8", "replace"))]
        if kind == p.HOOKS_DUMP:
            return [first, b"[]"]
        if kind in (p.REMOVE_ALL_HOOKS, p.DISABLE_ALL_HOOKS):
            return [first]
        if kind in (p.HOOK_INSERT, p.HOOK_REMOVE, p.BREAKPOINT_UNLOCK):
            return _error("breakpoints and hooks are not supported by this executor (mission, py_trees)")
        if kind == p.TOGGLE_RECORDING:
            return self._toggle_recording(first, request[1])
        if kind == p.GET_TRANSITIONS:
            with self._lock:
                recorded, self._recorded = b"".join(self._recorded), collections.deque(maxlen=MAX_RECORDED)
            return [first, recorded]
        return _error("Request not recognized")

    def _blackboards(self, names: str) -> bytes:
        entries: dict[str, Any] | None = None
        dump: dict[str, Any] = {}
        for name in names.split(";"):
            if name in self._instances:
                entries = blackboard_entries() if entries is None else entries
                dump[name] = entries
        return msgpack.packb(dump, use_bin_type=True)

    def _toggle_recording(self, first: bytes, command: bytes) -> list[bytes]:
        if command == b"start":
            now = _wall_us()
            with self._lock:
                self._recording, self._recording_t0 = True, now
                self._recorded.clear()
            return [first, str(now).encode()]
        if command == b"stop":
            with self._lock:
                self._recording = False
            return [first]
        return _error(f"expected start or stop, got {command[:20]!r}")


_NEEDS_ARGUMENT = frozenset({p.BLACKBOARD, p.HOOK_INSERT, p.HOOK_REMOVE, p.BREAKPOINT_UNLOCK, p.TOGGLE_RECORDING})


def _error(message: str) -> list[bytes]:
    return [b"error", message.encode("utf-8")]


def _status_buffer(tree: UidTree) -> tuple[bytearray, dict[int, int]]:
    """Every node IDLE, in STATUS order; uid → offset of its status byte."""
    buffer = bytearray()
    offsets: dict[int, int] = {}
    for uid in tree.status_order():
        buffer += p.STATUS_ENTRY.pack(uid, p.IDLE)
        offsets[uid] = len(buffer) - 1
    return buffer, offsets
