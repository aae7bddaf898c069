"""Finding the deployment a client talks to, and waiting for its services to appear.

:func:`resolve` turns a client's arguments into where to connect: explicit ``connect`` /
``config_file`` / ``$ACNMP_CONNECT`` win; otherwise the run file of a running ``acnmp up``
(services/transport/runfile.py) gives the anchor, the namespace and the credentials of a role
(``operator`` may start jobs, ``client`` only asks; docs/SECURITY.md).

:func:`call_when_available` retries a query answered ``unavailable`` (nothing matched its key yet:
a fresh session that has not learned the deployment's queryables, or a service still starting)
until the query's own timeout, so the first query of a new client does not fail.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass
from typing import Sequence

import zenoh

from services.transport import DEFAULT_NAMESPACE, WireError, call
from services.transport.runfile import RunFile, find, running

#: Environment variable with comma-separated endpoints: connect there, no discovery.
CONNECT_ENV = "ACNMP_CONNECT"


@dataclass(frozen=True)
class Target:
    """Where a client connects: namespace, endpoints (None: the config file's), zenoh config file
    (credentials) or None, and the zenoh mode (None: the config file's)."""

    namespace: str
    connect: list[str] | None
    config_file: str | None
    mode: str | None


def resolve(namespace: str | None, connect: Sequence[str] | None, config_file: str | None,
            mode: str | None, role: str = "operator") -> Target:
    """The :class:`Target` of a client.

    ``connect`` (or ``$ACNMP_CONNECT``) naming the anchor of a running secured deployment, with
    no ``config_file`` nor ``mode``: that deployment's credentials of ``role``. Otherwise, with
    ``connect``, ``config_file`` or ``$ACNMP_CONNECT``: those, in ``mode`` (default peer),
    namespace ``namespace`` or the default. Otherwise the running deployment of ``namespace``
    (or the only one running): its anchor and the config file of ``role`` (``operator`` or
    ``client``), in the mode that file says. Raises
    :class:`~services.transport.runfile.DeploymentNotFound` (an OSError) when there is none.
    """
    env = [e for e in os.environ.get(CONNECT_ENV, "").split(",") if e]
    known = _announced(connect or env) if config_file is None and mode is None else None
    if known is not None:  # the anchor of a running `acnmp up`: use its credentials
        namespace = known.namespace if namespace in (None, DEFAULT_NAMESPACE) else namespace
        connect, config_file = [known.anchor], _credentials(known, role)
    if connect is not None or config_file is not None or env:
        endpoints = list(connect) if connect is not None else (env or None)  # None: the file's
        return Target(namespace or DEFAULT_NAMESPACE, endpoints, config_file,
                      mode if mode is not None or config_file is not None else "peer")
    run = find(namespace)
    creds = _credentials(run, role)
    if not creds:  # an unsecured deployment: a peer of its mesh
        return Target(run.namespace, [run.anchor], None, mode or "peer")
    return Target(run.namespace, [run.anchor], creds, None)


def _credentials(run: RunFile, role: str) -> str | None:
    """The config file of ``role`` in run file ``run`` (None when it is not secured)."""
    return (run.operator_credentials if role == "operator" else run.credentials) or None


def _announced(endpoints: Sequence[str] | None) -> RunFile | None:
    """The running secured deployment whose anchor is one of ``endpoints``, if any."""
    for run in running() if endpoints else ():
        if run.anchor in endpoints and run.credentials:
            return run
    return None


def call_when_available(session: zenoh.Session, key: str, payload: dict | None, timeout: float, *,
                        first_delay: float = 0.05, max_delay: float = 0.5, caller=call):
    """:func:`services.transport.rpc.call` (or ``caller``, e.g. ``call_all``), retried while it
    answers ``unavailable`` and ``timeout`` seconds have not passed (delays from ``first_delay``
    doubling to ``max_delay``). Returns what ``caller`` returns. Any other error, or
    ``unavailable`` at the end, is raised as the WireError it is."""
    deadline = time.monotonic() + timeout
    delay = first_delay
    while True:
        remaining = deadline - time.monotonic()
        try:
            return caller(session, key, payload, max(remaining, 0.05))
        except WireError as exc:
            if exc.code != "unavailable" or time.monotonic() + delay >= deadline:
                raise
        time.sleep(delay)
        delay = min(delay * 2, max_delay)
