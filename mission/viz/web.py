"""The live web view: `mission run --serve` (and the ROS node) serve the mission page on 127.0.0.1.

Standard library only: a ThreadingHTTPServer, server-sent events for the ticks, no CDN. Endpoints:

* ``/``              the page (mission.viz.html, live mode) with the run's history so far;
* ``/events``        server-sent events: ``header``, one ``tick`` per tick (id = tick), ``end``;
                     ``?after=N`` or the browser's Last-Event-ID resumes without gaps;
* ``/camera.jpg``    the newest camera frame with detection overlays (mission.viz.overlay), JPEG;
* ``/tree.svg``      the tree with the latest statuses; ``POST /api/tree.svg`` draws a posted tree
                     (the page's "Open log…");
* ``/api/header``, ``/api/history?after=N``   JSON, for tools and tests.

A run's tree may come and go (an action server's goals, ``on_tree``): with no tree yet the page says it waits
for a goal; a new tree gets a new header (``generation`` counts them; an open page reloads itself) and a fresh
history; when the tree stops, the page keeps the last tree with its final statuses and says that no tree runs
(``running`` false in the header).

It binds 127.0.0.1 only, never another interface. The server starts when the observer is created, so a
port already in use is reported before the simulation spends time starting.
"""

from __future__ import annotations

import errno
import json
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any
from urllib.parse import parse_qs, urlparse

from mission.core import blackboard as bbk
from mission.core.errors import MissionError
from mission.core.observers import RunObserver, Tick
from mission.viz.html import render_page, tree_svg_for_page
from mission.viz.model import apply_tick, from_snapshot
from mission.viz.overlay import draw_detections, encode_jpeg
from mission.viz.probe import TickProbe, probe_for, release_probe
from mission.viz.svg import render_svg
from mission.viz.tick_log import header as make_header

HOST = "127.0.0.1"
MAX_HISTORY = 20_000  # ticks kept for scrubbing (≈1.5 kB each)
PAGE_HISTORY = 3_000  # ticks embedded in a freshly loaded page; older ones stay scrubbable via the API
NO_GOAL = "no goal: waiting for a tree"  # the page of a run with no tree (an action server before its first goal)
STOPPED = "no tree runs (the goal ended); the last tree's final statuses are shown"


def _dumps(obj: Any) -> str:
    return json.dumps(obj, separators=(",", ":"), ensure_ascii=False, default=str)


