"""Drive a headless Chromium over the DevTools protocol, standard library only.

For the viewer's tests and for the screenshots in ``docs/viewer.md``: load a page, collect
console errors and uncaught exceptions, evaluate JavaScript, drag the mouse, take a
screenshot. Chromium is started with ``--remote-debugging-pipe`` (the protocol's JSON
messages, ``\\0``-terminated, on file descriptors 3 and 4), so no websocket library and no
network port are needed. WebGL runs on SwiftShader (software), as on a machine without a GPU.

Not a general browser-automation library: one page, one tab, no frames.
"""

from __future__ import annotations

import base64
import fcntl
import json
import os
import select
import shutil
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

__all__ = ["Browser", "BrowserError", "find_chromium"]


class BrowserError(RuntimeError):
    """Chromium failed, timed out, or a command returned an error."""


def find_chromium() -> str | None:
    """Path of a Chromium or Chrome executable on ``PATH`` (None when there is none)."""
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


def _high_fd(fd: int) -> int:
    new = fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, 10)
    os.close(fd)
    return new


class Browser:
    """A headless Chromium with one tab (use as a context manager).

    Parameters
    ----------
    width, height : int
        Viewport size, CSS pixels.
    executable : str, optional
        Default :func:`find_chromium`.
    timeout : float
        Seconds to wait for any one answer or page load.

    Attributes
    ----------
    errors : list of str
        Console errors, uncaught exceptions and error log entries, in order.
    """

    def __init__(
        self, width: int = 1200, height: int = 900, *, executable: str | None = None, timeout: float = 60.0
    ) -> None:
        exe = executable or find_chromium()
        if exe is None:
            raise BrowserError(
                "chromium: expected a chromium executable on PATH; got none (apt install chromium)"
            )
        self.timeout = timeout
        self.errors: list[str] = []
        self._events: list[dict[str, Any]] = []
        self._next = 0
        self._buf = b""
        self._profile = tempfile.mkdtemp(prefix="em-chromium-")
        to_child_r, to_child_w = (_high_fd(fd) for fd in os.pipe())
        from_child_r, from_child_w = (_high_fd(fd) for fd in os.pipe())

        def _fds() -> None:  # in the child: its fd 3 reads our commands, fd 4 writes answers
            os.dup2(to_child_r, 3)
            os.dup2(from_child_w, 4)

        args = [
            exe,
            "--headless",
            "--no-sandbox",
            "--remote-debugging-pipe",
            f"--user-data-dir={self._profile}",
            "--no-first-run",
            "--no-default-browser-check",
            "--disable-extensions",
            "--disable-background-networking",
            "--mute-audio",
            "--hide-scrollbars",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            f"--window-size={width},{height}",
            "about:blank",
        ]
        self._proc = subprocess.Popen(
            args,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            preexec_fn=_fds,  # only dup2 in the child
            close_fds=False,
        )
        os.close(to_child_r)
        os.close(from_child_w)
        self._w, self._r = to_child_w, from_child_r
        try:
            target = self._call("Target.createTarget", {"url": "about:blank"}, session=False)["targetId"]
            self._session = self._call(
                "Target.attachToTarget", {"targetId": target, "flatten": True}, session=False
            )["sessionId"]
            for domain in ("Page", "Runtime", "Log"):
                self._call(f"{domain}.enable")
            self._call(
                "Emulation.setDeviceMetricsOverride",
                {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False},
            )
        except Exception:
            self.close()
            raise

    # -- protocol ---------------------------------------------------------------------------
    def _send(self, msg: dict[str, Any]) -> None:
        os.write(self._w, json.dumps(msg).encode() + b"\0")

    def _read_message(self, deadline: float) -> dict[str, Any]:
        while b"\0" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise BrowserError("chromium: expected an answer; got none in time")
            ready, _, _ = select.select([self._r], [], [], left)
            if ready:
                chunk = os.read(self._r, 1 << 20)
                if not chunk:
                    raise BrowserError("chromium: the browser closed its pipe (it crashed or exited)")
                self._buf += chunk
        raw, self._buf = self._buf.split(b"\0", 1)
        msg = json.loads(raw)
        if "method" in msg:
            self._on_event(msg)
        return msg

    def _on_event(self, msg: dict[str, Any]) -> None:
        method, p = msg["method"], msg.get("params", {})
        if method == "Runtime.exceptionThrown":
            d = p.get("exceptionDetails", {})
            text = d.get("exception", {}).get("description") or d.get("text", "exception")
            self.errors.append(f"uncaught: {text}")
        elif method == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
            args = " ".join(str(a.get("value", a.get("description", ""))) for a in p.get("args", []))
            self.errors.append(f"console.{p['type']}: {args}")
        elif method == "Log.entryAdded" and p.get("entry", {}).get("level") == "error":
            e = p["entry"]
            self.errors.append(f"log: {e.get('text', '')} {e.get('url', '')}".strip())
        self._events.append(msg)

    def _call(self, method: str, params: dict[str, Any] | None = None, *, session: bool = True) -> dict:
        self._next += 1
        msg: dict[str, Any] = {"id": self._next, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = self._session
        self._send(msg)
        deadline = time.monotonic() + self.timeout
        while True:
            ans = self._read_message(deadline)
            if ans.get("id") == self._next:
                if "error" in ans:
                    raise BrowserError(f"{method}: {ans['error'].get('message', ans['error'])}")
                return ans.get("result", {})

    # -- page -------------------------------------------------------------------------------
    def open(self, url: str | os.PathLike[str]) -> None:
        """Load ``url`` (a path is opened as ``file://``) and wait for its load event."""
        if not str(url).startswith(("file:", "http:", "https:", "about:", "data:")):
            url = Path(url).resolve().as_uri()
        self._events.clear()
        self._call("Page.navigate", {"url": str(url)})
        deadline = time.monotonic() + self.timeout
        while not any(e.get("method") == "Page.loadEventFired" for e in self._events):
            self._read_message(deadline)

    def evaluate(self, expression: str, *, await_promise: bool = True) -> Any:
        """The value of a JavaScript expression (JSON-able), awaiting a promise."""
        res = self._call(
            "Runtime.evaluate",
            {"expression": expression, "returnByValue": True, "awaitPromise": await_promise},
        )
        if "exceptionDetails" in res:
            d = res["exceptionDetails"]
            raise BrowserError(f"evaluate: {d.get('exception', {}).get('description') or d.get('text')}")
        return res.get("result", {}).get("value")

    def wait_for(self, expression: str, timeout: float | None = None) -> Any:
        """Poll ``expression`` until it is truthy; return its value."""
        deadline = time.monotonic() + (timeout or self.timeout)
        while True:
            value = self.evaluate(expression)
            if value:
                return value
            if time.monotonic() > deadline:
                raise BrowserError(f"wait_for: expected {expression} to become true; it did not in time")
            time.sleep(0.05)

    def mouse_drag(self, x0: float, y0: float, x1: float, y1: float, steps: int = 8) -> None:
        """Press the left button at (x0, y0), move to (x1, y1), release (CSS pixels)."""
        self._call("Input.dispatchMouseEvent", {"type": "mouseMoved", "x": x0, "y": y0})
        self._call(
            "Input.dispatchMouseEvent",
            {"type": "mousePressed", "x": x0, "y": y0, "button": "left", "buttons": 1, "clickCount": 1},
        )
        for k in range(1, steps + 1):
            x = x0 + (x1 - x0) * k / steps
            y = y0 + (y1 - y0) * k / steps
            self._call(
                "Input.dispatchMouseEvent",
                {"type": "mouseMoved", "x": x, "y": y, "button": "left", "buttons": 1},
            )
        self._call(
            "Input.dispatchMouseEvent",
            {"type": "mouseReleased", "x": x1, "y": y1, "button": "left", "buttons": 0, "clickCount": 1},
        )

    def screenshot(self, path: str | os.PathLike[str] | None = None, *, clip: dict | None = None) -> bytes:
        """A PNG of the viewport (or of ``clip``: ``{"x", "y", "width", "height"}``)."""
        params: dict[str, Any] = {"format": "png"}
        if clip is not None:
            params["clip"] = {**clip, "scale": 1}
        data = base64.b64decode(self._call("Page.captureScreenshot", params)["data"])
        if path is not None:
            Path(path).write_bytes(data)
        return data

    def close(self) -> None:
        """Stop Chromium and remove its temporary profile."""
        try:
            if self._proc.poll() is None:
                try:
                    self._send({"id": 0, "method": "Browser.close", "params": {}})
                    self._proc.wait(timeout=5)
                except (OSError, subprocess.TimeoutExpired):
                    self._proc.kill()
                    self._proc.wait(timeout=5)
        finally:
            for fd in (getattr(self, "_w", None), getattr(self, "_r", None)):
                if fd is not None:
                    try:
                        os.close(fd)
                    except OSError:
                        pass
            self._w = self._r = None
            shutil.rmtree(self._profile, ignore_errors=True)

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
