"""A zenoh router written as a Python session in router mode: no zenohd binary needed.

Use it for deployments over several hosts or containers: run ``acnmp serve router --listen
tcp/0.0.0.0:7447`` on one host (only there do you open a non-loopback address), and every other
process in client mode with ``--mode client --connect tcp/<router-host>:7447``. On one machine the
default deployment needs no router (see services/transport/session.py).
"""
from __future__ import annotations

import logging
import threading
from dataclasses import dataclass
from typing import ClassVar

import zenoh

from .keys import Keyspace
from .lifetime import wait_until_stopped
from .service import Ready, Service
from .session import DEFAULT_ROUTER_PORT, loopback_endpoint

log = logging.getLogger(__name__)


@dataclass
class RouterConfig(Service):
    """A router: ``session.listen`` defaults to ``tcp/127.0.0.1:7447``. With a namespace it also
    declares the liveliness token ``acnmp/<ns>/router/<zid>`` so a launcher can see it live."""

    name: ClassVar[str] = "router"
    summary: ClassVar[str] = "a zenoh router, for deployments over several hosts"
    default_mode: ClassVar[str] = "router"
    modes: ClassVar[tuple[str, ...]] = ("router",)

    def __post_init__(self) -> None:
        if self.session.mode not in (None, "router"):
            raise ValueError("--mode: the router always runs in router mode")
        if self.session.listen is None and self.session.config is None:
            self.session.listen = [loopback_endpoint(DEFAULT_ROUTER_PORT)]

    def serve(self, session: zenoh.Session, stop: threading.Event, ready: Ready) -> int:
        zid = str(session.zid())
        token = session.liveliness().declare_token(Keyspace(self.session.namespace).router_token(zid))
        log.info("router %s listening on %s", zid, self.session.listen or "(config file)")
        ready(f"router {zid} listening on {self.session.listen or '(config file)'}")
        wait_until_stopped(stop)
        token.undeclare()
        return 0


if __name__ == "__main__":  # python -m services.transport.router [--listen EP] [--config FILE]
    import sys

    from .service import main

    sys.exit(main(RouterConfig))
