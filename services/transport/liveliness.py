"""Liveliness: waiting for tokens of live processes, listing the ones alive now."""
from __future__ import annotations

import threading
import time

import zenoh

from .keys import is_concrete


def wait_for_liveliness(session: zenoh.Session, key_expr: str, count: int = 1,
                        timeout: float = 10.0) -> list[str]:
    """Wait until at least ``count`` liveliness tokens matching ``key_expr`` are alive.

    Returns the sorted token keys. Raises TimeoutError (listing what was seen) after ``timeout``.
    A subscriber with history sees tokens declared before and after the call.
    """
    alive: set[str] = set()
    cond = threading.Condition()

    def on_sample(sample: zenoh.Sample) -> None:
        if not is_concrete(sample.key_expr):  # a wildcard token stands for no process
            return
        with cond:
            if sample.kind == zenoh.SampleKind.PUT:
                alive.add(str(sample.key_expr))
            else:
                alive.discard(str(sample.key_expr))
            cond.notify_all()

    sub = session.liveliness().declare_subscriber(key_expr, on_sample, history=True)
    try:
        with cond:
            ok = cond.wait_for(lambda: len(alive) >= count, timeout=timeout)
            found = sorted(alive)
    finally:
        sub.undeclare()
    if not ok:
        raise TimeoutError(f"{len(found)}/{count} liveliness token(s) for {key_expr} after {timeout}s: {found}")
    return found


def alive_tokens(session: zenoh.Session, key_expr: str, timeout: float = 2.0) -> list[str]:
    """Return the keys of the liveliness tokens matching ``key_expr`` alive now (one query); only
    concrete keys (a token declared on a wildcard stands for no process)."""
    found = set()
    for reply in session.liveliness().get(key_expr, timeout=timeout):
        if reply.ok is not None and is_concrete(reply.ok.key_expr):
            found.add(str(reply.ok.key_expr))
    return sorted(found)



def wait_for_liveliness_gone(session: zenoh.Session, key_expr: str, timeout: float = 10.0) -> None:
    """Wait until no liveliness token matching ``key_expr`` is alive (e.g. until the router has
    dropped a killed process's token). Raises TimeoutError (listing what is alive) after ``timeout``.

    Asks the router what is alive, again after each token change it reports (or every 0.5 s): a
    subscriber alone cannot tell "gone" from "history not delivered yet"."""
    changed = threading.Event()
    sub = session.liveliness().declare_subscriber(key_expr, lambda _sample: changed.set())
    deadline = time.monotonic() + timeout
    try:
        while True:
            changed.clear()
            found = alive_tokens(session, key_expr, timeout=min(2.0, timeout))
            if not found:
                return
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"liveliness token(s) for {key_expr} still alive after {timeout}s: {found}")
            changed.wait(min(0.5, left))
    finally:
        sub.undeclare()
