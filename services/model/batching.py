"""Dynamic batching: concurrent predicts of one skill model computed in one forward pass.

The zenoh callback that receives a predict query does nothing but :meth:`PredictBatcher.submit` it
with a *preparation*: a callable that decodes and checks the request
(:func:`services.model.handlers.prepare_predict`). The batcher's own threads (``threads``, default
1) each take every predict waiting (up to ``max_items``, after an optional collection window),
prepare them, and run those of one model (the same :class:`SkillModel` entry, so one version)
through :meth:`acnmp_core.model.cnmp.CNMP.predict_queries` in one pass; each predict's future is
completed with its own reply, which sends it (services/transport/rpc.py).

Why the preparation runs here rather than on the receiving thread: a batch can only hold what is
waiting *here*. When handler threads decoded and checked each query first, the queries waited in
their pool's queue instead, undecoded, and a pass held two predicts on average whatever the load
(benchmarks/results/bench_predict.json). A request that fails its checks fails only its own future.
Nothing here imports zenoh.
"""
from __future__ import annotations

import collections
import logging
import threading
import time
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Callable

from services.transport.rpc import Expired
from services.transport.wire import WireError

from .config import DEFAULT_BATCH_MAX, DEFAULT_BATCH_WINDOW
from .handlers import PreparedPredict, pin_threads, predict_reply

log = logging.getLogger(__name__)

#: Observation plus query points (N + T) of one pass at most, beyond which a pass is split: the
#: decoder's activations of a much larger pass fall out of the cache and cost more per row than
#: several passes. A single predict larger than this runs alone.
PASS_POINTS = 2048

#: What a preparation returns: a checked single predict, or the finished reply of a request that
#: needs no pass (an explicit ``{"batch": [...]}`` request, answered item by item).
Preparation = Callable[[], "PreparedPredict | dict"]


@dataclass
class _Job:
    prepare: Preparation
    deadline: float | None
    future: Future


def _fail(job: _Job, exc: BaseException) -> None:
    """Fail ``job``'s future with ``exc`` (which answers its query), then drop the tracebacks of
    ``exc`` and of the exceptions it chains: their frames hold the round's jobs, whose futures
    hold ``exc`` again (a cycle that only the garbage collector frees, seldom in an idle
    service), and the refused request's payload, up to 16 MiB each: 100 refused predicts held
    2.5-2.8x the service's idle memory for good (issue 73)."""
    job.future.set_exception(exc)
    seen = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        exc.__traceback__ = None
        exc = exc.__cause__ or exc.__context__


def _fail_unanswered(jobs: list[_Job], exc: BaseException) -> None:
    """:func:`_fail` each of ``jobs`` not answered yet with ``exc``."""
    for job in jobs:
        if not job.future.done():
            _fail(job, exc)


