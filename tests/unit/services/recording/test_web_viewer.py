"""The live web viewer (services/recording/web_viewer.py): it listens on 127.0.0.1 only, as
`acnmp up --help` says (Rerun 0.41's serve_web_viewer listened on 0.0.0.0), with Rerun's analytics
off, and goes when it is closed or its starter dies."""
from __future__ import annotations

import json
import os
import sys
import urllib.request
from pathlib import Path

import pytest

from services.recording.web_viewer import WebViewer, rerun_binary
from services.transport import free_port
from tests.paths import ROOT

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/net/tcp")


def listening_addresses(port: int) -> set[str]:
    """The local IPv4/IPv6 addresses (hex, as /proc/net/tcp* write them) listening on ``port``."""
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        with open(table) as f:
            for line in f.readlines()[1:]:
                local, state = line.split()[1], line.split()[3]
                address, hex_port = local.split(":")
                if state == "0A" and int(hex_port, 16) == port:  # 0A: LISTEN
                    found.add(address)
    return found


def test_the_web_viewer_listens_on_loopback_only_with_analytics_off():
    port = free_port()
    with WebViewer("rerun+http://127.0.0.1:9/proxy", port) as viewer:
        assert listening_addresses(port) == {"0100007F"}  # 127.0.0.1, and no 0.0.0.0 or ::
        page = urllib.request.urlopen(viewer.url, timeout=10).read().decode()
        assert "<html" in page and viewer.url.startswith(f"http://127.0.0.1:{port}/?url=rerun%2Bhttp")
        assert viewer.url.endswith("&hide_welcome_screen")  # no examples fetched from app.rerun.io
        env = dict(item.split("=", 1) for item in
                   Path(f"/proc/{viewer.proc.pid}/environ").read_text().split("\0") if "=" in item)
        config = json.loads((Path(env["XDG_CONFIG_HOME"]) / "rerun" / "analytics.json").read_text())
        assert config["analytics_enabled"] is False
        assert env.get("XDG_CONFIG_HOME") != os.environ.get("XDG_CONFIG_HOME")  # the user's setting untouched
        private = Path(env["XDG_CONFIG_HOME"]).parent
    assert viewer.proc.poll() is not None and listening_addresses(port) == set() and not private.exists()


def test_a_port_taken_is_one_line_naming_it():
    port = free_port()
    with WebViewer("rerun+http://127.0.0.1:9/proxy", port):
        with pytest.raises(RuntimeError, match=f"web viewer: 127.0.0.1:{port} is in use by another program"):
            WebViewer("rerun+http://127.0.0.1:9/proxy", port).start()


def test_rerun_binary_is_the_executable_not_its_python_wrapper():
    assert rerun_binary().is_file() and rerun_binary().read_bytes()[:4] == b"\x7fELF"


def test_the_viewer_goes_with_a_recorder_killed_by_sigkill(tmp_path):
    """A recorder killed with -9 must not leave its viewer holding the port: the launcher restarts
    the recorder with the same --web-viewer PORT."""
    import signal
    import subprocess
    import time

    port = free_port()
    starter = subprocess.Popen(
        [sys.executable, "-c", "import sys, time\n"
         "from services.recording.web_viewer import WebViewer\n"
         f"v = WebViewer('rerun+http://127.0.0.1:9/proxy', {port}).start()\n"
         "print(v.proc.pid, flush=True)\n"
         "time.sleep(600)\n"],
        cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        child = int(starter.stdout.readline())
        assert listening_addresses(port) == {"0100007F"}
        starter.send_signal(signal.SIGKILL)
        starter.wait(timeout=10)
        # the viewer's main thread turns zombie before its other threads have closed the socket
        # (they share one file table): wait for the port itself, not for the process state
        deadline = time.monotonic() + 20
        while listening_addresses(port):
            assert time.monotonic() < deadline, f"the viewer outlived its recorder ({_state(child)})"
            time.sleep(0.05)
        assert "zombie" in _state(child) or not Path(f"/proc/{child}").exists()
    finally:
        starter.kill()
        starter.wait(timeout=10)


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/status").read_text().split("State:")[1].splitlines()[0]
    except (OSError, IndexError):
        return "zombie"