class LiveView(RunObserver):
    """A run observer that serves the live page (pacing a simulation to be watchable is the runner's
    WallClockPacer, not this page's job).

    `hold` keeps serving after the run until
    Ctrl-C (an interactive `mission run --serve`); `close_at_end` False leaves the server up for the caller
    to :meth:`close` (tests, screenshots, a ROS node that restarts trees).
    """

    def __init__(
        self,
        port: int = 8765,
        *,
        hold: bool = False,
        close_at_end: bool = True,
        quiet: bool = False,
        option: str = "--port",
    ) -> None:
        self.close_at_end = close_at_end
        self.hold = hold
        self.quiet = quiet
        self._cv = threading.Condition()
        self._header: dict[str, Any] | None = None
        self._generation = 0  # headers sent so far: one per tree the run had (and one while it had none)
        self._history: list[dict[str, Any]] = []
        self._frame: tuple[int, Any, list[Any]] | None = None  # (tick, Frame, detections)
        self._jpeg: tuple[int, bytes] | None = None
        self._ended = False
        self._closing = False
        self._probe: TickProbe | None = None  # the probe of the tree shown, while that tree runs
        self.server = _bind(port, self, option)
        self.port = int(self.server.server_address[1])
        self.url = f"http://{HOST}:{self.port}/"
        self._thread = threading.Thread(target=self.server.serve_forever, name="mission-live-view", daemon=True)
        self._thread.start()

    # -- RunObserver ------------------------------------------------------------------------------
    def on_start(self, runner: Any) -> None:
        self._show(runner)
        if not self.quiet:
            print(f"mission: live view at {self.url}", file=sys.stderr, flush=True)

    def on_tree(self, runner: Any) -> None:
        """A new tree is shown from its first tick; a stopped one stays on the page with its final statuses."""
        if runner.tree is not None:
            self._show(runner)
            return
        with self._cv:
            old, self._probe = self._probe, None
            if self._header is not None:
                self._generation += 1
                self._header = {**self._header, "generation": self._generation, "running": False, "notice": STOPPED}
            self._cv.notify_all()
        if old is not None:
            release_probe(old)

    def _show(self, runner: Any) -> None:
        """Probe the run's tree (none: the page waits for a goal) and start its history afresh."""
        probe = None if runner.tree is None else probe_for(runner)
        header = make_header(runner, runner.world, probe)
        with self._cv:
            old, self._probe = self._probe, probe
            self._generation += 1
            header.update(generation=self._generation, running=probe is not None, notice="" if probe else NO_GOAL)
            self._header = header
            self._history.clear()
            self._ended = False
            self._cv.notify_all()
        if old is not None:
            release_probe(old)

    def on_tick(self, runner: Any, tick: Tick) -> None:
        probe = self._probe
        rec = None if probe is None else probe.record(runner, tick.ground_truth)
        frame = runner.get(bbk.FRAME)
        with self._cv:
            if rec is not None and probe is self._probe:  # not a tree replaced meanwhile (another thread)
                self._history.append(rec)
                if len(self._history) > MAX_HISTORY:
                    del self._history[: len(self._history) - MAX_HISTORY]
            if frame is not None:  # perception goes on without a tree: /camera.jpg stays current
                self._frame = (int(runner.ticks), frame, list(runner.get(bbk.DETECTIONS, []) or []))
            self._cv.notify_all()

    def on_end(self, runner: Any, outcome: Any) -> None:
        with self._cv:
            self._ended = True
            probe, self._probe = self._probe, None
            self._cv.notify_all()
        if probe is not None:
            release_probe(probe)
        if self.hold and not self._closing:
            print(f"mission: run finished; the live view stays at {self.url} — Ctrl-C to stop", file=sys.stderr)
            try:
                while not self._closing:
                    with self._cv:
                        self._cv.wait(1.0)
            except KeyboardInterrupt:
                pass
        if self.close_at_end or self.hold:
            self.close()

    # -- data for handlers --------------------------------------------------------------------------
    def page(self) -> str:
        with self._cv:
            header = self._header
            hist = self._history[-PAGE_HISTORY:]
        if header is None:
            return render_page("live", None, header=None, title="mission — waiting for the run")
        if header.get("tree") is None:
            return render_page("live", None, header=header, title=f"mission — {NO_GOAL}", empty=NO_GOAL)
        root = from_snapshot(header["tree"])
        if hist:
            apply_tick(root, hist[-1]["nodes"])
        stopped = "" if header.get("running", True) else " (no tree runs)"
        return render_page(
            "live",
            root,
            header=header,
            ticks=hist,
            title=f"mission — {root.name}{stopped}",
            notice=header.get("notice", ""),
        )

    def history(self, after: int) -> list[dict[str, Any]]:
        with self._cv:
            return [r for r in self._history if r["tick"] > after]

    def header(self) -> dict[str, Any] | None:
        with self._cv:
            return self._header

    def camera_jpeg(self) -> bytes | None:
        with self._cv:
            frame = self._frame
            cached = self._jpeg
        if frame is None:
            return None
        if cached is not None and cached[0] == frame[0]:
            return cached[1]
        tick, fr, dets = frame
        data = encode_jpeg(draw_detections(fr.image, dets, getattr(fr, "intrinsics", None)))
        with self._cv:
            self._jpeg = (tick, data)
        return data

    def tree_svg(self) -> str | None:
        with self._cv:
            header, last = self._header, (self._history[-1] if self._history else None)
        if header is None or header.get("tree") is None:
            return None
        root = from_snapshot(header["tree"])
        if last is not None:
            apply_tick(root, last["nodes"])
        stopped = "" if header.get("running", True) else " (no tree runs)"
        return render_svg(root, feedback=True, title=f"{root.name} — tick {last['tick'] if last else 0}{stopped}")

    def stream(self, handler: BaseHTTPRequestHandler, after: int) -> None:
        """Send events until the client goes away or the server closes (what is pending is sent first)."""
        sent_header: dict[str, Any] | None = None
        sent_end = False
        last_beat = time.monotonic()
        while True:
            with self._cv:
                while True:
                    header, ended, closing = self._header, self._ended, self._closing
                    new = [r for r in self._history if r["tick"] > after]
                    if new or closing or (header is not sent_header) or (ended and not sent_end):
                        break
                    if time.monotonic() - last_beat > 10:
                        break
                    self._cv.wait(1.0)
            chunks: list[str] = []
            if header is not None and header is not sent_header:
                about = {"created": header.get("created"), "generation": header.get("generation")}
                chunks.append(f"event: header\ndata: {_dumps(about)}\n\n")
                sent_header = header
            for r in new:
                chunks.append(f"id: {r['tick']}\nevent: tick\ndata: {_dumps(r)}\n\n")
                after = r["tick"]
            if ended and not sent_end:
                chunks.append("event: end\ndata: {}\n\n")
                sent_end = True
            if not chunks:
                chunks.append(": keep-alive\n\n")
            handler.wfile.write("".join(chunks).encode("utf-8"))
            handler.wfile.flush()
            last_beat = time.monotonic()
            if closing:
                return

    # -- lifecycle ------------------------------------------------------------------------------------
    def close(self) -> None:
        with self._cv:
            if self._closing:
                return
            self._closing = True
            self._cv.notify_all()
        self.server.shutdown()
        self.server.server_close()
        self._thread.join(timeout=5)


