"""A fork server for a deployment's processes: torch is imported once, not once per process.

``python -m services.launcher.spawner MODULE ...`` imports the given modules (the services' own, so
torch, numpy and zenoh), then forks a child per request; each child runs ``python -m <module>
ARGS`` as a fresh interpreter would (``runpy``, ``__main__``), in a session of its own, its output
appended to its log. A fresh interpreter importing torch costs about 2-3.5 s of CPU on the 2-core
test machine; a fork of this process costs milliseconds and shares its memory until written.

Why it is safe to fork here: the spawner has no thread and no zenoh session when it forks (it
imports only modules that start no thread at import: never rerun, whose import starts a tokio
runtime; :data:`FORKABLE` lists what the launcher sends here), and every child opens its own
session after the fork.

Protocol, one JSON object per line: the launcher writes ``{"argv": [python, "-m", module, ...],
"log": path, "env": {...}}`` on the spawner's stdin; the spawner answers ``{"pid": N}`` on its
stdout once the child exists, and ``{"exit": N, "code": C}`` when it has reaped it (``C`` as
:attr:`subprocess.Popen.returncode`: minus the signal that killed it). The spawner exits when its
stdin closes (the launcher stopped, or died: its children then see their parent change and stop,
services/transport/lifetime.py). Each child's ``ACNMP_PARENT_PID`` names the spawner.

A child's environment is the request's: it may differ from the spawner's only in the variables of
:data:`PER_CHILD_ENV` (and those its launcher adds: :attr:`Spawner.per_child_env`), which the
services read when they run and never when their modules are imported (the spawner imported them
with its own environment). So one spawner can serve several
deployments of one process (a test session, a benchmark: :func:`services.launcher.deployment.share_spawner`).

:class:`Spawner` is the launcher's side; :class:`SpawnedProcess` behaves as the
:class:`subprocess.Popen` of a child (``pid``, ``poll``, ``wait``, ``send_signal``, ``kill``,
``terminate``, ``returncode``), signalled through a pidfd so a reused pid is never hit.
"""
from __future__ import annotations

import gc
import importlib
import json
import logging
import os
import runpy
import selectors
import signal
import subprocess
import sys
import threading
from pathlib import Path
from typing import Mapping, Sequence

from services.transport.lifetime import PARENT_PID_ENV

log = logging.getLogger(__name__)

#: The processes the launcher starts through the spawner (``python -m`` module -> what the spawner
#: imports ahead for it). Not the recorder: rerun starts threads when imported.
FORKABLE: dict[str, str] = {
    "services.learner": "services.learner.service",
    "services.model": "services.model.service",
    "services.worker": "services.worker.service",
}
#: Whether this system has what the spawner needs: fork and pidfds (Linux 5.3 and later). Where it
#: has not, the launcher starts every child as a fresh interpreter.
FORK_SERVER_AVAILABLE = hasattr(os, "fork") and hasattr(os, "pidfd_open") and hasattr(signal, "pidfd_send_signal")
#: Environment variables a forked child may have values of its own for (see :meth:`Spawner.usable_for`):
#: where a deployment keeps its run files, state, caches and host name, and whom it watches; read when
#: a service runs, never at import.
PER_CHILD_ENV = frozenset({"ACNMP_RUNTIME_DIR", "ACNMP_PARENT_PID", "ACNMP_CACHE", "ACNMP_HOST",
                           "XDG_STATE_HOME", "XDG_RUNTIME_DIR"})


def _import_env(env: Mapping[str, str], per_child: frozenset[str]) -> dict[str, str]:
    """``env`` without the variables ``per_child``: what the spawner's imports may have depended on."""
    return {k: v for k, v in env.items() if k not in per_child}


# ----- the spawner process ------------------------------------------------------------------------
def _say(message: dict) -> None:
    os.write(1, (json.dumps(message) + "\n").encode())


