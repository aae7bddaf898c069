"""Zenoh sessions: configuration (loopback, no multicast by default), opening and closing them.

Discovery on one machine (what ``acnmp up`` uses)
-------------------------------------------------
Multicast scouting is off by default (it would announce on every interface), so peers need another
way to find each other. The launcher opens a *peer* session listening on one loopback endpoint, the
**anchor** (``tcp/127.0.0.1:<free port>``), and starts every child with ``--connect <anchor>`` and
``--listen tcp/127.0.0.1:0``. Zenoh's gossip scouting (on by default for peers, it travels over
existing links, no multicast) tells each newcomer the locators of the peers already connected, and
peers auto-connect, so the deployment becomes a full mesh: queries go process-to-process in one hop
and keep working if the anchor goes away. Measured on this machine: a third peer is meshed with the
second ~0.1 s after opening, and a put between them arrives after the anchor closed.
A router (services/router.py) with client-mode processes is the alternative for several hosts or
containers: one more hop, a single point of failure, but one address to open in a firewall.

A peer whose ``connect`` endpoint is not up yet still opens and keeps retrying in the background;
a *client* fails at once, so :func:`open_session` retries opening a client until ``open_timeout``.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import re
import socket
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Sequence

import zenoh

from .argtypes import key_name
from .keys import DEFAULT_NAMESPACE
from .payload_limits import low_pass_filters
from .wire import DEFAULT_MAX_BYTES

MODES = ("peer", "client", "router")
LOOPBACK = "127.0.0.1"
DEFAULT_ROUTER_PORT = 7447

def free_port(host: str = LOOPBACK) -> int:
    """Return a TCP port that was free on ``host`` a moment ago (the OS picks it)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def loopback_endpoint(port: int = 0) -> str:
    """``tcp/127.0.0.1:<port>``; port 0 lets the OS choose when listening."""
    return f"tcp/{LOOPBACK}:{int(port)}"


#: Config keys that come from command-line options, for error messages.
_OPTIONS = {"mode": "--mode", "listen/endpoints": "--listen", "connect/endpoints": "--connect"}


def _zenoh_message(exc: BaseException) -> str:
    """The readable part of a zenoh error: its first sentence, without Rust source locations."""
    lines = str(exc).splitlines()
    text = lines[0] if lines else type(exc).__name__
    if text.lstrip().startswith("-->"):  # a JSON5 syntax error: " --> 1:9", a drawing, "  = expected ..."
        what = [ln.strip()[2:] for ln in lines if ln.strip().startswith("= ")]
        text = f"line:column {text.strip()[3:].strip()}: {what[-1] if what else 'syntax error'}"
    text = re.sub(r"\s+at /\S+:\d+\.?", "", text)           # "... at /root/.cargo/...rs:615."
    text = re.sub(r"^Json5Err\(Message \{ msg: \"(.*?)(: [^:]*)?\", location.*$", r"\1", text)
    return text.strip()


#: The largest zenoh message a session takes in (``transport/link/rx/max_message_size``): the
#: request limit (services/transport/wire.py) and 1 MiB for the key, attachment and framing. A
#: bigger message is refused while its fragments arrive, before it is whole in memory (zenoh's
#: default is 1 GiB).
MAX_MESSAGE_BYTES = DEFAULT_MAX_BYTES + (1 << 20)


def make_config(mode: str | None = "peer", listen: Sequence[str] | None = None,
                connect: Sequence[str] | None = None, config_file: str | Path | None = None, *,
                multicast: bool | None = None, gossip: bool | None = None) -> zenoh.Config:
    """Build a zenoh Config: built-in defaults, then ``config_file`` (JSON5/YAML), then arguments.

    Defaults: ``mode`` peer; listen ``tcp/127.0.0.1:0`` for peers, ``tcp/127.0.0.1:7447`` for a
    router, nothing for a client; no connect endpoint; multicast scouting off; gossip scouting
    on. A value the config file sets wins over a default; an explicit argument (not None) wins
    over the file. Raises ValueError for an unknown mode or a file that does not parse.
    """
    if config_file is not None:
        try:
            cfg = zenoh.Config.from_file(str(config_file))
        except Exception as exc:  # zenoh raises ZError; make it the CLI's ValueError
            raise ValueError(f"--config {config_file}: {_zenoh_message(exc)}") from None
    else:
        cfg = zenoh.Config()
    pristine = zenoh.Config()

    def from_file(key: str) -> bool:
        # the file set `key` iff it differs from a fresh Config's value
        return config_file is not None and cfg.get_json(key) != pristine.get_json(key)

    def put(key: str, value: Any) -> None:
        try:
            cfg.insert_json5(key, json.dumps(value))
        except zenoh.ZError as exc:  # e.g. an endpoint without <protocol>/: the CLI's ValueError
            option = _OPTIONS.get(key, key)
            raise ValueError(f"{option} {' '.join(map(str, value)) if isinstance(value, list) else value}: "
                             f"{_zenoh_message(exc)}") from None

    if mode is not None:
        if mode not in MODES:
            raise ValueError(f"zenoh mode {mode!r} is not one of {MODES}")
        put("mode", mode)
    elif not from_file("mode"):
        put("mode", "peer")
    effective = json.loads(cfg.get_json("mode")) or "peer"

    if listen is not None:
        put("listen/endpoints", list(listen))
    elif not from_file("listen/endpoints"):
        default_listen = {"peer": [loopback_endpoint(0)],
                          "router": [loopback_endpoint(DEFAULT_ROUTER_PORT)], "client": []}[effective]
        put("listen/endpoints", default_listen)
    if connect is not None:
        put("connect/endpoints", list(connect))
    if multicast is not None or not from_file("scouting/multicast/enabled"):
        put("scouting/multicast/enabled", bool(multicast))
    if gossip is not None or not from_file("scouting/gossip/enabled"):
        put("scouting/gossip/enabled", True if gossip is None else bool(gossip))
    if not from_file("transport/link/rx/max_message_size"):
        put("transport/link/rx/max_message_size", MAX_MESSAGE_BYTES)
    if not from_file("low_pass_filter"):
        put("low_pass_filter", low_pass_filters())
    return cfg


