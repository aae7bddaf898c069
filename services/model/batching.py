"""Dynamic batching: concurrent predicts of one skill model computed in one forward pass.

Handler threads check each predict (parse, cost, network inputs) and :meth:`PredictBatcher.submit`
it; one batcher thread takes the oldest waiting predict and every other one waiting for the same
model (the same :class:`SkillModel` entry, so one version), optionally waiting up to a collection
window for more, runs them through :meth:`acnmp_core.cnmp.CNMP.predict_queries` and completes each
predict's future with its own reply. Nothing here imports zenoh: the futures are answered by
services/transport/rpc.py.

Why one thread: the forward passes are what is shared; torch runs each on one core
(``torch.set_num_threads(1)``), leaving the other to decoding, encoding and zenoh. The replies of a
pass are built and sent on a second thread, so that the next pass (whose torch kernels release the
GIL) overlaps with the Python work of encoding the last one.
"""
from __future__ import annotations

import collections
import logging
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

from acnmp_core.cnmp import Query
from services.transport.rpc import Expired
from services.transport.wire import WireError

from .handlers import PredictItem, SkillModel, pin_threads, predict_reply

log = logging.getLogger(__name__)

#: Predicts of one skill run in one forward pass at most (the service's ``--batch-max`` default).
DEFAULT_BATCH_MAX = 16
#: Observation plus query points (N + T) of one pass at most, beyond which a pass is split: the
#: decoder's activations of a larger pass (3200 rows of 128 floats) fall out of the cache and cost
#: more per row than several passes (measured: 0.17 ms per 200 rows up to 1600 rows, 0.47 ms at 3200).
#: A single predict larger than this runs alone.
PASS_POINTS = 2048
#: Seconds the batcher waits for more predicts once it has one (``--batch-window``, default 0:
#: it takes what is waiting, so a lone predict is never delayed; see benchmarks/bench_predict.py).
DEFAULT_BATCH_WINDOW = 0.0


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
    window : seconds to wait for more predicts after the first of a pass (0: only those waiting).
    max_pending : predicts waiting at most; :meth:`submit` raises WireError ``overloaded`` beyond.
    max_points : observation plus query points (N + T) of one pass at most (:data:`PASS_POINTS`);
        a predict larger than that runs alone, so a pass never costs more than the largest single
        query may (:data:`services.model.handlers.MAX_BATCH_POINTS`).
    """

    def __init__(self, max_items: int = DEFAULT_BATCH_MAX, window: float = DEFAULT_BATCH_WINDOW, *,
                 max_pending: int = 64, max_points: int = PASS_POINTS):
        if max_items < 1:
            raise ValueError(f"max_items: expected >= 1, got {max_items}")
        if not window >= 0:
            raise ValueError(f"window: expected >= 0 seconds, got {window}")
        self.max_items, self.window, self.max_pending, self.max_points = max_items, window, max_pending, max_points
        self._cond = threading.Condition()
        self._jobs: collections.deque[_Job] = collections.deque()
        self._stopping = False
        self.passes = 0      # forward passes run
        self.computed = 0    # predicts computed in them
        self.largest = 0     # most predicts in one pass
        self.expired = 0     # dropped uncomputed: their deadline had passed
        self._replier = ThreadPoolExecutor(1, thread_name_prefix="model-replies")
        self._thread = threading.Thread(target=self._run, name="model-batcher", daemon=True)
        self._thread.start()

    def submit(self, entry: SkillModel, item: PredictItem, query: Query, deadline: float | None) -> Future:
        """Queue one checked predict (``query`` its network inputs from
        :func:`services.model.handlers.item_query`); returns a future of its reply map, failed with
        :class:`Expired` if ``deadline`` (``time.monotonic()`` seconds) passes before it is computed.
        Raises WireError ``overloaded`` when ``max_pending`` predicts are waiting, ``unavailable``
        once closing."""
        job = _Job(entry, item, query, deadline, Future())
        with self._cond:
            if self._stopping:
                raise WireError("unavailable", "the model service is shutting down")
            if len(self._jobs) >= self.max_pending:
                raise WireError("overloaded", f"{self.max_pending} predicts are already waiting; try again later")
            self._jobs.append(job)
            self._cond.notify()
        return job.future

    def _take(self) -> list[_Job]:
        """The next pass: the oldest job and the waiting jobs of the same entry, within the bounds."""
        with self._cond:
            while not self._jobs and not self._stopping:
                self._cond.wait()
            if not self._jobs:
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
                if len(batch) >= self.max_items or left <= 0 or self._stopping:
                    break
                self._cond.wait(left)
            return batch

    def _run(self) -> None:
        pin_threads()
        while True:
            batch = self._take()
            if not batch:
                return
            now = time.monotonic()
            live = []
            for job in batch:
                if job.deadline is not None and now > job.deadline:
                    self.expired += 1
                    job.future.set_exception(Expired())  # its querier has given up: not computed
                else:
                    live.append(job)
            if live:
                self._compute(live)

    def _compute(self, jobs: list[_Job]) -> None:
        entry = jobs[0].entry
        try:
            preds = entry.model.predict_queries([job.query for job in jobs])
        except Exception as exc:  # never kill the batcher: every predict of the pass gets the error
            log.exception("batched forward pass of %d predicts failed", len(jobs))
            for job in jobs:
                job.future.set_exception(exc)
            return
        self.passes += 1
        self.computed += len(jobs)
        self.largest = max(self.largest, len(jobs))
        self._replier.submit(self._reply, entry, jobs, preds)

    @staticmethod
    def _reply(entry: SkillModel, jobs: list[_Job], preds: list) -> None:
        for job, pred in zip(jobs, preds):
            try:
                reply = predict_reply(entry, job.item, pred)
            except Exception as exc:
                job.future.set_exception(exc)
            else:
                job.future.set_result(reply)  # runs the future's callbacks (the zenoh reply) here

    def close(self) -> None:
        """Compute what is waiting, then stop the batcher thread (submit refuses from now on)."""
        with self._cond:
            self._stopping = True
            self._cond.notify_all()
        self._thread.join(timeout=10.0)
        self._replier.shutdown(wait=True)
