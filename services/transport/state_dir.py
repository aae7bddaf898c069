"""Where a deployment keeps its state when ``--state-dir`` is not given.

The default is the platform's user state directory (``$XDG_STATE_HOME/acnmp/<namespace>``, by
default ``~/.local/state/acnmp/<namespace>`` on Linux; platformdirs' equivalent elsewhere), so a
deployment finds its skills again whatever directory it is started from. Before 0.2 the default
was ``./runs/<namespace>/state`` under the current directory: for one release a state directory
found there (and none at the new place) is still used, with one line on stderr saying how to move
it.
"""
from __future__ import annotations

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