@contextlib.contextmanager
def open_session(mode: str | None = "peer", listen: Sequence[str] | None = None,
                 connect: Sequence[str] | None = None, config_file: str | Path | None = None, *,
                 config: zenoh.Config | None = None, open_timeout: float = 10.0,
                 multicast: bool | None = None) -> Iterator[zenoh.Session]:
    """Open a zenoh session (``with open_session(...) as s:``) and always close it on exit.

    Takes the arguments of :func:`make_config`, or a ready ``config``. A client whose router is
    not up yet is retried until ``open_timeout`` seconds; then ConnectionError. Closing matters: a
    process with an open session hangs at interpreter exit.
    """
    cfg = config if config is not None else make_config(mode, listen, connect, config_file, multicast=multicast)
    deadline = time.monotonic() + open_timeout
    delay = 0.05
    while True:
        try:
            session = zenoh.open(cfg)
            break
        except zenoh.ZError as exc:
            if time.monotonic() + delay > deadline:
                raise ConnectionError(f"cannot open zenoh session: {_zenoh_message(exc)}") from None
            time.sleep(delay)
            delay = min(delay * 2, 1.0)
    try:
        yield session
    finally:
        with contextlib.suppress(Exception):
            session.close()



@dataclass
class SessionOptions:
    """The zenoh options every process and command shares (``--namespace --mode --listen --connect
    --config``); ``None`` leaves a value to the config file or the default."""

    namespace: str = DEFAULT_NAMESPACE
    mode: str | None = None
    listen: list[str] | None = None
    connect: list[str] | None = None
    config: str | None = None

    @staticmethod
    def add_arguments(parser: argparse.ArgumentParser, *, default_mode: str = "peer",
                      modes: Sequence[str] = MODES) -> None:
        """Add the options to ``parser``; ``default_mode`` is what ``--mode`` says when not given."""
        parser.add_argument("--namespace", "-n", type=key_name("namespace"), default=DEFAULT_NAMESPACE,
                            help="key prefix acnmp/<namespace>/ shared by one deployment (default: %(default)s)")
        parser.add_argument("--mode", choices=tuple(modes), default=None,
                            help=f"zenoh mode (default: {default_mode}, or what --config says)")
        parser.add_argument("--listen", action="append", default=None, metavar="EP",
                            help="endpoint to listen on, e.g. tcp/127.0.0.1:7447 (repeatable; default: loopback)")
        parser.add_argument("--connect", action="append", default=None, metavar="EP",
                            help="endpoint to connect to, e.g. tcp/127.0.0.1:7447 (repeatable)")
        parser.add_argument("--config", default=None, metavar="FILE",
                            help="zenoh JSON5 config file, merged under the options above")

    @classmethod
    def from_args(cls, args: argparse.Namespace) -> "SessionOptions":
        """The options parsed by :meth:`add_arguments`."""
        return cls(args.namespace, args.mode, args.listen, args.connect, args.config)

    def open(self, default_mode: str = "peer", **kwargs) -> contextlib.AbstractContextManager[zenoh.Session]:
        """:func:`open_session` with these options (``default_mode`` unless ``mode`` or the config
        file says otherwise); ``kwargs`` go to :func:`open_session`."""
        mode = self.mode if self.mode is not None or self.config is not None else default_mode
        return open_session(mode, self.listen, self.connect, self.config, **kwargs)
