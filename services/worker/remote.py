"""RemoteEvaluator: a RolloutEvaluator that spreads a batch over the live workers of one robot kind.

How a batch of B roll-outs is run:

1. the live workers are the liveliness tokens ``acnmp/<ns>/worker/<robot>/*`` (waiting up to
   ``discover_timeout`` for the first one);
2. the batch is cut into contiguous chunks, one per worker (``np.array_split`` sizes), and every
   chunk is queried concurrently on ``.../<id>/rollout``. When a batch has fewer roll-outs than
   there are workers, the workers it goes to take turns (round robin from a random start per
   evaluator), so many jobs with small batches spread over a large pool instead of all landing on
   the first workers by name;
3. a liveliness subscriber watches the workers while chunks are in flight: when a worker's token
   goes (it died, e.g. ``kill -9``) or its query fails with ``timeout``/``unavailable``/``internal``,
   its chunk is cut again over the workers still live and re-sent;
4. results are written into their slots by index: each roll-out is taken from exactly one reply,
   so the returned batch is in order and every roll-out counts once. A reply that arrives for an
   abandoned chunk is discarded.

The returned batch is an :class:`~services.worker.core.ExecutedBatch`: its ``workers`` name the
worker that executed each roll-out. Client errors (``bad_request``, ``bad_shape``,
``unknown_task``, ...) are not retried: they raise ValueError, as an in-process evaluator would. No
live worker for ``discover_timeout`` raises RuntimeError.
"""
from __future__ import annotations

import contextlib
import logging
import random
import threading
import time
from dataclasses import dataclass

import numpy as np
import zenoh

from acnmp_core.rollout import RolloutBatch
from acnmp_core.tasks.registry import task_credit, task_names
from services.transport import Keyspace, WireError, alive_tokens, call
from services.transport.keys import check_name, token_id

from .core import ExecutedBatch, batch_from_reply, rollout_request, take

log = logging.getLogger(__name__)

#: Error codes after which a chunk is re-sent to another worker (the worker, not the request, failed).
RETRY_CODES = ("timeout", "unavailable", "internal")


@dataclass
class _Chunk:
    start: int
    stop: int
    worker: str
    attempt: int  # generation: a late reply of an abandoned attempt is ignored