def serve(preload: Sequence[str]) -> dict | None:
    """Import ``preload``, then fork a child per request until stdin closes (returns None).

    Returns in a forked child only, with its request (the caller runs it: :func:`run_child`), so the
    child unwinds to the top of the interpreter as ``python -m`` would."""
    for name in preload:
        importlib.import_module(name)
    gc.freeze()  # what the children share stays shared: their collector never walks it
    sel = selectors.DefaultSelector()
    sel.register(0, selectors.EVENT_READ, None)
    pending = b""
    while True:
        for key, _ in sel.select():
            if key.data is not None:  # a child's pidfd: it exited
                pid = key.data
                _, status = os.waitpid(pid, 0)
                sel.unregister(key.fd)
                os.close(key.fd)
                _say({"exit": pid, "code": os.waitstatus_to_exitcode(status)})
                continue
            chunk = os.read(0, 1 << 16)
            if not chunk:
                return None
            pending += chunk
            while b"\n" in pending:
                line, pending = pending.split(b"\n", 1)
                request = json.loads(line)
                pid = os.fork()
                if pid == 0:
                    for other in list(sel.get_map().values()):
                        if other.data is not None:
                            os.close(other.fd)
                    sel.close()
                    return request
                sel.register(os.pidfd_open(pid), selectors.EVENT_READ, pid)
                _say({"pid": pid})


