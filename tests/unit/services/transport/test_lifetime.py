"""A child of a launcher stops when its launcher is gone, also when the launcher died before the
child started watching it (services/transport/lifetime.py ``watch_parent``)."""
from __future__ import annotations

import os
import subprocess
import sys
import threading

from services.transport import lifetime


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_a_launcher_dead_before_the_child_watches_stops_the_child(monkeypatch):
    monkeypatch.setenv(lifetime.PARENT_PID_ENV, str(_dead_pid()))
    monkeypatch.setattr(lifetime, "launcher_gone", threading.Event())
    stop = threading.Event()
    assert lifetime.watch_parent(stop) is None
    assert stop.is_set() and lifetime.launcher_gone.is_set()


def test_a_variable_passed_on_by_another_live_process_is_not_a_launcher(monkeypatch):
    monkeypatch.setenv(lifetime.PARENT_PID_ENV, str(os.getpid()))  # alive, but not this process's parent
    stop = threading.Event()
    assert lifetime.watch_parent(stop) is None
    assert not stop.is_set()


def test_the_parent_launcher_is_watched(monkeypatch):
    monkeypatch.setenv(lifetime.PARENT_PID_ENV, str(os.getppid()))
    stop = threading.Event()
    thread = lifetime.watch_parent(stop, poll=0.05)
    assert thread is not None and thread.is_alive() and not stop.is_set()
    stop.set()
    thread.join(5)
    assert not thread.is_alive()
