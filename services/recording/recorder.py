"""The recorder: subscribes ``acnmp/<ns>/event/**`` and is the one writer of the .rrd file.

Zenoh delivers samples on its own threads; the callback only decodes and validates the event and
queues it. The main thread takes events off the queue and logs them (services/rrd_writer.py), so
there is exactly one writer and shutdown is ordered:

1. SIGTERM/SIGINT sets the stop event (services/transport/lifetime.py installs the handlers);
   when the stop comes from the launcher's death instead (no launcher orders the shutdown: every
   child stops at once), the recorder goes on recording until no learner's liveliness token is
   left in its namespace (a learner drops it last, once its last events are recorded; at most
   :data:`LEARNER_GRACE` s), so the learner's last events (a running job's ``interrupted``) are in
   the file;
2. the subscriber is undeclared, so nothing new arrives, and the queue is drained into the file;
3. the liveliness token goes;
4. the recording is flushed and its file sink closed, which writes the footer
   (``rerun rrd verify FILE`` passes); then the zenoh session closes.

Declared entities: advanced subscriber ``acnmp/<ns>/event/**`` (zenoh-ext: history from the
publishers' caches, late publisher detection, heartbeat recovery), queryable
``acnmp/<ns>/recorder/status`` (request: none, or ``{"v":1,"jobs":[job, ...]}``; reply:
``{"v":1,"path","events":{kind:n},"rollouts":{job:n},"rejected":n,"duplicates":n,
"republished":{job:n},"missed":n}``, with ``"held":{job:[[lo, hi], ...]}`` for the jobs asked: the
roll-out indices of each that the recording's files hold; ``republished``: roll-outs a learner
published again, from its journal, that the recording already held). The recorder flushes its
file before it answers, so what a reply counts or holds survives a kill -9 of the recorder: a
learner drops a roll-out from its journal only once ``held`` says so (issue 73). Then, once both
exist, liveliness token
``acnmp/<ns>/recorder/<zid>``: a publisher that sees the token knows its events will be recorded.

No event lost while the recorder is down: every event publisher keeps a cache
(services/recording/publisher.py), and a (re)started recorder gets from each live publisher the
events it holds. So that the files of one deployment hold each event once, every event is
identified by its publisher (zenoh entity global id) and sequence number (the sample's source
info), kept in a :class:`~services.recording.event_ids.SeenEvents` (per publisher a mark and a
few runs above it: memory O(publishers), not O(events)); an event already held is dropped
(``duplicates``). Events that no file holds although a later event of their publisher arrived
(they left its cache before any recorder got them) are counted as ``missed``.

A restarted recorder is given the files written before it (``--seen FILE``, oldest first). Each
recorder, before it subscribes, writes the state it starts from, atomically, into a **marks
file** beside its recording (``<file>.seen.json``, :func:`marks_path`): so the next one reads the
marks file of the newest earlier file and the event ids of that file only (what reached it
before its recorder died), not every earlier file: restarts cost O(one file), not O(all files).
"""
from __future__ import annotations

import json
import logging
import queue
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import zenoh
import zenoh.ext as zext

from services.transport import Keyspace, Ready, WireError, declare_rpc, wait_for_liveliness_gone
from services.transport.argtypes import check_output_path
from services.transport.auth import write_private
from services.transport.keys import is_concrete
from services.transport.lifetime import launcher_gone
from services.transport.wire import field

from .config import RecorderOptions
from .event_ids import SeenEvents, marks_path
from .events import decode_event, rollout_key
from .replay import recorded_event_ids
from .rrd_writer import RrdWriter
from .web_viewer import WebViewer

log = logging.getLogger(__name__)

#: Seconds a recorder whose launcher died records on while a learner still answers: longer than
#: the learner's own wait for the recorder (services/learner/service.py RECORDED_WAIT, 4 s).
LEARNER_GRACE = 6.0

#: Events queued between zenoh threads and the writer; when full, the callback blocks, and since
#: events are put with CongestionControl.BLOCK the publishers slow down instead of losing events.
QUEUE_SIZE = 10_000


def event_id(sample: zenoh.Sample) -> str | None:
    """``"<zid>/<eid>/<sn>"``: the publisher's entity global id and the sample's sequence number,
    unique per event of a deployment; None for a sample without source info (a plain put)."""
    info = sample.source_info
    if info is None or info.source_id is None or info.source_sn is None:
        return None
    return f"{info.source_id.zid}/{info.source_id.eid}/{info.source_sn}"


#: Schema version of the marks file.
MARKS_VERSION = 1


def write_marks(recording: str | Path, seen: SeenEvents) -> Path:
    """Write ``seen`` (the events held before ``recording`` was started) into its marks file,
    atomically (a reader sees the old file or the new one, never half of one); returns its path."""
    text = json.dumps({"v": MARKS_VERSION, "recording": Path(recording).name, "publishers": seen.to_json()})
    return write_private(marks_path(recording), text + "\n")


