"""Publishing events on a session: the sending side of the recording.

Events go through zenoh-ext **advanced publishers** (one per event key, declared on first use)
with a cache: a recorder that (re)starts while this process runs recovers, from each publisher's
cache, the events it missed (services/recording/recorder.py, docs/EVENTS.md).
"""
from __future__ import annotations

import logging
import threading
import time
from collections import Counter, OrderedDict

import zenoh
import zenoh.ext as zext

from services.transport import Keyspace, WireError, call, encode, wait_for_liveliness

from .event_ids import IndexRanges
from .events import event_key, validate_event

log = logging.getLogger(__name__)

#: Events each publisher (one per event key, e.g. one job's roll-outs) keeps for late or restarted
#: recorders. Beyond it the oldest cached event of that key is dropped: a recorder down while more
#: than this many events of one key are published misses the oldest ones (it counts them as
#: ``missed`` in its status reply, from zenoh's sample-miss detection).
CACHE_SAMPLES = 1000

#: Event keys with a live publisher (and cache) per EventPublisher; publishing on one more key
#: undeclares the least recently used one, whose cache goes with it. So one process holds at most
#: MAX_KEYS * CACHE_SAMPLES cached events (a learner's keys: one per job and per skill).
MAX_KEYS = 64

#: Seconds between the heartbeats by which a subscriber learns a publisher's last sequence number
#: (zenoh-ext sample-miss detection), so a lost tail of events is also recovered.
HEARTBEAT = 0.5

#: Seconds between two looks at the recorder's counts in :meth:`EventPublisher.wait_recorded`.
POLL_INTERVAL = 0.05


class EventPublisher:
    """Publishes the events of one namespace on an open session.

    Puts use ``CongestionControl.BLOCK``: an event is a record of what happened (the recorder
    must count every roll-out once), so it is better to slow the sender than to drop it.
    Each event key gets its own advanced publisher with a cache of ``cache_samples`` (default
    :data:`CACHE_SAMPLES`) events, for the :data:`MAX_KEYS` keys used last; they live until
    :meth:`close` or the session closes.
    """

    def __init__(self, session: zenoh.Session, keys: Keyspace | str, cache_samples: int = CACHE_SAMPLES):
        if cache_samples < 1:
            raise ValueError(f"cache_samples: expected >= 1, got {cache_samples}")
        self.session = session
        self.keys = keys if isinstance(keys, Keyspace) else Keyspace(keys)
        self.cache_samples = int(cache_samples)
        self._publishers: OrderedDict[str, zext.AdvancedPublisher] = OrderedDict()
        self._lock = threading.Lock()
        self._rollouts: Counter[str] = Counter()  # rollout events published per job

    def _publisher(self, key: str) -> zext.AdvancedPublisher:
        with self._lock:
            pub = self._publishers.get(key)
            if pub is not None:
                self._publishers.move_to_end(key)
            else:
                if len(self._publishers) >= MAX_KEYS:
                    self._publishers.popitem(last=False)[1].undeclare()
                pub = zext.declare_advanced_publisher(
                    self.session, key, congestion_control=zenoh.CongestionControl.BLOCK,
                    cache=zext.CacheConfig(max_samples=self.cache_samples),
                    sample_miss_detection=zext.MissDetectionConfig(heartbeat=HEARTBEAT),
                    publisher_detection=True)
                self._publishers[key] = pub
            return pub

    def publish(self, msg: dict) -> None:
        """Validate, encode and put one event (any kind)."""
        validate_event(msg)
        self._publisher(event_key(self.keys, msg)).put(encode(msg))
        if msg["kind"] == "rollout":
            with self._lock:
                self._rollouts[msg["job"]] += 1

    def rollouts_published(self) -> dict[str, int]:
        """``{job: n}``: the rollout events this publisher has put, per job."""
        with self._lock:
            return dict(self._rollouts)

    def _held_by_recorder(self, timeout: float) -> dict[str, int]:
        """``{job: n}``: the roll-outs of each job the recorder holds, as its status says: those it
        wrote and those it found already held when they were published again (``republished``, a
        learner's journal). WireError when no recorder answers."""
        status = call(self.session, self.keys.recorder_status(), None, timeout=timeout)
        held = dict(status.get("rollouts") or {})
        for job, n in (status.get("republished") or {}).items():
            held[job] = held.get(job, 0) + n
        return held

    def held(self, jobs: list[str], timeout: float = 5.0) -> dict[str, IndexRanges]:
        """``{job: indices}``: the roll-outs of each of ``jobs`` that the recording's files hold (one
        status query; the recorder flushes its file before it answers, so they survive its kill -9).
        ``{}`` when no recorder answers or its reply cannot be read."""
        if not jobs:
            return {}
        try:
            status = call(self.session, self.keys.recorder_status(), {"v": 1, "jobs": list(jobs)}, timeout=timeout)
            return {job: IndexRanges.from_wire(status["held"][job]) for job in jobs if job in status["held"]}
        except (WireError, KeyError, TypeError, ValueError) as exc:
            log.debug("the recorder's held roll-outs are unknown: %s", exc)
            return {}

    def wait_recorded(self, timeout: float = 10.0) -> bool:
        """Block until the recorder's counts (its status queryable) hold every rollout event this
        publisher put, job by job; True when they do, False after ``timeout`` s (or at once when no
        recorder answers). A put returns when the event is queued, not when it is recorded: call
        this before stopping the recorder, or the events still in flight are lost with it."""
        wanted = self.rollouts_published()
        if not wanted:
            return True
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            try:
                have = self._held_by_recorder(min(left, 5.0))
            except WireError as exc:
                if exc.code == "unavailable":  # no recorder: nothing will ever record them
                    return False
                continue
            if all(have.get(job, 0) >= n for job, n in wanted.items()):
                return True
            time.sleep(min(POLL_INTERVAL, max(0.0, deadline - time.monotonic())))

    def close(self) -> None:
        """Undeclare the publishers (their caches go with them); idempotent."""
        with self._lock:
            pubs, self._publishers = list(self._publishers.values()), OrderedDict()
        for pub in pubs:
            pub.undeclare()

    def wait_for_recorder(self, timeout: float = 10.0) -> bool:
        """Block until a recorder of this namespace is live (its liveliness token); True if found.

        Call it before the first event: an event published before any recorder ran is still
        recovered from the cache, but waiting keeps the recording in order.
        """
        try:
            wait_for_liveliness(self.session, self.keys.tokens("recorder"), timeout=timeout)
            return True
        except TimeoutError:
            return False
