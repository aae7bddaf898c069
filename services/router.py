"""A zenoh router written as a Python session in router mode: no zenohd binary needed.

Use it for deployments over several hosts or containers: run ``acnmp serve router --listen
tcp/0.0.0.0:7447`` on one host (only there do you open a non-loopback address), and every other
process in client mode with ``--mode client --connect tcp/<router-host>:7447``. On one machine the
default deployment needs no router (see services/session.py).
"""
from __future__ import annotations

import argparse
import logging
import sys
import threading
from typing import Callable, Sequence

from services import keys
from services.session import (DEFAULT_ROUTER_PORT, add_session_arguments, install_shutdown_handlers,
                              loopback_endpoint, open_session, wait_until_stopped)

log = logging.getLogger(__name__)


def run(listen: Sequence[str] | None = None, connect: Sequence[str] | None = None,
        config_file: str | None = None, *, namespace: str | None = None,
        stop: threading.Event | None = None, ready: Callable[[str], None] | None = None) -> int:
    """Run a router until ``stop`` is set (default: until SIGTERM/SIGINT); return exit code 0.

    ``listen`` defaults to ``tcp/127.0.0.1:7447``. With ``namespace`` the router also declares
    the liveliness token ``acnmp/<ns>/router/<zid>`` so ``acnmp up`` can see it live. ``ready`` is
    called with the router's zenoh id once it listens.
    """
    if stop is None:
        stop = install_shutdown_handlers()
    if listen is None and config_file is None:
        listen = [loopback_endpoint(DEFAULT_ROUTER_PORT)]
    with open_session("router", listen, connect, config_file) as session:
        zid = str(session.zid())
        token = None
        if namespace:
            token = session.liveliness().declare_token(keys.liveliness_key(namespace, "router", zid))
        log.info("router %s listening on %s", zid, listen or "(config file)")
        if ready is not None:
            ready(zid)
        wait_until_stopped(stop)
        if token is not None:
            token.undeclare()
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the router's options (the shared session options; mode is always router)."""
    add_session_arguments(parser, default_mode="router")


def run_from_args(args: argparse.Namespace) -> int:
    """Run with options parsed by :func:`add_arguments`."""
    if args.mode not in (None, "router"):
        raise ValueError("the router always runs in router mode")
    return run(args.listen, args.connect, args.config, namespace=args.namespace,
               ready=lambda zid: print(f"router {zid} listening on {args.listen or 'tcp/127.0.0.1:7447'}", flush=True))


def main(argv: list[str] | None = None) -> int:
    """``python -m services.router [--listen EP] [--connect EP] [--config FILE]``."""
    parser = argparse.ArgumentParser(prog="acnmp serve router", description=__doc__.splitlines()[0])
    add_arguments(parser)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s router %(levelname)s %(message)s")
    return run_from_args(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
