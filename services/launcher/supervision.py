"""Supervision of a local deployment's children: a child that dies unexpectedly is started again.

:class:`RestartPolicy` is the rule (no processes: unit-tested on its own): the n-th restart of a
child within ``window`` seconds waits ``first_delay * factor**(n-1)`` seconds (at most
``max_delay``), and after ``max_restarts`` restarts within the window the launcher gives up on
that child and says so.

:class:`Supervisor` applies it to a :class:`~services.launcher.deployment.LocalDeployment`: a thread
polls the children (``Popen.poll``, every ``poll`` seconds); a child found dead is restarted after
its backoff with the same command line (``LocalDeployment.restart_child``), and, on a helper thread,
its liveliness token is awaited. Each restart is logged (``report``) and published as a ``process``
event (``acnmp/<ns>/event/process/<name>``, docs/PROTOCOL.md) once the new process is live, so the
recorder records it; giving up is published at once. :meth:`Supervisor.stop` is called before the
deployment stops its children, so a child stopped on purpose is never restarted.
"""
from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass, field
from typing import Callable, Protocol, Sequence

from services.recording.events import process_event

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RestartPolicy:
    """When to restart a dead child (all times in seconds).

    max_restarts : restarts allowed within ``window``; one more death and the child is given up.
    window : the sliding window the restarts are counted in.
    first_delay, factor, max_delay : backoff of the n-th restart in the window,
        ``min(first_delay * factor**(n-1), max_delay)``.
    """

    max_restarts: int = 5
    window: float = 60.0
    first_delay: float = 0.25
    factor: float = 2.0
    max_delay: float = 8.0

    def __post_init__(self) -> None:
        if self.max_restarts < 0 or self.window <= 0 or self.first_delay < 0 or self.factor < 1 \
                or self.max_delay < self.first_delay:
            raise ValueError(f"restart policy: inconsistent settings {self}")

    def delay(self, restarts: Sequence[float], now: float) -> float | None:
        """Backoff before the next restart, given the times of the earlier restarts (monotonic
        seconds) and ``now``; None when ``max_restarts`` were already made within the window."""
        recent = sum(1 for t in restarts if now - t < self.window)
        if recent >= self.max_restarts:
            return None
        return min(self.first_delay * self.factor ** recent, self.max_delay)


@dataclass
class Restart:
    """One restart (or the decision to give up): child ``name``, the dead process's pid and exit
    code, the new pid (None when given up), how many restarts of it the window holds (this one
    included), the backoff, when the death was seen (monotonic s) and, once live, how long after
    that the new process's token appeared (``live_after``, s; None until then or when never)."""

    name: str
    old_pid: int
    exit_code: int
    pid: int | None
    restarts: int
    delay: float
    seen_at: float
    live_after: float | None = None
    gave_up: bool = False


class Supervised(Protocol):
    """What the supervisor needs of a deployment (LocalDeployment implements it)."""

    def dead_children(self) -> list[tuple[str, int, int]]:
        """(name, pid, exit code) of every child that has exited."""

    def restart_child(self, name: str) -> int:
        """Start child ``name`` again; returns the new pid."""

    def wait_child_live(self, name: str) -> None:
        """Block until child ``name``'s liveliness token is seen; raises if it dies or times out."""

    def publish_event(self, event: dict) -> None:
        """Publish one event for the recorder (may do nothing)."""


@dataclass
class _Pending:
    due: float
    record: Restart