def read_marks(recording: str | Path) -> SeenEvents | None:
    """The state a recording's marks file holds, or None without a (readable) marks file."""
    try:
        data = json.loads(marks_path(recording).read_text())
        if data.get("v") != MARKS_VERSION:
            raise ValueError(f"marks file version {data.get('v')!r}")
        return SeenEvents.from_json(data["publishers"])
    except FileNotFoundError:
        return None
    except (OSError, ValueError, KeyError, AttributeError) as exc:
        log.warning("ignoring the marks file of %s: %s", recording, exc)
        return None


def earlier_events(seen: Sequence[str | Path]) -> SeenEvents:
    """The events the earlier files ``seen`` (oldest first) of this deployment hold: from the
    newest file back to the first one with a marks file, that marks file plus the event ids of
    those files (normally one: the previous recorder's). A file that cannot be read is skipped
    with a warning (a recorder that died before writing anything leaves none)."""
    ids: list[set[str]] = []
    state = None
    for earlier in reversed(list(seen)):
        try:
            ids.append(recorded_event_ids(earlier))
        except (OSError, ValueError) as exc:
            log.warning("cannot read the ids of %s: %s", earlier, exc)
        state = read_marks(earlier)
        if state is not None:
            break
    state = state or SeenEvents()
    for chunk in ids:
        state.update(chunk)
    return state


def record(session: zenoh.Session, keys: Keyspace, path: str, stop: threading.Event, ready: Ready, *,
           recording_id: str | None = None, seen: list[str] | tuple[str, ...] = (), grpc_port: int | None = None,
           web_port: int | None = None) -> dict:
    """Record the events of ``keys``' namespace into ``path`` until ``stop`` is set; returns the
    final counts. ``ready`` gets one line once the recorder is live (its token is declared).
    ``recording_id``: the Rerun recording id (None: a new one). ``seen``: files earlier recorders
    of this deployment wrote (oldest first); events they hold are not written again. Writes the
    marks file of ``path`` before subscribing (:func:`write_marks`). ``grpc_port``: also serve the
    stream live on 127.0.0.1 (the ready line gives the viewer's address), ``web_port`` with Rerun's
    web viewer connected to it."""
    events: queue.Queue = queue.Queue(maxsize=QUEUE_SIZE)
    rejected, duplicates = [0], [0]
    republished: dict[str, int] = {}  # per job: roll-outs published again that the recording holds
    ids = earlier_events(seen)

    overflow: list = []  # events that arrived while shutting down with a full queue
    lock = threading.Lock()

    def on_sample(sample: zenoh.Sample) -> None:
        if not is_concrete(sample.key_expr):  # a put on acnmp/NS/** is no event: dropped, counted
            with lock:
                rejected[0] += 1
            log.warning("rejected a sample on the wildcard %s", sample.key_expr)
            return
        try:
            msg = decode_event(sample.payload.to_bytes())
        except WireError as exc:
            # a bad event is reported, never recorded: the .rrd only holds valid data
            with lock:
                rejected[0] += 1
            log.warning("rejected event on %s: %s", sample.key_expr, exc)
            return
        eid, key = event_id(sample), rollout_key(msg)
        if eid is not None or key is not None:
            with lock:
                # every id is added (a dropped event's own number leaves no gap in its publisher's)
                new_event = eid is None or ids.add(eid)
                new_rollout = key is None or ids.add(key)
                if not (new_event and new_rollout):  # from a cache or a learner's journal, already held
                    duplicates[0] += 1
                    if new_event:  # a learner published a roll-out this recording holds again
                        republished[msg["job"]] = republished.get(msg["job"], 0) + 1
                    return
        item = (msg, eid)
        while True:
            try:
                events.put(item, timeout=0.2)
                return
            except queue.Full:
                if stop.is_set():
                    # the main thread may be inside sub.undeclare(), waiting for this very
                    # callback: never block then, keep the event aside for the final drain
                    overflow.append(item)
                    return

    def missed() -> int:
        with lock:
            return ids.missed()

    def on_miss(miss: zext.Miss) -> None:
        # zenoh-ext's view of a gap: only for a publisher this recorder already heard from, so a
        # restarted one would miss the events lost while it was down; the count comes from ids
        log.warning("missed %d event(s) of publisher %s", miss.nb, miss.source)

    writer = RrdWriter(path, recording_id=recording_id, grpc_port=grpc_port)  # creates the file's directory
    live = ""
    web = None
    if writer.grpc_url is not None:
        live = f"; live: rerun --connect {writer.grpc_url}"
        if web_port is not None:
            try:
                web = WebViewer(writer.grpc_url, web_port).start()
            except BaseException:
                writer.close()
                raise
            live += f" or {web.url}"
    try:
        write_marks(path, ids)  # before any event: the next recorder starts from these plus this file's ids
        durable = ids.copy()  # roll-outs in the files: the earlier ones', and this one's once flushed
        sub = zext.declare_advanced_subscriber(
            session, keys.events(), on_sample,
            history=zext.HistoryConfig(detect_late_publishers=True),
            recovery=zext.RecoveryConfig(heartbeat=True), subscriber_detection=True)
        misses = sub.sample_miss_listener(on_miss)

        def status_reply(request: dict | None, _query) -> dict:
            # counted first, then flushed: every roll-out the reply counts or holds is in the file
            asked = status_jobs(request)
            reply = {"v": 1, "path": str(path), "rejected": rejected[0], "duplicates": duplicates[0],
                     "republished": dict(republished), "missed": missed(), **writer.stats()}
            flushed = writer.flush()
            with lock:
                durable.update(flushed)
                if asked:
                    reply["held"] = {job: durable.ranges(f"rollout/{job}") for job in asked}
            return reply

        # its own thread: a flush waits for the disk, never on one of zenoh's
        status = declare_rpc(session, keys.recorder_status(), status_reply, workers=1)
        token_key = keys.recorder_token(str(session.zid()))
        token = session.liveliness().declare_token(token_key)
        log.info("recording %s into %s", keys.events(), path)
        ready(f"recorder live as {token_key}, writing {path}{live}")
        while not stop.is_set():
            _drain(events, writer, timeout=0.2)
        if launcher_gone.is_set():  # the learner stops at the same moment: take its last events too
            waiting = threading.Thread(target=_wait_learners_gone, args=(session, keys), daemon=True)
            waiting.start()
            while waiting.is_alive():
                _drain(events, writer, timeout=0.2)
        misses.undeclare()
        sub.undeclare()
        _drain(events, writer, timeout=0.0, until_empty=True)
        for msg, eid in overflow:
            writer.log_event(msg, eid)
        token.undeclare()
        status.close()
    finally:
        if web is not None:
            web.close()
        writer.close()
    final = {**writer.stats(), "rejected": rejected[0], "duplicates": duplicates[0], "missed": missed()}
    log.info("recording closed: %s", final)
    return final


