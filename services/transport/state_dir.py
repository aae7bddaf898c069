"""Where a deployment keeps its state when ``--state-dir`` is not given.

The default is the platform's user state directory (``$XDG_STATE_HOME/acnmp/<namespace>``, by
default ``~/.local/state/acnmp/<namespace>`` on Linux; platformdirs' equivalent elsewhere), so a
deployment finds its skills again whatever directory it is started from. Before 0.2 the default
was ``./runs/<namespace>/state`` under the current directory: for one release a state directory
found there (and none at the new place) is still used, with one line on stderr saying how to move
it. :class:`DirectoryLock` keeps a second process (a learner, a launcher) out of a state directory
in use.
"""
from __future__ import annotations

import fcntl
import os
import sys
from pathlib import Path
from typing import Callable

import platformdirs

__all__ = ["default_state_dir", "legacy_state_dir", "user_state_root"]


def user_state_root() -> Path:
    """The platform's user state directory for acnmp (not created)."""
    return platformdirs.user_state_path("acnmp", appauthor=False)


def legacy_state_dir(namespace: str, cwd: Path | None = None) -> Path:
    """The pre-0.2 default: ``<cwd>/runs/<namespace>/state``."""
    return (cwd or Path.cwd()) / "runs" / namespace / "state"


def default_state_dir(namespace: str, *, cwd: Path | None = None,
                      say: Callable[[str], None] | None = None) -> Path:
    """The state directory of ``namespace`` when none is given.

    Returns ``user_state_root() / namespace``, unless only the old default
    (:func:`legacy_state_dir`) holds a state directory: that one is returned and ``say`` (default:
    a line on stderr) is told so once, with the command that moves it.
    """
    new = user_state_root() / namespace
    old = legacy_state_dir(namespace, cwd)
    if not new.exists() and old.is_dir() and any(old.iterdir()):
        (say or _stderr)(f"acnmp: using the state directory {old} (the default before 0.2, read for one more "
                         f"release); the default is now {new}: move it there with  mkdir -p {new.parent} && "
                         f"mv {old} {new}")
        return old
    return new


def _stderr(line: str) -> None:
    print(line, file=sys.stderr)


class StateDirInUse(RuntimeError):
    """Another live process holds the lock of a state directory (see :class:`DirectoryLock`)."""


class DirectoryLock:
    """An exclusive lock on a directory for as long as this process holds it.

    ``flock`` on ``<directory>/<name>`` (created, mode 0600): the OS releases it when the holder
    exits, even by ``kill -9``, so a stale lock never needs cleaning up. The file holds the
    holder's pid and ``owner``, quoted when another process is refused. Re-entrant within one
    object only: a second lock on the same file, even in this process, is refused.
    """

    def __init__(self, directory: str | os.PathLike, name: str, owner: str):
        self.path = Path(directory).resolve() / name
        self.owner = owner
        self._fd: int | None = None

    def acquire(self) -> "DirectoryLock":
        """Take the lock or raise :class:`StateDirInUse` naming the directory and the holder."""
        if self._fd is not None:
            return self
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(fd, 200).decode("utf-8", "replace").strip() or "unknown"
            os.close(fd)
            raise StateDirInUse(f"state directory {self.path.parent} is in use by another {self.owner} "
                                f"(pid {holder}); stop it first or give another --state-dir") from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()} ({self.owner})\n".encode())
        self._fd = fd
        return self

    def release(self) -> None:
        """Give the lock up (the file stays: removing it would race with a newcomer)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> "DirectoryLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()
