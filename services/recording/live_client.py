"""A real Rerun client of a live recording: the ``rerun`` command connected to a recorder's gRPC
server (``acnmp up --viewer``), saving what it receives to a file as it arrives. Tests and
benchmarks use it to see what a viewer would get; a user can keep a copy of a remote stream."""
from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

from services.transport import free_port


@contextlib.contextmanager
def saving_client(url: str, path: str | Path) -> Iterator[subprocess.Popen]:
    """Run ``rerun URL --save PATH`` (its own viewer server bound to a free port on 127.0.0.1)
    for the duration of the block; stopped with SIGINT (killed if it does not stop within 10 s)."""
    rerun = Path(sys.executable).with_name("rerun")
    client = subprocess.Popen([str(rerun), url, "--save", str(path), "--bind", "127.0.0.1", "--port", str(free_port())],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        yield client
    finally:
        client.send_signal(signal.SIGINT)
        try:
            client.wait(timeout=10)
        except subprocess.TimeoutExpired:
            client.kill()
            client.wait()
        client.stderr.close()