#: Jobs one status request may ask about (``jobs``).
MAX_STATUS_JOBS = 1000


def status_jobs(request: dict | None) -> list[str]:
    """The jobs a status request asks which roll-outs the recording holds of (``{"v": 1, "jobs":
    [job, ...]}``; none without a payload); WireError ``bad_request`` for another ``jobs``."""
    jobs = field(request or {}, "jobs", list, default=[])
    if len(jobs) > MAX_STATUS_JOBS or not all(isinstance(j, str) and j for j in jobs):
        raise WireError("bad_request", f"field 'jobs': expected at most {MAX_STATUS_JOBS} job ids (strings)")
    return jobs


def _wait_learners_gone(session: zenoh.Session, keys: Keyspace) -> None:
    """Return once no learner token of ``keys``' namespace is alive, or after :data:`LEARNER_GRACE` s."""
    try:
        wait_for_liveliness_gone(session, keys.tokens("learner"), timeout=LEARNER_GRACE)
    except TimeoutError:
        log.warning("a learner was still live %.0f s after the launcher died; closing the recording", LEARNER_GRACE)


def _drain(events: queue.Queue, writer: RrdWriter, *, timeout: float, until_empty: bool = False) -> None:
    """Log queued events: wait up to ``timeout`` for the first, then take what is there."""
    try:
        msg, eid = events.get(timeout=timeout) if timeout > 0 else events.get_nowait()
    except queue.Empty:
        return
    deadline = time.monotonic() + 0.5  # come back to check the stop flag at least twice a second
    while True:
        try:
            writer.log_event(msg, eid)
        except Exception:  # one unloggable event must not stop the recording
            log.exception("could not log %s event", msg.get("kind"))
        if not until_empty and time.monotonic() > deadline:
            return
        try:
            msg, eid = events.get_nowait()
        except queue.Empty:
            return


@dataclass
class RecorderConfig(RecorderOptions):
    """The recorder process: its options (:class:`~services.recording.config.RecorderOptions`) and
    :meth:`serve`, which records until the stop event. After it returns, ``final`` holds the counts
    written (``{"events": {...}, "rollouts": {...}, "rejected": n}``)."""

    def serve(self, session: zenoh.Session, stop: threading.Event, ready: Ready) -> int:
        """Record on the open zenoh ``session`` until ``stop``; returns the exit code."""
        check_output_path(self.out, "--out")  # one line, not rerun's error and its warning at exit
        if self.web_viewer is not None and self.serve_grpc is None:
            raise ValueError("--web-viewer: only with --serve-grpc (the web viewer shows that stream)")
        self.final = record(session, Keyspace(self.session.namespace), self.out, stop, ready,
                            recording_id=self.recording_id, seen=self.seen, grpc_port=self.serve_grpc,
                            web_port=self.web_viewer)
        return 0
