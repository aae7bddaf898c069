"""Workers excluded for what they did: within a job for good, across the learner's jobs for a while.

A worker that answers with numbers no task reports (NaN, inf, a reward of -1e308), with arrays of
the wrong shape, with a reply for another chunk, that keeps failing or that answers far slower
than its peers is excluded from the job that saw it (services/worker/remote.py), named in the
job's status and events, and its roll-outs re-sent to healthy workers. The learner's other jobs
avoid it for :data:`EXCLUDE_S` seconds as well (:class:`WorkerExclusions`, shared by the
evaluators of one learner) while another worker of its kind is live; a worker the registry
excludes but no job of its own has seen fail is still tried when it is the only one left, so a
one-worker deployment is not stopped by one bad minute.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Any

#: Seconds the learner's other jobs avoid an excluded worker (while another worker is live).
EXCLUDE_S = 120.0


@dataclass(frozen=True)
class Exclusion:
    """Worker ``worker`` excluded, and why (one line: what it answered, for which roll-outs), by
    ``attempt`` of its job (the learner stamps it: an evaluator runs one attempt; a worker going
    down with a launcher that died is that attempt's, not the resumed one's)."""

    worker: str
    reason: str
    attempt: int = 0

    def line(self) -> str:
        """``<worker>: <reason>``, for a log, an error message and an event."""
        return f"{self.worker}: {self.reason}"

    def to_dict(self) -> dict[str, Any]:
        """The map a job status and a job record carry: ``{"worker", "reason", "attempt"}``."""
        return {"worker": self.worker, "reason": self.reason, "attempt": self.attempt}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "Exclusion":
        """Inverse of :meth:`to_dict` (a map without ``attempt``, written before it existed, is of
        attempt 0); TypeError/KeyError for another map."""
        worker, reason, attempt = d["worker"], d["reason"], d.get("attempt", 0)
        if not isinstance(worker, str) or not isinstance(reason, str):
            raise TypeError(f"an exclusion needs strings 'worker' and 'reason', got {d!r}")
        if isinstance(attempt, bool) or not isinstance(attempt, int) or attempt < 0:
            raise TypeError(f"an exclusion's 'attempt' must be an integer >= 0, got {attempt!r}")
        return cls(worker, reason, attempt)


class WorkerExclusions:
    """The workers the learner's jobs excluded lately: ``exclude`` records one for ``exclude_for``
    seconds (default :data:`EXCLUDE_S`), ``excluded()`` names the ones still avoided. Thread-safe."""

    def __init__(self, exclude_for: float = EXCLUDE_S):
        self.exclude_for = float(exclude_for)
        self._until: dict[str, tuple[float, Exclusion]] = {}
        self._lock = threading.Lock()

    def exclude(self, exclusion: Exclusion) -> None:
        """Avoid ``exclusion.worker`` for ``exclude_for`` seconds from now."""
        with self._lock:
            self._until[exclusion.worker] = (time.monotonic() + self.exclude_for, exclusion)

    def excluded(self) -> dict[str, Exclusion]:
        """The workers avoided now, by id."""
        now = time.monotonic()
        with self._lock:
            for worker in [w for w, (until, _) in self._until.items() if until <= now]:
                del self._until[worker]
            return {w: exclusion for w, (_, exclusion) in self._until.items()}
