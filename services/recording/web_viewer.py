"""Rerun's web viewer for a live recording, hosted on 127.0.0.1 by the ``rerun`` command line.

Rerun 0.41's ``rerun.serve_web_viewer`` takes no address and listens on every interface
(0.0.0.0); its command line takes ``--bind``. So the recorder runs ``rerun --serve-web --bind
127.0.0.1 --web-viewer-port PORT GRPC_URL`` as its child: given a gRPC URL, the command hosts only
the web viewer's page, which connects the browser to that URL (the recorder's gRPC server, also on
127.0.0.1).

Outside calls, turned off where Rerun has a switch: the child runs with Rerun's analytics off
(``rerun analytics disable``, written into a private configuration directory, so the user's own
setting is left alone): no usage event for serving the viewer; the page's address hides the
welcome screen, whose examples the viewer would fetch from app.rerun.io. What the page still does
in the browser Rerun 0.41 has no switch for (docs/DEPLOYMENT.md): it loads the Inter font from
fonts.googleapis.com, posts usage events to tel.rerun.io, and asks api.github.com for the latest
release (the viewer's setting "Check for updates on startup", kept by the browser, stops that).
"""
from __future__ import annotations

import contextlib
import ctypes
import importlib.util
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from urllib.parse import quote

#: Where the web viewer listens; the help texts and docs say so.
BIND = "127.0.0.1"


def rerun_binary() -> Path:
    """The ``rerun`` executable itself (the ``rerun_cli`` package's binary, not its Python wrapper,
    which does not pass a SIGTERM on); FileNotFoundError when rerun-sdk came without it."""
    spec = importlib.util.find_spec("rerun_cli")
    path = Path(spec.origin).parent / "rerun" if spec and spec.origin else None
    if path is None or not path.is_file():
        raise FileNotFoundError("the rerun command line is not installed (the rerun-sdk package's rerun_cli)")
    return path


def analytics_off_env(config_dir: str | os.PathLike) -> dict[str, str]:
    """The environment of a ``rerun`` child whose analytics are off: Rerun's configuration and
    data directories moved into ``config_dir`` (created), where ``rerun analytics disable`` has
    written its setting; the user's own configuration is not touched."""
    root = Path(config_dir)
    env = dict(os.environ, XDG_CONFIG_HOME=str(root / "config"), XDG_DATA_HOME=str(root / "data"))
    subprocess.run([str(rerun_binary()), "analytics", "disable"], env=env, check=True, timeout=30,
                   stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    return env


def page_url(grpc_url: str, port: int) -> str:
    """The address of the web viewer on ``BIND``:``port`` opening the stream at ``grpc_url``,
    without the welcome screen (whose examples the viewer would fetch from app.rerun.io)."""
    return f"http://{BIND}:{int(port)}/?url={quote(grpc_url, safe='')}&hide_welcome_screen"


def stop_child(proc: subprocess.Popen, grace: float) -> int:
    """End the child ``proc`` if it still runs: SIGTERM, then SIGKILL when it has not exited after
    ``grace`` seconds; return its exit code once it has exited."""
    if proc.poll() is None:
        proc.terminate()
        try:
            return proc.wait(timeout=grace)
        except subprocess.TimeoutExpired:
            proc.kill()
    return proc.wait(timeout=grace)


def _die_with_parent():
    """``preexec_fn`` on Linux: the child gets SIGTERM when the thread that started it dies (a
    recorder killed with -9 leaves no viewer holding its port); None elsewhere."""
    if not sys.platform.startswith("linux"):
        return None
    prctl = ctypes.CDLL(None, use_errno=True).prctl  # resolved before the fork: the child only calls it
    pr_set_pdeathsig = 1
    return lambda: prctl(pr_set_pdeathsig, signal.SIGTERM)


class WebViewer:
    """Rerun's web viewer on ``BIND``:``port``, showing the live stream at ``grpc_url``.

    ``with WebViewer(grpc_url, port) as viewer:`` starts it and returns once its port accepts
    connections (RuntimeError naming the cause when the child exits first or ``timeout`` s pass);
    ``viewer.url`` is the page's address with the stream in its query. Leaving the block (or
    :meth:`close`) stops the child and removes its private directory.
    """

    def __init__(self, grpc_url: str, port: int, *, timeout: float = 30.0):
        self.grpc_url, self.port, self.timeout = grpc_url, int(port), float(timeout)
        self.url = page_url(grpc_url, self.port)
        self.proc: subprocess.Popen | None = None
        self._dir: str | None = None

    def start(self) -> "WebViewer":
        """Start the child and wait until it listens; returns self."""
        if _listening(self.port):  # else the wait below would take another server for the child
            raise RuntimeError(f"web viewer: {BIND}:{self.port} is in use by another program")
        self._dir = tempfile.mkdtemp(prefix="acnmp-web-viewer-")
        try:
            env = analytics_off_env(self._dir)
            log = Path(self._dir) / "rerun.log"
            with open(log, "wb") as out:
                self.proc = subprocess.Popen(
                    [str(rerun_binary()), "--serve-web", "--bind", BIND, "--web-viewer-port", str(self.port),
                     self.grpc_url], env=env, stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                    preexec_fn=_die_with_parent())
            deadline = time.monotonic() + self.timeout
            while not _listening(self.port):
                if self.proc.poll() is not None:
                    tail = log.read_text(errors="replace").strip().splitlines()[-1:]
                    raise RuntimeError(f"web viewer: rerun exited with code {self.proc.returncode} before "
                                       f"listening on {BIND}:{self.port}" + (f" ({tail[0]})" if tail else ""))
                if time.monotonic() > deadline:
                    raise RuntimeError(f"web viewer: not listening on {BIND}:{self.port} after {self.timeout:.0f} s")
                time.sleep(0.05)
        except BaseException:
            self.close()
            raise
        return self

    def close(self) -> None:
        """Stop the child (SIGTERM, SIGKILL after 5 s) and remove its directory; idempotent."""
        if self.proc is not None:
            stop_child(self.proc, grace=5.0)
        if self._dir is not None:
            shutil.rmtree(self._dir, ignore_errors=True)
            self._dir = None

    def __enter__(self) -> "WebViewer":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.close()


def _listening(port: int) -> bool:
    """Whether something accepts TCP connections on ``BIND``:``port``."""
    with contextlib.closing(socket.socket(socket.AF_INET, socket.SOCK_STREAM)) as s:
        s.settimeout(0.2)
        return s.connect_ex((BIND, port)) == 0