def run_child(request: dict) -> None:
    """In a forked child: a session of its own, stdin from /dev/null, output appended to the
    request's log, the spawner as the parent to watch; then ``python -m`` the request's module."""
    argv = request["argv"]
    import setproctitle  # here, not at the top: the title is the child's business

    setproctitle.setproctitle(" ".join(argv))  # what `ps` shows: the command it replaces, not the spawner's
    os.setsid()
    null = os.open(os.devnull, os.O_RDONLY)
    out = os.open(request["log"], os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    os.dup2(null, 0)
    os.dup2(out, 1)
    os.dup2(out, 2)
    os.close(null)
    os.close(out)
    os.environ.clear()
    os.environ.update(request["env"])
    os.environ[PARENT_PID_ENV] = str(os.getppid())
    sys.argv = [argv[0], *argv[3:]]
    runpy.run_module(argv[2], run_name="__main__", alter_sys=True)


# ----- the launcher's side ------------------------------------------------------------------------
class SpawnerGone(RuntimeError):
    """The spawner process is not there to start a child (it exited or never started)."""


class SpawnedProcess:
    """A child of the spawner, as the :class:`subprocess.Popen` of a child of this process."""

    def __init__(self, pid: int, args: list[str]):
        self.pid, self.args = pid, args
        self.returncode: int | None = None
        self._exited = threading.Event()
        self._fd_lock = threading.Lock()  # a signal never goes through a pidfd closed (and its number reused) meanwhile
        try:
            self._pidfd: int | None = os.pidfd_open(pid)
        except ProcessLookupError:  # it exited and was reaped already: the exit report follows
            self._pidfd = None

    def _exit(self, code: int) -> None:
        with self._fd_lock:
            self.returncode = code
            if self._pidfd is not None:
                os.close(self._pidfd)
                self._pidfd = None
        self._exited.set()

    def poll(self) -> int | None:
        """The exit code once the spawner reported the child's exit, else None."""
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        """Block until the child exited (at most ``timeout`` s: :class:`subprocess.TimeoutExpired`);
        its exit code."""
        if not self._exited.wait(timeout):
            raise subprocess.TimeoutExpired(self.args, timeout)
        return self.returncode

    def send_signal(self, sig: int) -> None:
        """Send ``sig`` to the child through its pidfd; nothing once it exited."""
        with self._fd_lock:
            if self.returncode is not None or self._pidfd is None:
                return
            try:
                signal.pidfd_send_signal(self._pidfd, sig)
            except ProcessLookupError:  # exited, not yet reported
                pass

    def terminate(self) -> None:
        """SIGTERM."""
        self.send_signal(signal.SIGTERM)

    def kill(self) -> None:
        """SIGKILL."""
        self.send_signal(signal.SIGKILL)


class Spawner:
    """Start and talk to a spawner process (``with Spawner(modules, env, cwd, log) as sp:``).

    ``modules``: the ``python -m`` modules it will start (keys of :data:`FORKABLE`); ``env`` and
    ``cwd``: its environment and directory, which every child it starts shares (:meth:`usable_for`);
    ``log``: its own output; ``per_child_env``: the variables a child's environment may have values
    of its own for (:data:`PER_CHILD_ENV` and any others no service reads at import). :meth:`spawn`
    starts a child and returns its :class:`SpawnedProcess`."""

    def __init__(self, modules: Sequence[str], env: Mapping[str, str], cwd: str | os.PathLike, log_file: Path,
                 per_child_env: frozenset[str] = PER_CHILD_ENV):
        self.modules = frozenset(m for m in modules if m in FORKABLE)
        self.env = dict(env)
        self.per_child_env = frozenset(per_child_env) | PER_CHILD_ENV
        self._import_env = _import_env(self.env, self.per_child_env)
        preload = sorted({FORKABLE[m] for m in self.modules} | {"services.transport.service"})
        with open(log_file, "ab") as err:
            self._proc = subprocess.Popen([sys.executable, "-m", __name__, *preload], cwd=cwd, env=self.env,
                                          stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=err,
                                          start_new_session=True)
        self._lock = threading.Lock()  # one request at a time: the next "pid" line answers it
        self._replies: list[dict] = []
        self._replied = threading.Condition()
        self._children: dict[int, SpawnedProcess] = {}
        self._early: dict[int, int] = {}  # exit codes reported before the child's object existed
        self._gone = False
        self._reader = threading.Thread(target=self._read, name="spawner-reader", daemon=True)
        self._reader.start()

    @property
    def pid(self) -> int:
        """The spawner process's pid (the parent of every child it forked)."""
        return self._proc.pid

    @property
    def running(self) -> bool:
        """Whether the spawner is there to start children (it has not exited nor been closed)."""
        return not self._gone

    def accepts_env(self, env: Mapping[str, str]) -> bool:
        """Whether the spawner runs and a child of environment ``env`` may be forked here: ``env``
        is the spawner's but for :attr:`per_child_env`."""
        return not self._gone and _import_env(env, self.per_child_env) == self._import_env

    def usable_for(self, argv: Sequence[str], env: Mapping[str, str]) -> bool:
        """Whether ``python -m`` ``argv`` can be forked here: its module is one this spawner
        imported for and :meth:`accepts_env` its environment."""
        return len(argv) > 2 and argv[1] == "-m" and argv[2] in self.modules and self.accepts_env(env)

    def spawn(self, argv: Sequence[str], log_file: Path, env: Mapping[str, str] | None = None,
              timeout: float = 60.0) -> SpawnedProcess:
        """Fork ``argv`` (``[python, "-m", module, *args]``) with its output appended to ``log_file``
        and ``env`` as its environment (default: the spawner's; see :meth:`usable_for`);
        :class:`SpawnerGone` if the spawner cannot."""
        request = {"argv": list(argv), "log": str(log_file), "env": dict(self.env if env is None else env)}
        with self._lock:
            try:
                self._proc.stdin.write((json.dumps(request) + "\n").encode())
                self._proc.stdin.flush()
            except (BrokenPipeError, OSError, ValueError) as exc:
                self._gone = True
                raise SpawnerGone(f"the spawner is gone: {exc}") from None
            with self._replied:
                if not self._replied.wait_for(lambda: self._replies or self._gone, timeout):
                    raise SpawnerGone(f"the spawner did not start {argv[2]} within {timeout:.0f} s")
                if not self._replies:
                    raise SpawnerGone("the spawner exited")
                pid = self._replies.pop(0)["pid"]
                child = SpawnedProcess(pid, list(argv))
                self._children[pid] = child
                if pid in self._early:
                    child._exit(self._early.pop(pid))
                return child

    def _read(self) -> None:
        for line in self._proc.stdout:
            message = json.loads(line)
            with self._replied:
                if "pid" in message:
                    self._replies.append(message)
                    self._replied.notify_all()
                elif "exit" in message:
                    child = self._children.pop(message["exit"], None)
                    if child is None:
                        self._early[message["exit"]] = message["code"]
                    else:
                        child._exit(message["code"])
        with self._replied:  # the spawner exited (or closed its output): nothing more will be reported
            self._gone = True
            self._replied.notify_all()
            orphans = list(self._children.values())
        for child in orphans:  # their exit codes went with the spawner
            log.warning("the spawner exited before pid %d: its exit code is unknown", child.pid)
            threading.Thread(target=_await_exit, args=(child,), daemon=True).start()

    def close(self, timeout: float = 10.0) -> None:
        """Close the spawner's stdin (it exits; children still running then stop, as they watch
        it: close it once they have exited) and reap it."""
        self._gone = True
        try:
            self._proc.stdin.close()
        except OSError:
            pass
        try:
            self._proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait(timeout=timeout)
        self._reader.join(timeout=timeout)

    def __enter__(self) -> "Spawner":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _await_exit(child: SpawnedProcess) -> None:
    """Report ``child`` exited (code -1: unknown) once its pidfd says so."""
    fd = child._pidfd
    if fd is not None:
        with selectors.DefaultSelector() as sel:
            sel.register(fd, selectors.EVENT_READ)
            sel.select()
    child._exit(-1)


if __name__ == "__main__":
    _request = serve(sys.argv[1:])
    if _request is not None:  # a forked child: run its module here, at the top of the interpreter
        run_child(_request)
