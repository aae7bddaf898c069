"""Where each process runs: its ``about`` queryable and the lookup ``acnmp status`` makes.

Every service (services/transport/service.py) answers on ``acnmp/<ns>/process/<service>/<zid>``
with one map: ``{"v": 1, "service", "zid", "host", "pid", "started" (UNIX s), "live" (its ready
line), "problems" (one line per problem it reports now: the learner's write failures, its job
loop, its quarantined files; empty when healthy)}``. ``host`` is ``$ACNMP_HOST`` when set (the multi-host harness names each network namespace
so; services/launcher/multihost.py), else the machine's host name (a container's own).

It answers only a query whose key expression lies within ``acnmp/<ns>/process/**`` (so a get on
``acnmp/**`` is still answered by nobody, docs/PROTOCOL.md), and it only reads: the query's payload
is ignored.
"""
from __future__ import annotations

import os
import socket
import time
from dataclasses import dataclass
from typing import Callable

import zenoh

from .keys import Keyspace, check_name
from .wire import WireError, decode, encode

HOST_ENV = "ACNMP_HOST"


def host_name() -> str:
    """This process's host: ``$ACNMP_HOST`` when set and not empty, else ``socket.gethostname()``."""
    return os.environ.get(HOST_ENV) or socket.gethostname()


@dataclass(frozen=True)
class ProcessAbout:
    """One process as its ``about`` reply describes it."""

    service: str
    zid: str
    host: str
    pid: int
    started: float
    live: str
    problems: tuple[str, ...] = ()

    @classmethod
    def from_reply(cls, msg: dict) -> "ProcessAbout":
        """The map of an ``about`` reply (ValueError/KeyError when it is not one)."""
        problems = msg.get("problems") or []
        if not isinstance(problems, list):
            raise ValueError("field 'problems': expected a list")
        return cls(str(msg["service"]), str(msg["zid"]), str(msg["host"]), int(msg["pid"]), float(msg["started"]),
                   str(msg.get("live", "")), tuple(str(p) for p in problems))


class AboutQueryable:
    """The ``about`` queryable of one process (declared by :func:`services.transport.service.run_service` for every service); ``live`` is set
    once the service said its ready line, ``health`` (``() -> [problem line]``) when it reports one."""

    def __init__(self, session: zenoh.Session, keys: Keyspace, service: str) -> None:
        self.zid = str(session.zid())
        self.key = keys.process(check_name("service", service), self.zid)
        self.scope = zenoh.KeyExpr(keys.processes())
        self.service, self.live, self.started = service, "", time.time()
        self.health: Callable[[], list[str]] | None = None
        self._queryable = session.declare_queryable(self.key, self._on_query)

    def problems(self) -> list[str]:
        """The problem lines the service reports now (a failing check is one itself)."""
        if self.health is None:
            return []
        try:
            return [str(line) for line in self.health()]
        except Exception as exc:  # a health check must never cost the reply
            return [f"its health check failed: {type(exc).__name__}: {exc}"]

    def _on_query(self, query: zenoh.Query) -> None:
        if not self.scope.includes(query.key_expr):  # acnmp/** and the like: not asked of it
            return
        body = {"v": 1, "service": self.service, "zid": self.zid, "host": host_name(), "pid": os.getpid(),
                "started": self.started, "live": self.live, "problems": self.problems()}
        query.reply(self.key, encode(body))

    def undeclare(self) -> None:
        """Stop answering."""
        self._queryable.undeclare()


def list_processes(session: zenoh.Session, keys: Keyspace, timeout: float = 2.0) -> list[ProcessAbout]:
    """Every process of namespace ``keys`` that answers within ``timeout`` seconds, sorted by
    service then host; a reply that does not decode is skipped."""
    found = []
    for reply in session.get(keys.processes(), timeout=timeout):
        if reply.ok is None:
            continue
        try:
            found.append(ProcessAbout.from_reply(decode(reply.ok.payload.to_bytes())))
        except (WireError, ValueError, KeyError, TypeError):
            continue
    return sorted(found, key=lambda p: (p.service, p.host, p.zid))
