"""The recorder: subscribes ``acnmp/<ns>/event/**`` and is the one writer of the .rrd file.

Zenoh delivers samples on its own threads; the callback only decodes and validates the event and
queues it. The main thread takes events off the queue and logs them (services/rrd_writer.py), so
there is exactly one writer and shutdown is ordered:

1. SIGTERM/SIGINT sets the stop event (services/session.py installs the handlers);
2. the subscriber is undeclared, so nothing new arrives, and the queue is drained into the file;
3. the liveliness token goes, the zenoh session closes;
4. the recording is flushed and its file sink closed, which writes the footer
   (``rerun rrd verify FILE`` passes).

Declared entities: subscriber ``acnmp/<ns>/event/**``, queryable ``acnmp/<ns>/recorder/status``
(reply: ``{"v":1,"path","events":{kind:n},"rollouts":{job:n},"rejected":n}``), then, once both
exist, liveliness token ``acnmp/<ns>/recorder/<zid>``: a publisher that sees the token knows its
events will be recorded.
"""
from __future__ import annotations

import argparse
import logging
import queue
import sys
import threading
import time
from pathlib import Path
from typing import Callable, Sequence

import zenoh

from services import keys
from services.events import decode_event
from services.rrd_writer import RrdWriter
from services.session import (add_session_arguments, declare_rpc, install_shutdown_handlers,
                              open_session, session_kwargs)
from services.wire import WireError

log = logging.getLogger(__name__)

#: Events queued between zenoh threads and the writer; when full, the callback blocks, and since
#: events are put with CongestionControl.BLOCK the publishers slow down instead of losing events.
QUEUE_SIZE = 10_000


def run(path: str | Path, namespace: str = keys.DEFAULT_NAMESPACE, *, mode: str | None = "peer",
        listen: Sequence[str] | None = None, connect: Sequence[str] | None = None,
        config_file: str | None = None, stop: threading.Event | None = None,
        ready: Callable[[str], None] | None = None) -> dict:
    """Record events of ``namespace`` into ``path`` until ``stop`` is set (default: a signal).

    Returns the final counts (``{"events": {...}, "rollouts": {...}, "rejected": n}``). ``ready``
    is called with the liveliness key once the recorder is live.
    """
    if stop is None:
        stop = install_shutdown_handlers()
    events: queue.Queue = queue.Queue(maxsize=QUEUE_SIZE)
    rejected = [0]

    overflow: list = []  # events that arrived while shutting down with a full queue
    lock = threading.Lock()

    def on_sample(sample: zenoh.Sample) -> None:
        try:
            msg = decode_event(sample.payload.to_bytes())
        except WireError as exc:
            # a bad event is reported, never recorded: the .rrd only holds valid data
            with lock:
                rejected[0] += 1
            log.warning("rejected event on %s: %s", sample.key_expr, exc)
            return
        while True:
            try:
                events.put(msg, timeout=0.2)
                return
            except queue.Full:
                if stop.is_set():
                    # the main thread may be inside sub.undeclare(), waiting for this very
                    # callback: never block then, keep the event aside for the final drain
                    overflow.append(msg)
                    return

    writer = RrdWriter(path)
    try:
        with open_session(mode, listen, connect, config_file) as session:
            sub = session.declare_subscriber(keys.event_subscription(namespace), on_sample)
            status = declare_rpc(session, keys.recorder_status_key(namespace),
                                 lambda _req, _q: {"v": 1, "path": str(path), "rejected": rejected[0],
                                                   **writer.stats()})
            token_key = keys.liveliness_key(namespace, "recorder", str(session.zid()))
            token = session.liveliness().declare_token(token_key)
            log.info("recording %s into %s", keys.event_subscription(namespace), path)
            if ready is not None:
                ready(token_key)
            while not stop.is_set():
                _drain(events, writer, timeout=0.2)
            sub.undeclare()
            _drain(events, writer, timeout=0.0, until_empty=True)
            for msg in overflow:
                writer.log_event(msg)
            token.undeclare()
            status.close()
    finally:
        writer.close()
    final = {**writer.stats(), "rejected": rejected[0]}
    log.info("recording closed: %s", final)
    return final


def _drain(events: queue.Queue, writer: RrdWriter, *, timeout: float, until_empty: bool = False) -> None:
    """Log queued events: wait up to ``timeout`` for the first, then take what is there."""
    try:
        msg = events.get(timeout=timeout) if timeout > 0 else events.get_nowait()
    except queue.Empty:
        return
    deadline = time.monotonic() + 0.5  # come back to check the stop flag at least twice a second
    while True:
        try:
            writer.log_event(msg)
        except Exception:  # one unloggable event must not stop the recording
            log.exception("could not log %s event", msg.get("kind"))
        if not until_empty and time.monotonic() > deadline:
            return
        try:
            msg = events.get_nowait()
        except queue.Empty:
            return


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the recorder's options: --out FILE plus the shared session options."""
    parser.add_argument("--out", "-o", default="runs/recording.rrd", metavar="FILE.rrd",
                        help="recording to write (default: %(default)s)")
    add_session_arguments(parser)


def run_from_args(args: argparse.Namespace) -> int:
    """Run with options parsed by :func:`add_arguments`; exit code 0 after a clean shutdown."""
    run(args.out, args.namespace, **session_kwargs(args),
        ready=lambda key: print(f"recorder live as {key}, writing {args.out}", flush=True))
    return 0


def main(argv: list[str] | None = None) -> int:
    """``python -m services.recorder --out FILE.rrd [--namespace NS] [--connect EP] ...``."""
    parser = argparse.ArgumentParser(prog="acnmp serve recorder", description=__doc__.splitlines()[0])
    add_arguments(parser)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s recorder %(levelname)s %(message)s")
    return run_from_args(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