@dataclass
class Supervisor:
    """Restarts a deployment's dead children by :class:`RestartPolicy`; see the module docstring.

    ``restarts`` lists every :class:`Restart` made (for tests and benchmarks); ``given_up`` the
    names of children no longer restarted. ``report(line)`` gets one line per restart, per live-again
    and per giving up (``acnmp up`` prints them on stderr).
    """

    deployment: Supervised
    policy: RestartPolicy = field(default_factory=RestartPolicy)
    report: Callable[[str], None] = log.warning
    poll: float = 0.1
    restarts: list[Restart] = field(default_factory=list)
    given_up: set[str] = field(default_factory=set)

    def __post_init__(self) -> None:
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._history: dict[str, list[float]] = {}
        self._pending: dict[str, _Pending] = {}
        self._waiters: list[threading.Thread] = []
        self._thread = threading.Thread(target=self._run, name="supervisor", daemon=True)

    def start(self) -> "Supervisor":
        """Start watching (a background thread); returns self."""
        self._thread.start()
        return self

    def stop(self, timeout: float = 5.0) -> None:
        """Stop watching: no child is restarted after this returns (pending restarts are dropped)."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=timeout)
        for t in list(self._waiters):
            t.join(timeout=timeout)

    def wait_restarts(self, name: str, count: int = 1, timeout: float = 60.0, *, live: bool = True) -> list[Restart]:
        """Block until child ``name`` was restarted ``count`` times (and, with ``live``, the last one
        is live); returns its restarts. TimeoutError otherwise. For tests and benchmarks."""
        end = time.monotonic() + timeout
        while True:
            with self._lock:
                mine = [r for r in self.restarts if r.name == name and not r.gave_up]
            if len(mine) >= count and (not live or mine[count - 1].live_after is not None):
                return mine
            if time.monotonic() > end:
                raise TimeoutError(f"{name}: {len(mine)} of {count} restart(s) after {timeout}s")
            time.sleep(0.05)

    # ----- the watching thread ---------------------------------------------------------------
    def _run(self) -> None:
        while not self._stop.wait(self.poll):
            now = time.monotonic()
            for name, pid, code in self.deployment.dead_children():
                with self._lock:
                    if name in self.given_up or name in self._pending:
                        continue
                    self._schedule(name, pid, code, now)
            for name, pending in sorted(self._pending.items()):
                if pending.due <= time.monotonic() and not self._stop.is_set():
                    del self._pending[name]
                    self._restart(pending.record)

    def _schedule(self, name: str, pid: int, code: int, now: float) -> None:
        history = self._history.setdefault(name, [])
        delay = self.policy.delay(history, now)
        recent = sum(1 for t in history if now - t < self.policy.window)
        if delay is None:
            self.given_up.add(name)
            record = Restart(name, pid, code, None, recent, 0.0, now, gave_up=True)
            self.restarts.append(record)
            self.report(f"{name} (pid {pid}) exited with code {code}: {recent} restarts within "
                        f"{self.policy.window:.0f} s, giving up on it")
            self._publish(record)
            return
        history.append(now)
        self._pending[name] = _Pending(now + delay, Restart(name, pid, code, None, recent + 1, delay, now))

    def _restart(self, record: Restart) -> None:
        try:
            record.pid = self.deployment.restart_child(record.name)
        except Exception as exc:  # e.g. the interpreter cannot be started: counts as another death
            self.report(f"{record.name}: restart failed: {type(exc).__name__}: {exc}")
            return
        with self._lock:
            self.restarts.append(record)
        self.report(f"{record.name} (pid {record.old_pid}) exited with code {record.exit_code}: restarted as "
                    f"pid {record.pid} after {record.delay:.2f} s (restart {record.restarts} of "
                    f"{self.policy.max_restarts} within {self.policy.window:.0f} s)")
        waiter = threading.Thread(target=self._await_live, args=(record,), name=f"live-{record.name}", daemon=True)
        self._waiters = [t for t in self._waiters if t.is_alive()] + [waiter]
        waiter.start()

    def _await_live(self, record: Restart) -> None:
        try:
            self.deployment.wait_child_live(record.name)
        except Exception as exc:  # it died again (the watcher restarts it) or the deployment is stopping
            if not self._stop.is_set():
                self.report(f"{record.name} (pid {record.pid}) did not come back: {exc}".splitlines()[0])
            return
        record.live_after = time.monotonic() - record.seen_at
        self.report(f"{record.name} (pid {record.pid}) is live again, {record.live_after:.2f} s after its exit was seen")
        self._publish(record)

    def _publish(self, record: Restart) -> None:
        try:
            self.deployment.publish_event(process_event(
                record.name, "gave_up" if record.gave_up else "restarted",
                pid=record.old_pid if record.pid is None else record.pid, exit_code=record.exit_code,
                restarts=record.restarts, delay=record.delay, live_after=record.live_after))
        except Exception:  # the session closing: the event is lost, the restart is not
            log.debug("could not publish the process event of %s", record.name, exc_info=True)
