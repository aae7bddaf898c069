"""The roll-out journals of a learner's jobs: kept until the recorder holds them, published again
one by one at a start (issues 66 and 73).

A running job writes each batch's roll-out events to its journal (``jobs/<job>.rollouts``) before
their indices are reserved and before they are published (services/learner/core.py). A roll-out
leaves the journal only once the recorder says its file holds it (``held`` in the recorder's
status reply: the recorder flushes its file before it answers, so what it says it holds survives
its kill -9; :meth:`Journals.settle`, called every second by the learner service): so a learner
killed anywhere, the recorder with it or not, publishes at its next start every roll-out the
recording may lack. Until issue 73 a journal kept the last two batches only, and a recorder
killed with the learner lost the events it had received but not yet written.

At a start :class:`Journals` publishes every journal again, each on its own:

* a journal holding events that cannot be published (a return of -inf, a bad field: what
  :func:`services.recording.events.validate_event` and the wire refuse) is **quarantined** like
  any unusable state file (moved to ``quarantine/``, named in the learner's health, hence
  ``acnmp status`` exits 1), and its other events are published (and journalled again);
* a journal whose publishing fails for another reason (the session) is **held**: its events
  stay in memory and in every later journal of its job, are tried again every :data:`RETRY_S`
  seconds, and the job is named in the learner's health until they are published;
* one journal never keeps the others from being published.

A finished job's journal is removed once the recorder holds all of its roll-outs, so a later
session publishes no fragment of an old job into a new recording; one never confirmed (a learner
killed right after its job ended) is published again at the next start, to lose nothing (the
recorder keeps each roll-out once).
"""
from __future__ import annotations

import logging
import threading
from dataclasses import dataclass
from typing import Callable, Iterable

from services.recording.event_ids import IndexRanges
from services.recording.events import validate_event
from services.transport.wire import WireError, encode

from .store import JobStore, StateWriteError

log = logging.getLogger(__name__)

#: Seconds between tries to publish a held journal.
RETRY_S = 5.0

#: Roll-out events a job's journal keeps at most while the recorder does not confirm them (it is
#: unreachable): beyond, the oldest go, as a publisher's cache of that many events would lose them
#: (services/recording/publisher.py); a journal is written again with every batch.
MAX_UNCONFIRMED = 1000


@dataclass(frozen=True)
class PendingJournal:
    """Job ``job``'s journalled roll-out events (``events`` of them) not yet published, and why."""

    job: str
    events: int
    error: str

    def line(self) -> str:
        """One line for the learner's health (``acnmp status``)."""
        return (f"job {self.job}: {self.events} journalled roll-out event(s) not published yet ({self.error}); "
                f"tried again every {RETRY_S:g} s")


@dataclass(frozen=True)
class Settled:
    """What one :meth:`Journals.settle` did: the jobs whose journals it removed, the roll-outs the
    recorder confirmed (dropped from the journals), the jobs whose journals still wait for it."""

    removed: tuple[str, ...] = ()
    confirmed: int = 0
    waiting: tuple[str, ...] = ()


def unpublishable(event: dict) -> str | None:
    """Why ``event`` cannot be published (its wire code and message), or None when it can."""
    try:
        validate_event(event)
        encode(event)
    except WireError as exc:
        return f"{exc.code}: {exc.message}"
    except (TypeError, ValueError, KeyError) as exc:
        return f"{type(exc).__name__}: {exc}"
    return None


def _index(event: dict) -> int | None:
    index = event.get("rollout_index")
    return index if isinstance(index, int) and not isinstance(index, bool) else None


