"""Process lifetime: SIGTERM/SIGINT set a stop event, children stop when their launcher dies.

Every service's main loop waits on one :class:`threading.Event` and then closes everything in
order (services/transport/service.py runs that for any service).
"""
from __future__ import annotations

import logging
import os
import signal
import sys
import threading
from typing import Callable, NoReturn

log = logging.getLogger(__name__)


def install_shutdown_handlers(stop: threading.Event | None = None) -> threading.Event:
    """Make SIGTERM and SIGINT set ``stop`` (a new Event if None) and return it.

    The main loop waits on the event and then closes everything in order. A second signal raises
    SystemExit(128+signum) for an impatient operator. Call from the main thread only (Python
    delivers signals there).
    """
    stop = stop if stop is not None else threading.Event()

    def handler(signum, _frame):
        if stop.is_set():
            raise SystemExit(128 + signum)
        log.info("signal %s: shutting down", signal.Signals(signum).name)
        stop.set()

    signal.signal(signal.SIGTERM, handler)
    signal.signal(signal.SIGINT, handler)
    watch_parent(stop)
    return stop


#: Set by the launcher in its children's environment: the launcher's pid.
PARENT_PID_ENV = "ACNMP_PARENT_PID"
#: Set (before the stop event) once :func:`watch_parent` found the launcher gone: nobody orders
#: the shutdown then, so a process that must outlive another (the recorder, the learner's last
#: events) can tell this stop from a SIGTERM.
launcher_gone = threading.Event()
#: What to do once the launcher is found gone, before the stop (:func:`on_launcher_gone`).
_when_gone: list[Callable[[], None]] = []


def on_launcher_gone(action: Callable[[], None]) -> None:
    """Run ``action`` once :func:`watch_parent` finds this process's launcher gone (killed: it
    cleans up nothing itself), before the stop event is set; an action that raises is logged."""
    _when_gone.append(action)


def watch_parent(stop: threading.Event, poll: float = 0.5) -> threading.Thread | None:
    """When this process was started by a launcher (``ACNMP_PARENT_PID`` in the environment), set
    ``stop`` as soon as that launcher is gone (killed with ``kill -9``, say), so no child outlives its
    deployment and the recorder still finalises its file. Returns the watching thread, or None when
    there is no launcher to watch."""
    raw = os.environ.get(PARENT_PID_ENV)
    if not raw:
        return None
    try:
        parent = int(raw)
    except ValueError:
        log.warning("%s=%r is not a pid; not watching the launcher", PARENT_PID_ENV, raw)
        return None

    def gone() -> None:
        log.warning("launcher (pid %d) is gone: shutting down", parent)
        launcher_gone.set()
        for action in list(_when_gone):
            try:
                action()
            except Exception:
                log.exception("cleaning up after the launcher failed")
        stop.set()

    def run() -> None:
        # A dead parent's children are re-parented (to init or a subreaper): getppid() changes.
        while not stop.wait(poll):
            if os.getppid() != parent:
                gone()
                return

    if os.getppid() != parent:
        if not pid_alive(parent):  # the launcher died before this process got here
            gone()
        return None  # or started by something else that merely passed the variable on
    thread = threading.Thread(target=run, name="watch-launcher", daemon=True)
    thread.start()
    return thread


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (a pid of another user counts as alive)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def wait_until_stopped(stop: threading.Event, poll: float = 0.2) -> None:
    """Block until ``stop`` is set, waking up regularly so signal handlers get to run."""
    while not stop.wait(poll):
        pass


def exit_now(code: int) -> NoReturn:
    """End a service process with exit ``code`` at once, skipping the interpreter's teardown.

    Call it only once the service has closed everything it owns (its session, files and
    recording: :func:`services.transport.service.run_service` returns after that). The teardown
    skipped is the garbage collection of torch, zenoh and rerun modules, which took 1.8-2.1 s per
    process on the 2-core test machine: without it a deployment stops in about half the time.
    """
    logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed or broken stream: nothing more to say anyway
            pass
    os._exit(int(code))
