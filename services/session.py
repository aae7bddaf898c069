"""Zenoh sessions for the deployment: configuration, lifetime, shutdown, liveliness and RPC helpers.

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
import logging
import os
import signal
import socket
import threading
import time
import traceback
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

import zenoh

from services import keys
from services.wire import (DEFAULT_MAX_BYTES, SCHEMA_VERSION, WireError, decode, encode,
                           error_from_payload, error_payload)

log = logging.getLogger(__name__)

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
            raise ValueError(f"zenoh config {config_file}: {exc}") from None
    else:
        cfg = zenoh.Config()
    pristine = zenoh.Config()

    def from_file(key: str) -> bool:
        # the file set `key` iff it differs from a fresh Config's value
        return config_file is not None and cfg.get_json(key) != pristine.get_json(key)

    def put(key: str, value: Any) -> None:
        cfg.insert_json5(key, json.dumps(value))

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
                raise ConnectionError(f"cannot open zenoh session: {exc}") from None
            time.sleep(delay)
            delay = min(delay * 2, 1.0)
    try:
        yield session
    finally:
        with contextlib.suppress(Exception):
            session.close()


# --------------------------------------------------------------------------------------------
# shutdown


def install_shutdown_handlers(stop: threading.Event | None = None) -> threading.Event:
    """Make SIGTERM and SIGINT set ``stop`` (a new Event if None) and return it.

    The main loop waits on the event and then closes everything in order. A second signal raises
    SystemExit(128+signum) for an impatient operator. Call from the main thread only (Python
    delivers signals there).
    """
    stop = stop if stop is not None else threading.Event()

    def handler(signum, _frame):
        if stop.is_set():
            raise SystemExit(128 + signum)
        log.info("signal %s: shutting down", signal.Signals(signum).name)
        stop.set()

    signal.signal(signal.SIGTERM, handler)
    signal.signal(signal.SIGINT, handler)
    watch_parent(stop)
    return stop


#: Set by the launcher in its children's environment: the launcher's pid.
PARENT_PID_ENV = "ACNMP_PARENT_PID"


def watch_parent(stop: threading.Event, poll: float = 0.5) -> threading.Thread | None:
    """When this process was started by a launcher (``ACNMP_PARENT_PID`` in the environment), set
    ``stop`` as soon as that launcher is gone (killed with ``kill -9``, say), so no child outlives its
    deployment and the recorder still finalises its file. Returns the watching thread, or None when
    there is no launcher to watch."""
    raw = os.environ.get(PARENT_PID_ENV)
    if not raw:
        return None
    try:
        parent = int(raw)
    except ValueError:
        log.warning("%s=%r is not a pid; not watching the launcher", PARENT_PID_ENV, raw)
        return None

    def run() -> None:
        # A dead parent's children are re-parented (to init or a subreaper): getppid() changes.
        while not stop.wait(poll):
            if os.getppid() != parent:
                log.warning("launcher (pid %d) is gone: shutting down", parent)
                stop.set()
                return

    if os.getppid() != parent:  # started by something else that merely passed the variable on
        return None
    thread = threading.Thread(target=run, name="watch-launcher", daemon=True)
    thread.start()
    return thread


def wait_until_stopped(stop: threading.Event, poll: float = 0.2) -> None:
    """Block until ``stop`` is set, waking up regularly so signal handlers get to run."""
    while not stop.wait(poll):
        pass


# --------------------------------------------------------------------------------------------
# liveliness


def wait_for_liveliness(session: zenoh.Session, key_expr: str, count: int = 1,
                        timeout: float = 10.0) -> list[str]:
    """Wait until at least ``count`` liveliness tokens matching ``key_expr`` are alive.

    Returns the sorted token keys. Raises TimeoutError (listing what was seen) after ``timeout``.
    A subscriber with history sees tokens declared before and after the call.
    """
    alive: set[str] = set()
    cond = threading.Condition()

    def on_sample(sample: zenoh.Sample) -> None:
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
    """Return the keys of the liveliness tokens matching ``key_expr`` alive now (one query)."""
    found = set()
    for reply in session.liveliness().get(key_expr, timeout=timeout):
        if reply.ok is not None:
            found.add(str(reply.ok.key_expr))
    return sorted(found)


# --------------------------------------------------------------------------------------------
# RPC over queries


def query(session: zenoh.Session, key: str, payload: dict | bytes | None = None, timeout: float = 5.0, *,
          expect_version: int | None = SCHEMA_VERSION, max_bytes: int = DEFAULT_MAX_BYTES) -> dict:
    """Send one query and return the first reply, decoded.

    ``payload`` is a message map (encoded here), raw bytes, or None. A ``reply_err`` is raised as
    the :class:`WireError` it carries; no reply at all raises WireError ``timeout`` (or
    ``unavailable`` if the query ended early because nothing matched).
    """
    body = encode(payload) if isinstance(payload, dict) else payload
    start = time.monotonic()
    replies = session.get(key, payload=body, timeout=timeout)
    for reply in replies:
        if reply.ok is not None:
            return decode(reply.ok.payload.to_bytes(), expect_version=expect_version, max_bytes=max_bytes)
        raise error_from_payload(reply.err.payload.to_bytes())
    waited = time.monotonic() - start
    if waited < timeout * 0.9:
        raise WireError("unavailable", f"no service answered on {key}")
    raise WireError("timeout", f"no reply on {key} within {timeout}s")


Handler = Callable[[Any, zenoh.Query], Any]


class RpcQueryable:
    """A queryable whose handler errors become ``reply_err`` payloads; see :func:`declare_rpc`.

    Use as a context manager or call :meth:`close`; closing undeclares the queryable and waits
    for handlers in flight (when a thread pool is used).
    """

    def __init__(self, session: zenoh.Session, key_expr: str, handler: Handler, *, workers: int = 0,
                 decode_payload: bool = True, expect_version: int | None = SCHEMA_VERSION,
                 max_bytes: int = DEFAULT_MAX_BYTES, complete: bool = True):
        self.key_expr = key_expr
        self._handler = handler
        self._decode = decode_payload
        self._expect_version = expect_version
        self._max_bytes = max_bytes
        self._pool = ThreadPoolExecutor(workers, thread_name_prefix="rpc") if workers > 0 else None
        self.served = 0
        self.failed = 0
        self._lock = threading.Lock()
        callback = self._dispatch if self._pool else self._serve
        self._queryable = session.declare_queryable(key_expr, callback, complete=complete)

    def _dispatch(self, query: zenoh.Query) -> None:
        # hand the query to the pool so a slow handler never holds a zenoh runtime thread
        try:
            self._pool.submit(self._serve, query)
        except RuntimeError:  # pool shut down: we are closing
            with contextlib.suppress(Exception):
                query.reply_err(error_payload("unavailable", "service is shutting down"))
            query.drop()

    def _serve(self, query: zenoh.Query) -> None:
        # `with query` drops it at the end: the querier's get() only finishes once it is dropped
        with query:
            try:
                request = None
                if self._decode:
                    raw = query.payload.to_bytes() if query.payload is not None else b""
                    request = decode(raw, expect_version=self._expect_version,
                                     max_bytes=self._max_bytes) if raw else None
                result = self._handler(request, query)
                body = encode(result) if isinstance(result, dict) else bytes(result)
                query.reply(self._reply_key(query), body)
                with self._lock:
                    self.served += 1
            except WireError as exc:
                self._fail(query, exc.code, exc.message)
            except Exception as exc:  # a raising callback would send no reply at all
                log.error("handler for %s failed:\n%s", self.key_expr, traceback.format_exc())
                self._fail(query, "internal", f"{type(exc).__name__}: {exc}")

    def _reply_key(self, query: zenoh.Query) -> str:
        # replies must intersect the query's key; a concrete query key is always safe
        key = str(query.key_expr)
        return key if "*" not in key else self.key_expr

    def _fail(self, query: zenoh.Query, code: str, message: str) -> None:
        with self._lock:
            self.failed += 1
        try:
            query.reply_err(error_payload(code, message))
        except Exception:  # session closing under us: nothing left to tell
            log.debug("reply_err failed on %s", self.key_expr, exc_info=True)

    def close(self) -> None:
        """Undeclare the queryable, then let handlers in flight finish."""
        with contextlib.suppress(Exception):
            self._queryable.undeclare()
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=False)

    def __enter__(self) -> "RpcQueryable":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def declare_rpc(session: zenoh.Session, key_expr: str, handler: Handler, **kwargs) -> RpcQueryable:
    """Declare a queryable on ``key_expr`` that answers every query exactly once.

    ``handler(request, query)`` gets the decoded request map (None when the query has no
    payload) and returns a reply map (encoded here) or bytes. A :class:`WireError` it raises
    (or that decoding raises) becomes ``reply_err`` with that code; any other exception becomes
    code ``internal``; the queryable keeps serving. ``workers=N`` runs handlers on N threads.
    Other keyword arguments: see :class:`RpcQueryable`.
    """
    return RpcQueryable(session, key_expr, handler, **kwargs)


# --------------------------------------------------------------------------------------------
# command-line plumbing shared by every `acnmp serve <process>`


def add_session_arguments(parser: argparse.ArgumentParser, *, default_mode: str = "peer") -> None:
    """Add --namespace, --mode, --listen, --connect, --config to a parser."""
    parser.add_argument("--namespace", "-n", default=keys.DEFAULT_NAMESPACE,
                        help="key prefix acnmp/<namespace>/ shared by one deployment (default: %(default)s)")
    parser.add_argument("--mode", choices=MODES, default=None,
                        help=f"zenoh mode (default: {default_mode}, or what --config says)")
    parser.add_argument("--listen", action="append", default=None, metavar="EP",
                        help="endpoint to listen on, e.g. tcp/127.0.0.1:7447 (repeatable; default: loopback)")
    parser.add_argument("--connect", action="append", default=None, metavar="EP",
                        help="endpoint to connect to, e.g. tcp/127.0.0.1:7447 (repeatable)")
    parser.add_argument("--config", default=None, metavar="FILE",
                        help="zenoh JSON5 config file, merged under the options above")
    parser.set_defaults(_default_mode=default_mode)


def session_kwargs(args: argparse.Namespace) -> dict:
    """Turn parsed :func:`add_session_arguments` options into :func:`open_session` keyword arguments."""
    mode = args.mode
    if mode is None and args.config is None:
        mode = getattr(args, "_default_mode", "peer")
    return {"mode": mode, "listen": args.listen, "connect": args.connect, "config_file": args.config}