class Journals:
    """The journals of a learner's jobs (see the module docstring).

    ``store`` holds them; ``publish(event)`` publishes one event; ``stop`` ends a replay early.
    Thread-safe: the replay, the job threads (:meth:`save`) and the service (:meth:`settle`) share it.
    """

    def __init__(self, store: JobStore, publish: Callable[[dict], None], stop: threading.Event):
        self.store, self.publish, self.stop = store, publish, stop
        self._unpublished: dict[str, list[dict]] = {}  # read at the start, not yet published
        self._held: dict[str, tuple[list[dict], str]] = {}  # job -> (events, why): publishing failed
        self._open: dict[str, dict[int, dict]] = {}  # job -> {index: event} journalled, not confirmed held
        self._lock = threading.Lock()

    def read(self) -> dict[str, int]:
        """Read every journal (:meth:`JobStore.take_journal`; an unreadable one is quarantined there)
        for :meth:`replay`; returns ``{job: one above the highest roll-out index it holds}``: those
        indices count as reserved (the kill may have come between the journal's write and the
        reservation's)."""
        tops = {}
        for job_id in self.store.journals():
            events = self.store.take_journal(job_id)
            if not events:
                self.store.drop_journal(job_id)
                continue
            self._unpublished[job_id] = events
            indices = [i for i in map(_index, events) if i is not None]
            if indices:
                tops[job_id] = 1 + max(indices)
        return tops

    def replay(self) -> None:
        """Publish every journal read by :meth:`read`, one by one (see the module docstring)."""
        for job_id in list(self._unpublished):
            if self.stop.is_set():
                return
            self._publish(job_id, self._unpublished[job_id], first=True)
            with self._lock:
                del self._unpublished[job_id]

    def retry(self) -> bool:
        """Try once more to publish every held journal; True when none is held any more."""
        with self._lock:
            held = {job: [ev for ev in events if _index(ev) in self._open.get(job, {})]
                    for job, (events, _) in self._held.items()}
        for job_id, events in held.items():
            if self.stop.is_set():
                break
            self._publish(job_id, events, first=False)
        with self._lock:
            return not self._held

    def _publish(self, job_id: str, events: list[dict], *, first: bool) -> None:
        bad = {i: why for i, ev in enumerate(events) if (why := unpublishable(ev)) is not None}
        good = [ev for i, ev in enumerate(events) if i not in bad]
        if first:
            with self._lock:  # until the recorder holds them
                self._open.setdefault(job_id, {}).update((_index(ev), ev) for ev in good if _index(ev) is not None)
        if bad and first:  # the file as it was, for the operator; the events that can be published, published
            i, why = next(iter(bad.items()))
            self.store.state.quarantine(
                self.store.journal_path(job_id),
                f"{len(bad)} of its {len(events)} roll-out events cannot be published (event {i}: {why}); "
                f"the other {len(events) - len(bad)} were published")
            if good:  # journalled again: kept until the recorder holds them
                try:
                    self.store.save_journal(job_id, good)
                except StateWriteError as exc:
                    log.warning("job %s: %s; its %d publishable journalled events are kept in memory only",
                                job_id, exc, len(good))
        try:
            for ev in good:
                self.publish(ev)
        except Exception as exc:
            if self.stop.is_set():
                return
            why = f"{type(exc).__name__}: {exc}".splitlines()[0]
            with self._lock:
                self._held[job_id] = (good, why)
            log.warning("job %s: could not publish its %d journalled roll-out event(s) (%s); kept, tried again "
                        "every %g s", job_id, len(good), why, RETRY_S)
            return
        with self._lock:
            self._held.pop(job_id, None)
        log.info("job %s: published its %d journalled roll-out event(s) again", job_id, len(good))

    def save(self, job_id: str, events: list[dict]) -> None:
        """Write job ``job_id``'s journal: its roll-outs the recorder has not confirmed yet (held
        ones included), then ``events``, which join them; :class:`~services.learner.store.StateWriteError`
        when it cannot be written (nothing changes then)."""
        with self._lock:
            opened = self._open.get(job_id, {})
            kept = [opened[i] for i in sorted(opened)]
        over = len(kept) + len(events) - MAX_UNCONFIRMED
        if over > 0:
            log.warning("job %s: the recorder has not confirmed %d of its roll-outs; its journal keeps the newest "
                        "%d", job_id, len(kept), MAX_UNCONFIRMED)
            dropped, kept = kept[:over], kept[over:]
        else:
            dropped = []
        self.store.save_journal(job_id, kept + events)
        with self._lock:
            opened = self._open.setdefault(job_id, {})
            for ev in dropped:
                opened.pop(_index(ev), None)
            opened.update((_index(ev), ev) for ev in events if _index(ev) is not None)

    def pending(self) -> tuple[PendingJournal, ...]:
        """The held journals (publishing them failed), for the learner's health."""
        with self._lock:
            return tuple(PendingJournal(job, len(events), why) for job, (events, why) in sorted(self._held.items()))

    def unconfirmed(self) -> dict[str, int]:
        """``{job: n}``: the journalled roll-outs of each job the recorder has not confirmed yet."""
        with self._lock:
            return {job: len(opened) for job, opened in self._open.items() if opened}

    def settle(self, finished: Iterable[str], held: Callable[[list[str]], dict[str, IndexRanges]]) -> Settled:
        """Drop from the journals the roll-outs the recorder holds: ``held`` gets the ids of the jobs
        with journalled roll-outs (those not published again yet left out) and returns, per job it
        knows, the indices its files hold. A ``finished`` job's journal is removed once none of its
        roll-outs waits any more."""
        with self._lock:  # a journal read at the start and not published yet is not the recorder's to confirm
            candidates = sorted(set(self._open) - set(self._unpublished))
        if not candidates:
            return Settled()
        asked = [job for job in candidates if self._open.get(job)]
        holds = held(asked) if asked else {}
        done, removed, confirmed = set(finished), [], 0
        with self._lock:
            for job in candidates:
                opened = self._open.get(job, {})
                indices = holds.get(job)
                if indices is not None:
                    gone = [i for i in opened if i in indices]
                    for i in gone:
                        del opened[i]
                    confirmed += len(gone)
                if job in done and not opened and job not in self._held:
                    self._open.pop(job, None)
                    removed.append(job)
            waiting = tuple(job for job in candidates if self._open.get(job))
        for job in removed:
            self.store.drop_journal(job)
        return Settled(tuple(removed), confirmed, waiting)
