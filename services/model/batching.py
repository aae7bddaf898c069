"""Dynamic batching: concurrent predicts of one skill model computed in one forward pass.

Handler threads check each predict (parse, cost, network inputs) and :meth:`PredictBatcher.submit`
it. There is no batcher thread: a handler thread that submits while fewer than ``max_passes``
passes are running becomes a pass's leader. It takes the oldest waiting predict and every other one
waiting for the same model (the same :class:`SkillModel` entry, so one version), optionally waits
up to a collection window for more, runs them through
:meth:`acnmp_core.cnmp.CNMP.predict_queries`, completes each predict's future with its own reply
(which sends it, services/transport/rpc.py), and goes on with what arrived meanwhile until nothing
waits. A predict submitted while the passes are all running waits for one of them: it is batched
with the others that arrive during that pass.

Why leaders rather than a batcher thread: a lone predict is computed and answered on the thread
that received it, with no hand-over between threads (each costs a wake-up and the GIL), so
batching costs a single client nothing. Nothing here imports zenoh.
"""
from __future__ import annotations

import collections
import logging
import threading
import time
from concurrent.futures import Future
from dataclasses import dataclass

from acnmp_core.cnmp import Query
from services.transport.rpc import Expired
from services.transport.wire import WireError

from .handlers import PredictItem, SkillModel, pin_threads, predict_reply

log = logging.getLogger(__name__)

#: Predicts of one skill run in one forward pass at most (the service's ``--batch-max`` default).
DEFAULT_BATCH_MAX = 16
#: Seconds a leader waits for more predicts once it has one (``--batch-window``, default 0: it takes
#: what is waiting, so a lone predict is never delayed; see benchmarks/bench_predict.py).
DEFAULT_BATCH_WINDOW = 0.0
#: Observation plus query points (N + T) of one pass at most, beyond which a pass is split: the
#: decoder's activations of a much larger pass fall out of the cache and cost more per row than
#: several passes. A single predict larger than this runs alone.
PASS_POINTS = 2048


@dataclass
class _Job:
    entry: SkillModel
    item: PredictItem
    query: Query
    deadline: float | None
    future: Future

    @property
    def points(self) -> int:
        return self.item.n_obs + self.item.n_query


class PredictBatcher:
    """Collects checked predicts and runs those of one model together; see the module docstring.

    Parameters
    ----------
    max_items : predicts in one forward pass at most (1: each alone, in arrival order).
    window : seconds a leader waits for more predicts after the first of a pass (0: only those waiting).
    max_pending : predicts waiting at most; :meth:`submit` raises WireError ``overloaded`` beyond.
    max_points : observation plus query points (N + T) of one pass at most (:data:`PASS_POINTS`);
        a predict larger than that runs alone, so a pass never costs more than the largest single
        query may (:data:`services.model.handlers.MAX_BATCH_POINTS`).
    max_passes : passes running at once at most (each on its leader's thread). With 1, and more
        handler threads than that, the other threads keep decoding and checking while a pass runs.
    """

    def __init__(self, max_items: int = DEFAULT_BATCH_MAX, window: float = DEFAULT_BATCH_WINDOW, *,
                 max_pending: int = 64, max_points: int = PASS_POINTS, max_passes: int = 1):
        if max_items < 1:
            raise ValueError(f"max_items: expected >= 1, got {max_items}")
        if not window >= 0:
            raise ValueError(f"window: expected >= 0 seconds, got {window}")
        if max_passes < 1:
            raise ValueError(f"max_passes: expected >= 1, got {max_passes}")
        self.max_items, self.window, self.max_pending = max_items, window, max_pending
        self.max_points, self.max_passes = max_points, max_passes
        self._cond = threading.Condition()
        self._jobs: collections.deque[_Job] = collections.deque()
        self._running = 0    # leaders at work
        self._closed = False
        self.passes = 0      # forward passes run
        self.computed = 0    # predicts computed in them
        self.largest = 0     # most predicts in one pass
        self.expired = 0     # dropped uncomputed: their deadline had passed

    def submit(self, entry: SkillModel, item: PredictItem, query: Query, deadline: float | None) -> Future:
        """Queue one checked predict (``query`` its network inputs from
        :func:`services.model.handlers.item_query`) and, if a pass may start, lead passes on this
        thread until nothing waits. Returns a future of its reply map (already done when this
        thread computed it), failed with :class:`Expired` if ``deadline`` (``time.monotonic()``
        seconds) passes before it is computed. Raises WireError ``overloaded`` when
        ``max_pending`` predicts are waiting, ``unavailable`` once closed."""
        job = _Job(entry, item, query, deadline, Future())
        with self._cond:
            if self._closed:
                raise WireError("unavailable", "the model service is shutting down")
            if len(self._jobs) >= self.max_pending:
                raise WireError("overloaded", f"{self.max_pending} predicts are already waiting; try again later")
            self._jobs.append(job)
            if self._running >= self.max_passes:
                self._cond.notify_all()  # a leader collecting within its window takes it
                return job.future
            self._running += 1
        pin_threads()
        while True:
            batch = self._take()
            if not batch:
                return job.future
            self._run_pass(batch)

    def _take(self) -> list[_Job]:
        """The next pass: the oldest job and the waiting jobs of the same entry, within the bounds;
        [] (and this leader retires) when nothing waits."""
        with self._cond:
            if not self._jobs:
                self._running -= 1
                self._cond.notify_all()  # close() waits for the leaders
                return []
            first = self._jobs.popleft()
            batch, points = [first], first.points
            end = time.monotonic() + self.window
            while len(batch) < self.max_items:
                for job in list(self._jobs):
                    if len(batch) >= self.max_items:
                        break
                    if job.entry is first.entry and points + job.points <= self.max_points:
                        self._jobs.remove(job)
                        batch.append(job)
                        points += job.points
                left = end - time.monotonic()
                if len(batch) >= self.max_items or left <= 0 or self._closed:
                    break
                self._cond.wait(left)
            return batch

    def _run_pass(self, batch: list[_Job]) -> None:
        now = time.monotonic()
        live = []
        for job in batch:
            if job.deadline is not None and now > job.deadline:
                self.expired += 1
                job.future.set_exception(Expired())  # its querier has given up: not computed
            else:
                live.append(job)
        if not live:
            return
        entry = live[0].entry
        try:
            preds = entry.model.predict_queries([job.query for job in live])
        except Exception as exc:  # every predict of the pass gets the error; the leader goes on
            log.exception("batched forward pass of %d predicts failed", len(live))
            for job in live:
                job.future.set_exception(exc)
            return
        with self._cond:
            self.passes += 1
            self.computed += len(live)
            self.largest = max(self.largest, len(live))
        for job, pred in zip(live, preds):
            try:
                reply = predict_reply(entry, job.item, pred)
            except Exception as exc:
                job.future.set_exception(exc)
            else:
                job.future.set_result(reply)  # runs the future's callbacks (the zenoh reply) here

    def close(self) -> None:
        """Refuse new predicts, and wait (up to 10 s) for the leaders to compute what is waiting."""
        deadline = time.monotonic() + 10.0
        with self._cond:
            self._closed = True
            self._cond.notify_all()
            while self._running and time.monotonic() < deadline:
                self._cond.wait(0.1)
