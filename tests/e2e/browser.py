"""Headless Chromium driven over the DevTools protocol, for the tests that load a page a user opens
(the live web viewer, tests/e2e/test_live_viewer.py).

Chromium is started with ``--remote-debugging-pipe``: the protocol's JSON messages, each ended by a
NUL byte, go in on its file descriptor 3 and come out on its 4, as Playwright drives it; so no port,
no websocket library and no browser download of a driver's own: Debian's ``chromium`` package
(``bash scripts/install_chromium.sh``) is all it takes. The flags are those that run as root in a
container without a display or a GPU (WebGL falls back to Chromium's software rasterizer), with a
new empty profile and none of Chromium's own calls out.
"""
from __future__ import annotations

import base64
import fcntl
import io
import json
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from services.recording.web_viewer import stop_child

FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--remote-debugging-pipe")


def chromium_path() -> str | None:
    """Debian's ``chromium`` (or a ``chromium-browser``) on PATH, None when there is none."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


class BrowserError(RuntimeError):
    """Chromium exited, or answered a command with an error (the message says which)."""


class Chromium:
    """``with Chromium(width, height) as browser:`` a headless Chromium with a new empty profile, a
    window of ``width`` x ``height`` pixels; :meth:`open` loads a page. Leaving the block ends the
    browser (SIGTERM, SIGKILL after 10 s) and removes its profile; its log is :attr:`log`."""

    def __init__(self, width: int = 1280, height: int = 800, executable: str | None = None):
        self.executable = executable or chromium_path()
        if self.executable is None:
            raise FileNotFoundError("no chromium on PATH (bash scripts/install_chromium.sh installs Debian's)")
        self.size = (int(width), int(height))
        self.proc: subprocess.Popen | None = None
        self._dir = tempfile.mkdtemp(prefix="acnmp-chromium-")
        self.log = Path(self._dir) / "chromium.log"
        self._ids = 0
        self._pending = b""

    def __enter__(self) -> "Chromium":
        to_browser_r, to_browser_w = os.pipe()
        from_browser_r, from_browser_w = os.pipe()

        def on_3_and_4():  # in the child: the protocol's descriptors where Chromium looks for them
            read = fcntl.fcntl(to_browser_r, fcntl.F_DUPFD, 10)
            write = fcntl.fcntl(from_browser_w, fcntl.F_DUPFD, 10)
            os.dup2(read, 3)
            os.dup2(write, 4)

        profile = Path(self._dir) / "profile"
        profile.mkdir()
        with open(self.log, "wb") as log:
            self.proc = subprocess.Popen(
                [self.executable, *FLAGS, f"--user-data-dir={profile}", f"--window-size={self.size[0]},{self.size[1]}",
                 "about:blank"], stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
                pass_fds=(3, 4), preexec_fn=on_3_and_4)
        os.close(to_browser_r)
        os.close(from_browser_w)
        self._send = os.fdopen(to_browser_w, "wb", buffering=0)
        self._receive = os.fdopen(from_browser_r, "rb", buffering=0)
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """End the browser and remove its profile and log; idempotent."""
        if self.proc is not None:
            for stream in (self._send, self._receive):
                stream.close()
            stop_child(self.proc, grace=10.0)
            self.proc = None
        shutil.rmtree(self._dir, ignore_errors=True)

    def command(self, method: str, params: dict | None = None, session: str | None = None) -> dict:
        """Send one DevTools command (to the page ``session`` when given) and return its result;
        the events Chromium sends meanwhile are passed over. BrowserError for an error reply, or
        when the browser has exited (with the end of its log)."""
        self._ids += 1
        message = {"id": self._ids, "method": method, "params": params or {}}
        if session is not None:
            message["sessionId"] = session
        try:
            self._send.write(json.dumps(message).encode() + b"\0")
            while True:
                while b"\0" not in self._pending:
                    chunk = self._receive.read(1 << 16)
                    if not chunk:
                        raise BrokenPipeError
                    self._pending += chunk
                raw, self._pending = self._pending.split(b"\0", 1)
                reply = json.loads(raw)
                if reply.get("id") == self._ids:
                    break
        except BrokenPipeError:
            tail = self.log.read_text(errors="replace").strip().splitlines()[-3:]
            raise BrowserError(f"chromium exited (its log ends: {' | '.join(tail)})") from None
        if "error" in reply:
            raise BrowserError(f"{method}: {reply['error'].get('message', reply['error'])}")
        return reply["result"]

    def open(self, url: str) -> "Page":
        """A new tab loading ``url``."""
        target = self.command("Target.createTarget", {"url": url})["targetId"]
        session = self.command("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        return Page(self, target, session)


class Page:
    """A tab of a :class:`Chromium`: run a script in it, take a screenshot, close it."""

    def __init__(self, browser: Chromium, target: str, session: str):
        self.browser, self.target, self.session = browser, target, session

    def close(self) -> None:
        """Close the tab (its page's scripts stop)."""
        self.browser.command("Target.closeTarget", {"targetId": self.target})

    def evaluate(self, expression: str):
        """The value of the JavaScript ``expression`` in the page (JSON-serialisable; a promise is
        awaited); BrowserError when it throws."""
        result = self.browser.command("Runtime.evaluate", {"expression": expression, "returnByValue": True,
                                                           "awaitPromise": True}, self.session)
        if "exceptionDetails" in result:
            details = result["exceptionDetails"]
            raise BrowserError(f"{expression[:60]!r} threw: {details.get('exception', {}).get('description') or details}")
        return result["result"].get("value")

    def wait_for(self, expression: str, timeout: float, poll: float = 0.25):
        """Evaluate ``expression`` until it gives a true value and return it; TimeoutError after
        ``timeout`` seconds, naming the expression and its last value."""
        deadline = time.monotonic() + timeout
        while True:
            value = self.evaluate(expression)
            if value:
                return value
            if time.monotonic() > deadline:
                raise TimeoutError(f"{expression[:80]!r} still {value!r} after {timeout:g} s")
            time.sleep(poll)

    def screenshot(self) -> np.ndarray:
        """What the tab shows now: (height, width, 3) uint8 RGB."""
        from PIL import Image

        png = base64.b64decode(self.browser.command("Page.captureScreenshot", {"format": "png"}, self.session)["data"])
        return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