class RemoteEvaluator:
    """Evaluate trajectories on remote workers; implements :class:`acnmp_core.rollout.RolloutEvaluator`.

    Parameters
    ----------
    session : an open zenoh session (not closed here).
    keys : the deployment's :class:`Keyspace` (or its namespace name).
    robot : whose workers to use (``acnmp/<ns>/worker/<robot>/*``).
    task, task_config : the registry task the workers run and its parameters.
    timeout : seconds one chunk may take before it goes to another worker.
    discover_timeout : seconds to wait for a live worker when there is none.
    max_attempts : chunk re-sends per batch before giving up (RuntimeError).
    stop : when set (the learner shutting down), a batch in flight is abandoned at once with
        InterruptedError instead of waiting for its replies.
    """

    def __init__(self, session: zenoh.Session, keys: Keyspace | str, robot: str, task: str,
                 task_config: dict | None = None, *, timeout: float = 60.0, discover_timeout: float = 10.0,
                 max_attempts: int = 20, stop: threading.Event | None = None):
        self.session = session
        self.keys = keys if isinstance(keys, Keyspace) else Keyspace(keys)
        self.robot = check_name("robot", robot)
        self.task = task
        #: the task's credit for adapt() (the registry's; "step" for a task this process does not know)
        self.credit = task_credit(task) if task in task_names() else "step"
        self.task_config = dict(task_config or {})
        self.timeout = float(timeout)
        self.discover_timeout = float(discover_timeout)
        self.max_attempts = int(max_attempts)
        self.stop = stop
        self._pattern = self.keys.worker_token(self.robot)
        self.ignored_tokens = 0  # liveliness tokens that named no worker (wildcards, bad ids)
        self._turn = random.randrange(1 << 30)  # which worker a batch starts on (round robin)

    def workers(self) -> list[str]:
        """Ids of the workers of this robot kind alive now (one liveliness query)."""
        ids = [token_id(k, self._pattern) for k in alive_tokens(self.session, self._pattern)]
        return [i for i in ids if i is not None]

    def _check_stop(self) -> None:
        if self.stop is not None and self.stop.is_set():
            raise InterruptedError("stopping: roll-out batch abandoned")

    def _wait_for(self, cond: threading.Condition, predicate, timeout: float) -> bool:
        """``cond.wait_for(predicate, timeout)`` (caller holds ``cond``), but raising InterruptedError
        within 0.1 s of ``stop`` being set: waiting for workers that a shutdown stopped would hold
        the learner for the whole ``discover_timeout``."""
        if self.stop is None:
            return cond.wait_for(predicate, timeout=timeout)
        end = time.monotonic() + timeout
        while True:
            if cond.wait_for(predicate, timeout=max(0.0, min(0.1, end - time.monotonic()))):
                return True
            self._check_stop()
            if time.monotonic() >= end:
                return False

    def evaluate(self, trajectories, times, task_params=None) -> ExecutedBatch:
        """trajectories (B, T, D), times (T,), task_params (P,) or None -> the B roll-outs in order,
        with the worker that executed each (``batch.workers``)."""
        trajs = np.asarray(trajectories, dtype=np.float64)
        if trajs.ndim != 3 or trajs.shape[0] < 1:
            raise ValueError(f"trajectories: expected shape (B, T, D) with B >= 1, got {trajs.shape}")
        times = np.asarray(times, dtype=np.float64)
        tp = None if task_params is None else np.asarray(task_params, dtype=np.float64).reshape(-1)
        b = trajs.shape[0]
        results: list[RolloutBatch | None] = [None] * b  # one slot per roll-out
        done_by: list[str] = [""] * b
        host_of: list[str] = [""] * b
        cond = threading.Condition()
        live: set[str] = set()
        dead: set[str] = set()
        inflight: dict[int, _Chunk] = {}  # chunk attempt id -> chunk
        failed: list[tuple[_Chunk, str]] = []
        fatal: list[BaseException] = []
        counter = [0]

        def on_token(sample: zenoh.Sample) -> None:
            wid = token_id(sample.key_expr, self._pattern)
            if wid is None:  # a wildcard or malformed token is nobody's: ignored, never a worker id
                self.ignored_tokens += 1
                return
            with cond:
                if sample.kind == zenoh.SampleKind.PUT:
                    live.add(wid)
                    dead.discard(wid)
                else:
                    live.discard(wid)
                    dead.add(wid)
                cond.notify_all()

        def run_chunk(chunk: _Chunk) -> None:
            req = rollout_request(self.task, self.task_config, trajs[chunk.start:chunk.stop], times, tp)
            key = self.keys.worker_rollout(self.robot, chunk.worker)
            try:
                reply = call(self.session, key, req, timeout=self.timeout)
                batch = batch_from_reply(reply)
                if len(batch) != chunk.stop - chunk.start:
                    raise WireError("internal", f"worker {chunk.worker} returned {len(batch)} roll-outs "
                                                f"for {chunk.stop - chunk.start}")
            except WireError as exc:
                with cond:
                    if inflight.pop(chunk.attempt, None) is not None:
                        if exc.code in RETRY_CODES:
                            failed.append((chunk, f"{exc.code}: {exc.message}"))
                        else:
                            fatal.append(ValueError(f"worker {chunk.worker}: {exc.code}: {exc.message}"))
                    cond.notify_all()
                return
            except Exception as exc:  # a malformed reply; the session closing
                with cond:
                    if inflight.pop(chunk.attempt, None) is not None:
                        failed.append((chunk, f"{type(exc).__name__}: {exc}"))
                    cond.notify_all()
                return
            with cond:
                if inflight.pop(chunk.attempt, None) is None:
                    return  # abandoned (its worker was declared dead): the chunk ran elsewhere
                for i in range(chunk.start, chunk.stop):
                    results[i] = take(batch, i - chunk.start, i - chunk.start + 1)
                    done_by[i] = chunk.worker
                    host_of[i] = str(reply.get("host") or "")
                cond.notify_all()

        def dispatch(start: int, stop: int, avoid: set[str]) -> None:
            # cut [start, stop) over the live workers not in `avoid`; caller holds `cond`
            candidates = sorted(live - avoid)
            if not candidates:
                candidates = sorted(live)  # the only workers left: let them try again
            if not candidates:
                raise RuntimeError(f"no live {self.robot} worker in namespace {self.keys.namespace}")
            n = min(len(candidates), stop - start)
            first, self._turn = self._turn % len(candidates), self._turn + n
            for idx, part in enumerate(np.array_split(np.arange(start, stop), n)):
                counter[0] += 1
                worker = candidates[(first + idx) % len(candidates)]
                chunk = _Chunk(int(part[0]), int(part[-1]) + 1, worker, counter[0])
                inflight[chunk.attempt] = chunk
                threading.Thread(target=run_chunk, args=(chunk,), daemon=True,
                                 name=f"rollout-{chunk.worker}").start()

        sub = self.session.liveliness().declare_subscriber(self._pattern, on_token, history=True)
        try:
            deadline = time.monotonic() + self.discover_timeout
            # the subscriber's history arrives asynchronously, token by token: a liveliness query
            # gives the complete list now, so the first batch is spread over every worker
            now = set(self.workers())
            with cond:
                live |= now - dead
                if not self._wait_for(cond, lambda: bool(live), self.discover_timeout):
                    raise RuntimeError(f"no live {self.robot} worker in namespace {self.keys.namespace} "
                                       f"after {self.discover_timeout}s")
                dispatch(0, b, set())
                resends = 0
                while True:
                    if fatal:
                        raise fatal[0]
                    self._check_stop()
                    # chunks on a worker that died: abandon and re-send
                    for att, chunk in list(inflight.items()):
                        if chunk.worker in dead:
                            inflight.pop(att)
                            failed.append((chunk, "worker disappeared"))
                    if failed:
                        redo, failed[:] = list(failed), []
                        for chunk, why in redo:
                            resends += 1
                            if resends > self.max_attempts:
                                raise RuntimeError(f"roll-outs {chunk.start}..{chunk.stop - 1} failed "
                                                   f"{resends} times; last: {why}")
                            log.warning("worker %s failed (%s): re-sending roll-outs %d..%d",
                                        chunk.worker, why, chunk.start, chunk.stop - 1)
                            if not live - {chunk.worker}:
                                # nobody else: wait a little for a worker to (re)appear
                                self._wait_for(cond, lambda: bool(live - {chunk.worker}), self.discover_timeout)
                            dispatch(chunk.start, chunk.stop, {chunk.worker})
                    if not inflight and not failed:
                        break
                    cond.wait(timeout=0.5 if self.stop is None else 0.1)  # a stop is seen within 0.1 s
                    if time.monotonic() > deadline + self.timeout * (self.max_attempts + 1):
                        raise RuntimeError("roll-out batch did not complete")
        finally:
            with contextlib.suppress(Exception):
                sub.undeclare()
        missing = [i for i, r in enumerate(results) if r is None]
        if missing:  # cannot happen when the loop above ends normally; guard the invariant
            raise RuntimeError(f"roll-outs {missing} have no result")
        return ExecutedBatch.of(RolloutBatch.concat(results), done_by, host_of)
