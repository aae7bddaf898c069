"""The roll-out journals of a learner's jobs, published again one by one at a start (issue 66).

A running job writes each batch's roll-out events to its journal (``jobs/<job>.rollouts``, with
the batch before) before their indices are reserved and before they are published
(services/learner/core.py), so a learner killed anywhere in between publishes them at its next
start. :class:`Journals` does that publishing, each journal on its own:

* a journal holding events that cannot be published (a return of -inf, a bad field: what
  :func:`services.recording.events.validate_event` and the wire refuse) is **quarantined** like
  any unusable state file (moved to ``quarantine/``, named in the learner's health, hence
  ``acnmp status`` exits 1), and its other events are published;
* a journal whose publishing fails for another reason (the session) is **held**: kept on disk,
  its events kept in memory and written into every later journal of its job (a job that runs
  again never overwrites them), tried again every :data:`RETRY_S` seconds, and named in the
  learner's health until published;
* one journal never keeps the others from being published.

A finished job's journal is removed once the recorder confirms it holds the job's roll-outs
(:meth:`Journals.settle`, called by the learner service), so a later session publishes no
fragment of an old job into a new recording; one whose confirmation never came (a learner killed
right after its job ended) is published again at the next start, to lose nothing (the recorder
keeps each roll-out once).
"""
from __future__ import annotations

import logging
import threading
from dataclasses import dataclass
from typing import Callable, Iterable

from services.recording.events import validate_event
from services.transport.wire import WireError, encode

from .store import JobStore

log = logging.getLogger(__name__)

#: Seconds between tries to publish a held journal.
RETRY_S = 5.0


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


class Journals:
    """The journals of a learner's jobs (see the module docstring).

    ``store`` holds them; ``publish(event)`` publishes one event; ``stop`` ends a replay early.
    Thread-safe: the replay, the job threads (:meth:`save`) and the service (:meth:`settle`) share it.
    """

    def __init__(self, store: JobStore, publish: Callable[[dict], None], stop: threading.Event):
        self.store, self.publish, self.stop = store, publish, stop
        self._unpublished: dict[str, list[dict]] = {}  # read at the start, not yet published
        self._held: dict[str, tuple[list[dict], str]] = {}  # job -> (events, why): publishing failed
        self._written: set[str] = set()  # jobs that wrote their journal since the start
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
            indices = [ev.get("rollout_index") for ev in events]
            indices = [i for i in indices if isinstance(i, int) and not isinstance(i, bool)]
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
            held = {job: events for job, (events, _) in self._held.items()}
        for job_id, events in held.items():
            if self.stop.is_set():
                break
            self._publish(job_id, events, first=False)
        with self._lock:
            return not self._held

    def _publish(self, job_id: str, events: list[dict], *, first: bool) -> None:
        bad = {i: why for i, ev in enumerate(events) if (why := unpublishable(ev)) is not None}
        if bad and first:  # the file as it was, for the operator; the events that can be published, published
            i, why = next(iter(bad.items()))
            self.store.state.quarantine(
                self.store.journal_path(job_id),
                f"{len(bad)} of its {len(events)} roll-out events cannot be published (event {i}: {why}); "
                f"the other {len(events) - len(bad)} were published")
        good = [ev for i, ev in enumerate(events) if i not in bad]
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
            rewritten = job_id in self._written
        if not bad and not rewritten:  # a journal its job wrote since holds that job's latest batch
            self.store.drop_journal(job_id)
        log.info("job %s: published its %d journalled roll-out event(s) again", job_id, len(good))

    def save(self, job_id: str, events: list[dict]) -> None:
        """Write job ``job_id``'s journal: its held events (if any), then ``events``;
        :class:`~services.learner.store.StateWriteError` when it cannot be written."""
        with self._lock:
            held = self._held.get(job_id, ([], ""))[0]
            self._written.add(job_id)
        self.store.save_journal(job_id, held + events)

    def pending(self) -> tuple[PendingJournal, ...]:
        """The held journals (publishing them failed), for the learner's health."""
        with self._lock:
            return tuple(PendingJournal(job, len(events), why) for job, (events, why) in sorted(self._held.items()))

    def settle(self, finished: Iterable[str], recorded: Callable[[list[str]], set[str]]) -> tuple[list[str], list[str]]:
        """Remove the journals of the ``finished`` jobs that ``recorded`` (given the job ids that
        have a journal, held ones and those not yet published again left out) says the recorder
        holds every published roll-out of;
        returns ``(removed, kept)``: the ids removed and those left for a later look."""
        with self._lock:  # a journal read at the start and not published yet is not the recorder's to confirm
            held = set(self._held) | set(self._unpublished)
        candidates = sorted(set(finished) & set(self.store.journals()) - held)
        if not candidates:
            return [], []
        done = sorted(set(recorded(candidates)) & set(candidates))
        for job_id in done:
            self.store.drop_journal(job_id)
        return done, [j for j in candidates if j not in done]