class PredictBatcher:
    """Prepares and computes predicts on its own threads, those of one model together; see the
    module docstring. Use as a context manager or call :meth:`close`.

    Parameters
    ----------
    max_items : predicts taken in one round at most (1: each alone, in arrival order).
    window : seconds a thread waits for more predicts after the first of a round (0: only those waiting).
    max_pending : predicts waiting at most; :meth:`submit` raises WireError ``overloaded`` beyond.
    max_points : observation plus query points (N + T) of one pass at most (:data:`PASS_POINTS`);
        a predict larger than that runs alone, so a pass never costs more than the largest single
        query may (:data:`services.model.handlers.MAX_BATCH_POINTS`).
    threads : threads preparing and computing. With 2, one prepares the next round while the
        other's forward pass (which releases the GIL) runs.
    """

    def __init__(self, max_items: int = DEFAULT_BATCH_MAX, window: float = DEFAULT_BATCH_WINDOW, *,
                 max_pending: int = 64, max_points: int = PASS_POINTS, threads: int = 1):
        if max_items < 1:
            raise ValueError(f"max_items: expected >= 1, got {max_items}")
        if not window >= 0:
            raise ValueError(f"window: expected >= 0 seconds, got {window}")
        if threads < 1:
            raise ValueError(f"threads: expected >= 1, got {threads}")
        self.max_items, self.window, self.max_pending = max_items, window, max_pending
        self.max_points, self.threads = max_points, threads
        self._cond = threading.Condition()
        self._jobs: collections.deque[_Job] = collections.deque()
        self._closed = False
        self.passes = 0      # forward passes run
        self.computed = 0    # predicts computed in them
        self.largest = 0     # most predicts in one pass
        self.expired = 0     # dropped uncomputed: their deadline had passed
        self._threads = [threading.Thread(target=self._work, name=f"predict-batch-{i}", daemon=True)
                         for i in range(threads)]
        for t in self._threads:
            t.start()

    def submit(self, prepare: Preparation, deadline: float | None = None) -> Future:
        """Queue one predict: ``prepare()`` (run later on a batcher thread) checks it and returns a
        :class:`PreparedPredict`, or a finished reply map, or raises (the future fails with that
        error). Returns a future of its reply map, failed with :class:`Expired` if ``deadline``
        (``time.monotonic()`` seconds) passes before it is computed. Cheap enough for a zenoh
        callback. Raises WireError ``overloaded`` when ``max_pending`` predicts are waiting,
        ``unavailable`` once closed."""
        job = _Job(prepare, deadline, Future())
        with self._cond:
            if self._closed:
                raise WireError("unavailable", "the model service is shutting down")
            if len(self._jobs) >= self.max_pending:
                raise WireError("overloaded", f"{self.max_pending} predicts are already waiting; try again later")
            self._jobs.append(job)
            self._cond.notify()
        return job.future

    def _take(self) -> list[_Job]:
        """The next round: the oldest jobs, up to ``max_items``, after the window; [] once closed
        and drained (the thread then ends)."""
        with self._cond:
            while not self._jobs:
                if self._closed:
                    return []
                self._cond.wait()
            end = time.monotonic() + self.window
            while len(self._jobs) < self.max_items and not self._closed:
                left = end - time.monotonic()
                if left <= 0:
                    break
                self._cond.wait(left)
            return [self._jobs.popleft() for _ in range(min(self.max_items, len(self._jobs)))]

    def _work(self) -> None:
        pin_threads()
        while True:
            jobs = self._take()
            if not jobs:
                return
            try:
                self._round(jobs)
            except Exception:  # never lose the thread: every future of the round gets an answer
                log.exception("predict round of %d failed", len(jobs))
                _fail_unanswered(jobs, WireError("internal", "the predict round failed"))
            # answered: their queries (and payloads) are not kept while this thread waits for the next
            del jobs

    def _round(self, jobs: list[_Job]) -> None:
        """Prepare ``jobs``, then compute the prepared ones in passes of one model each, the passes
        with the fewest points first (arrival order among equals)."""
        groups: dict[int, list[tuple[_Job, PreparedPredict]]] = {}
        for job in jobs:
            if self._expired(job):
                continue
            try:
                prepared = job.prepare()
            except Exception as exc:  # a bad request fails alone
                _fail(job, exc)
                continue
            if isinstance(prepared, dict):
                job.future.set_result(prepared)
            else:
                groups.setdefault(id(prepared.entry), []).append((job, prepared))
        passes = []
        for group in groups.values():
            batch, points = [], 0
            # small ones packed together, however they interleave with large ones (sorted is stable)
            for job, prepared in sorted(group, key=lambda jp: jp[1].points):
                if batch and points + prepared.points > self.max_points:
                    passes.append((points, batch))
                    batch, points = [], 0
                batch.append((job, prepared))
                points += prepared.points
            passes.append((points, batch))
        # cheapest first: a light predict taken with heavy ones waits for none of them
        for _, batch in sorted(passes, key=lambda p: p[0]):
            self._run_pass(batch)

    def _expired(self, job: _Job) -> bool:
        if job.deadline is not None and time.monotonic() > job.deadline:
            with self._cond:
                self.expired += 1
            _fail(job, Expired())  # its querier has given up: not computed
            return True
        return False

    def _run_pass(self, batch: list[tuple[_Job, PreparedPredict]]) -> None:
        live = [(job, p) for job, p in batch if not self._expired(job)]
        if not live:
            return
        entry = live[0][1].entry
        try:
            preds = entry.model.predict_queries([p.query for _, p in live])
        except Exception as exc:  # every predict of the pass gets the error; the thread goes on
            log.exception("batched forward pass of %d predicts failed", len(live))
            for job, _ in live:
                _fail(job, exc)
            return
        with self._cond:
            self.passes += 1
            self.computed += len(live)
            self.largest = max(self.largest, len(live))
        for (job, prepared), pred in zip(live, preds):
            try:
                reply = predict_reply(entry, prepared.item, pred)
            except Exception as exc:
                _fail(job, exc)
            else:
                job.future.set_result(reply)  # runs the future's callbacks (the zenoh reply) here

    def close(self) -> None:
        """Refuse new predicts, and wait (up to 10 s) for the threads to compute what is waiting."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        deadline = time.monotonic() + 10.0
        for t in self._threads:
            t.join(timeout=max(0.0, deadline - time.monotonic()))

    def __enter__(self) -> "PredictBatcher":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
