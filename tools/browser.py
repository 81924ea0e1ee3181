"""Drive a headless Chromium over the DevTools protocol on a pipe — stdlib only, no network port.

Used to test the web view in a real browser and to take the screenshots in ``docs/``. Chromium speaks
the DevTools protocol as NUL-terminated JSON on file descriptors 3 (commands in) and 4 (replies out)
when started with ``--remote-debugging-pipe``, so nothing listens on a socket and no websocket client
is needed. The flags keep it from reaching the network (no background updates, sync or QUIC).

    with HeadlessChromium() as browser:
        browser.open("http://127.0.0.1:8765/", width=1280, height=800)
        browser.wait_for("document.querySelectorAll('.node').length > 0")
        browser.screenshot("page.png")
"""

from __future__ import annotations

import base64
import contextlib
import fcntl
import json
import os
import shutil
import subprocess
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from mission.core.errors import MissionError
from mission.core.files import atomic_write_bytes

CHROMIUM_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-default-apps",
    "--disable-extensions",
    "--hide-scrollbars",
    "--mute-audio",
    "--remote-debugging-pipe",
)


def find_chromium() -> str | None:
    """Path of a Chromium/Chrome binary (Debian's `chromium` first), or None."""
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


class BrowserError(MissionError):
    """Chromium is missing, crashed or did not answer in time."""