class _Handler(BaseHTTPRequestHandler):
    server_version = "mission-live-view"
    protocol_version = "HTTP/1.1"

    @property
    def view(self) -> LiveView:
        return self.server.view  # type: ignore[attr-defined, no-any-return]

    def log_message(self, format: str, *args: Any) -> None:  # quiet: the run's output is what matters
        pass

    def _send(self, code: int, body: bytes, ctype: str, cache: bool = False) -> None:
        self.send_response(code)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "max-age=60" if cache else "no-store")
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _json(self, obj: Any) -> None:
        self._send(200, _dumps(obj).encode("utf-8"), "application/json")

    def do_HEAD(self) -> None:
        self.do_GET()

    def do_GET(self) -> None:
        url = urlparse(self.path)
        query = parse_qs(url.query)
        try:
            if url.path in ("/", "/index.html"):
                self._send(200, self.view.page().encode("utf-8"), "text/html; charset=utf-8")
            elif url.path == "/events":
                after = int(self.headers.get("Last-Event-ID") or query.get("after", ["-1"])[0])
                self.send_response(200)
                self.send_header("Content-Type", "text/event-stream")
                self.send_header("Cache-Control", "no-store")
                self.send_header("Connection", "close")
                self.end_headers()
                self.close_connection = True
                self.view.stream(self, after)
            elif url.path == "/camera.jpg":
                data = self.view.camera_jpeg()
                if data is None:
                    self._send(404, b"no camera frame yet", "text/plain")
                else:
                    self._send(200, data, "image/jpeg")
            elif url.path == "/tree.svg":
                svg = self.view.tree_svg()
                if svg is None:
                    self._send(404, b"no tree to draw: the run has not started or waits for a goal", "text/plain")
                else:
                    self._send(200, svg.encode("utf-8"), "image/svg+xml")
            elif url.path == "/api/header":
                self._json(self.view.header())
            elif url.path == "/api/history":
                self._json(self.view.history(int(query.get("after", ["-1"])[0])))
            elif url.path == "/healthz":
                self._send(200, b"ok", "text/plain")
            else:
                self._send(404, b"not found", "text/plain")
        except (BrokenPipeError, ConnectionResetError):
            pass
        except ValueError as err:
            self._send(400, f"bad request: {err}".encode(), "text/plain")

    def do_POST(self) -> None:
        url = urlparse(self.path)
        if url.path != "/api/tree.svg":
            self._send(404, b"not found", "text/plain")
            return
        try:
            length = int(self.headers.get("Content-Length") or 0)
            if length > 5_000_000:
                raise ValueError("tree too large")
            tree = json.loads(self.rfile.read(length))
            root = from_snapshot(tree)
            self._send(200, tree_svg_for_page(root, live=True).encode("utf-8"), "image/svg+xml")
        except (ValueError, KeyError, TypeError, AttributeError) as err:
            self._send(400, f"expected a tree (a tick log header's `tree`): {err}".encode(), "text/plain")


class _Server(ThreadingHTTPServer):
    daemon_threads = True
    allow_reuse_address = True


def _bind(port: int, view: LiveView, option: str = "--port") -> _Server:
    """The live view's server on 127.0.0.1:`port`; errors name the option that chose the port, as the user
    gave it (`--port` for `mission run`, `-p serve_port` for the ROS node)."""
    name = f"{option} {port}" if option.startswith("--") else f"{option}:={port}"
    advice = f"{option} N, or {option} 0" if option.startswith("--") else f"{option}:=N, or {option}:=0"
    try:
        server = _Server((HOST, int(port)), _Handler)
    except OSError as err:
        if err.errno == errno.EADDRINUSE:
            raise MissionError(
                f"{name}: {HOST}:{port} is already in use (another live view?); "
                f"choose another with {advice} for any free port"
            ) from None
        raise MissionError(f"{name}: cannot serve on {HOST}:{port} ({err.strerror or err})") from None
    server.view = view  # type: ignore[attr-defined]
    return server