class HeadlessChromium:
    """One headless Chromium with one page, driven by DevTools commands."""

    def __init__(self, binary: str | None = None, timeout: float = 20.0) -> None:
        self.binary = binary or find_chromium()
        if self.binary is None:
            raise BrowserError("chromium not found: install Debian's `chromium` (scripts/bootstrap does)")
        self.timeout = timeout
        self._profile = tempfile.mkdtemp(prefix="mission-chromium-")
        self._next_id = 0
        self._replies: dict[int, dict[str, Any]] = {}
        self._events: list[dict[str, Any]] = []
        self._cv = threading.Condition()
        self._session: str | None = None
        cmd_r, cmd_w = os.pipe()
        out_r, out_w = os.pipe()

        def wire_fds() -> None:  # in the child: commands on fd 3, replies on fd 4
            high_r = fcntl.fcntl(cmd_r, fcntl.F_DUPFD, 10)  # out of the way of 3 and 4 first
            high_w = fcntl.fcntl(out_w, fcntl.F_DUPFD, 10)
            os.dup2(high_r, 3)
            os.dup2(high_w, 4)

        self._proc = subprocess.Popen(
            [self.binary, *CHROMIUM_FLAGS, f"--user-data-dir={self._profile}", "about:blank"],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            # fds 3 and 4 are made in the child by dup2 (inheritable); every other fd Python opened is
            # non-inheritable (PEP 446) and closes at exec, so close_fds (which would close 3 and 4) is off.
            close_fds=False,
            preexec_fn=wire_fds,  # only dup2: safe between fork and exec
        )
        os.close(cmd_r)
        os.close(out_w)
        self._out = os.fdopen(cmd_w, "wb", buffering=0)
        self._in = os.fdopen(out_r, "rb", buffering=0)
        self._reader = threading.Thread(target=self._read_loop, name="chromium-devtools", daemon=True)
        self._reader.start()
        target = self.send("Target.createTarget", {"url": "about:blank"}, browser=True)["targetId"]
        self._session = self.send("Target.attachToTarget", {"targetId": target, "flatten": True}, browser=True)[
            "sessionId"
        ]
        self.send("Page.enable")
        self.send("Runtime.enable")

    # -- protocol ---------------------------------------------------------------------------------
    def _read_loop(self) -> None:
        buf = b""
        while True:
            try:
                chunk = self._in.read(65536)
            except OSError:
                chunk = b""
            if not chunk:
                with self._cv:
                    self._cv.notify_all()
                return
            buf += chunk
            while b"\0" in buf:
                raw, buf = buf.split(b"\0", 1)
                msg = json.loads(raw)
                with self._cv:
                    if "id" in msg:
                        self._replies[msg["id"]] = msg
                    else:
                        self._events.append(msg)
                    self._cv.notify_all()

    def send(self, method: str, params: dict[str, Any] | None = None, *, browser: bool = False) -> dict[str, Any]:
        """One DevTools command; returns its result or raises BrowserError."""
        with self._cv:
            self._next_id += 1
            mid = self._next_id
        msg: dict[str, Any] = {"id": mid, "method": method, "params": params or {}}
        if not browser and self._session:
            msg["sessionId"] = self._session
        self._out.write(json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + self.timeout
        with self._cv:
            while mid not in self._replies:
                left = deadline - time.monotonic()
                if left <= 0 or self._proc.poll() is not None:
                    raise BrowserError(f"chromium did not answer {method} within {self.timeout:.0f} s")
                self._cv.wait(min(left, 0.5))
            reply = self._replies.pop(mid)
        if "error" in reply:
            raise BrowserError(f"chromium: {method}: {reply['error'].get('message', reply['error'])}")
        return reply.get("result", {})

    # -- page -------------------------------------------------------------------------------------
    def open(self, url: str, *, width: int = 1280, height: int = 800, scale: float = 1.0) -> None:
        """Load `url` in a `width`×`height` viewport and wait for its load event."""
        self.send(
            "Emulation.setDeviceMetricsOverride",
            {"width": width, "height": height, "deviceScaleFactor": scale, "mobile": False},
        )
        with self._cv:
            self._events.clear()
        self.send("Page.navigate", {"url": url})
        deadline = time.monotonic() + self.timeout
        with self._cv:
            while not any(e.get("method") == "Page.loadEventFired" for e in self._events):
                left = deadline - time.monotonic()
                if left <= 0:
                    raise BrowserError(f"{url} did not load within {self.timeout:.0f} s")
                self._cv.wait(min(left, 0.5))

    def evaluate(self, expression: str) -> Any:
        """The value of a JavaScript expression in the page (promises awaited)."""
        res = self.send("Runtime.evaluate", {"expression": expression, "returnByValue": True, "awaitPromise": True})
        if "exceptionDetails" in res:
            detail = res["exceptionDetails"]
            text = detail.get("exception", {}).get("description") or detail.get("text")
            raise BrowserError(f"javascript error: {text}")
        return res.get("result", {}).get("value")

    def wait_for(self, expression: str, timeout: float | None = None, poll: float = 0.05) -> Any:
        """Poll until `expression` is truthy; returns its value or raises BrowserError at the timeout."""
        deadline = time.monotonic() + (timeout or self.timeout)
        while True:
            value = self.evaluate(expression)
            if value:
                return value
            if time.monotonic() > deadline:
                raise BrowserError(f"timed out waiting for: {expression}")
            with self._cv:  # not a fixed sleep: wakes early on any browser event
                self._cv.wait(poll)

    def console_errors(self) -> list[str]:
        """Exceptions and console errors the page raised so far."""
        with self._cv:
            events = list(self._events)
        out = []
        for e in events:
            if e.get("method") == "Runtime.exceptionThrown":
                d = e["params"]["exceptionDetails"]
                out.append(d.get("exception", {}).get("description") or d.get("text", "?"))
            elif e.get("method") == "Runtime.consoleAPICalled" and e["params"].get("type") == "error":
                out.append(" ".join(str(a.get("value", a.get("description", ""))) for a in e["params"]["args"]))
        return out

    def screenshot(self, path: str | Path, *, full_page: bool = False) -> Path:
        """A PNG of the viewport (or the whole page) at `path`."""
        params: dict[str, Any] = {"format": "png"}
        if full_page:
            size = self.evaluate("[document.documentElement.scrollWidth, document.documentElement.scrollHeight]")
            params["clip"] = {"x": 0, "y": 0, "width": size[0], "height": size[1], "scale": 1}
            params["captureBeyondViewport"] = True
        data = base64.b64decode(self.send("Page.captureScreenshot", params)["data"])
        return atomic_write_bytes(path, data)

    # -- lifecycle --------------------------------------------------------------------------------
    def close(self) -> None:
        with contextlib.suppress(OSError):  # no reply to wait for: the browser exits
            self._out.write(json.dumps({"id": 0, "method": "Browser.close"}).encode() + b"\0")
        try:
            self._proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait(timeout=5)
        for f in (self._out, self._in):
            with contextlib.suppress(OSError):
                f.close()
        shutil.rmtree(self._profile, ignore_errors=True)

    def __enter__(self) -> HeadlessChromium:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
