"""RemoteEvaluator: a RolloutEvaluator that spreads a batch over the live workers of one robot kind.

How a batch of B roll-outs is run:

1. the live workers are the liveliness tokens ``acnmp/<ns>/worker/<robot>/*`` (waiting up to
   ``discover_timeout`` for the first one), less the workers excluded (below);
2. the batch is cut into contiguous chunks, one per worker (``np.array_split`` sizes), and every
   chunk is queried concurrently on ``.../<id>/rollout``, named by a ``chunk`` tag the reply must
   carry back. When a batch has fewer roll-outs than there are workers, the workers it goes to
   take turns (round robin from a random start per evaluator), so many jobs with small batches
   spread over a large pool instead of all landing on the first workers by name;
3. a liveliness subscriber watches the workers while chunks are in flight: when a worker's token
   goes (it died, e.g. ``kill -9``) or its query fails, its chunk is cut again over the healthy
   workers and re-sent;
4. results are written into their slots by index: each roll-out is taken from exactly one reply,
   so the returned batch is in order and every roll-out counts once. A reply that arrives for an
   abandoned chunk is discarded.

**One bad worker never fails the job** (issue 66). A worker is *excluded* from the job (for the
evaluator's life: one attempt of a job), named in :attr:`RemoteEvaluator.excluded`, and its chunk
re-sent to healthy workers, when it

* answers with a reply that cannot be read or holds numbers no task reports: NaN or inf (the
  wire refuses them), a reward, return, error or state beyond 1e150 in magnitude
  (:class:`acnmp_core.rollout.RolloutBatch`), arrays of the wrong shape, another number of
  roll-outs, another chunk's tag or another worker's id;
* answers nothing within ``timeout`` (``timeout``), or far slower than its peers: a chunk still
  running after :data:`SLOW_FACTOR` times the recent time per roll-out (at least
  :data:`SLOW_MIN_S` s) is also sent to an idle healthy worker, the first answer counts, and a
  worker beaten that way is excluded as too slow;
* fails :data:`MAX_FAILURES` times (``internal``, ``unavailable``, a broken reply);
* refuses a request (``bad_request``, ``bad_shape``, ``unknown_task``, ...) that another worker
  then runs. The same refusal from a second worker means the request is at fault: ValueError, as an
  in-process evaluator would raise, and nobody is excluded for it.

**Cross-checks** (issue 73: a worker that lies with finite numbers, right shapes and the right
tag passes every check above). With ``cross_check`` = f, each chunk a worker answered is, with
probability f, run again on another healthy worker, and with ``check_success`` so is every chunk
reporting a success (what would end a job that stops on success); the two results must agree
within the simulators' determinism (:func:`services.worker.core.disagreement`). When they do not, a
third healthy worker runs the chunk too and each worker that disagrees with it is excluded
(``its results for roll-outs i..j disagree with ...``) and its chunk's results replaced by the
third's; with no third worker, both are excluded, so the batch never rests on one worker alone.
With no second healthy worker (a one-worker deployment) nothing is checked. ``checks``,
``check_rollouts`` and ``disagreements`` count them.

Every exclusion also goes to the learner's :class:`~services.worker.exclusion.WorkerExclusions`
(``exclusions``), so its other jobs avoid the worker for a while. The job fails (RuntimeError
naming every excluded worker and why) only when no healthy worker of its kind is left for
``discover_timeout`` seconds. The returned batch is an :class:`~services.worker.core.ExecutedBatch`:
its ``workers`` name the worker that executed each roll-out.
"""
from __future__ import annotations

import contextlib
import logging
import random
import statistics
import threading
import time
import uuid
from collections import deque
from dataclasses import dataclass

import numpy as np
import zenoh

from acnmp_core.rollout import RolloutBatch
from acnmp_core.tasks.registry import task_credit, task_names
from services.transport import Keyspace, WireError, alive_tokens, call
from services.transport.keys import check_name, token_id
from services.transport.rpc import UnreadableReply

from .core import ExecutedBatch, batch_from_reply, disagreement, rollout_request, take
from .exclusion import Exclusion, WorkerExclusions

log = logging.getLogger(__name__)

#: Error codes of a worker refusing the request itself: the request's fault once a second worker
#: agrees (ValueError), the worker's once another runs it.
REFUSAL_CODES = ("bad_request", "bad_shape", "bad_dtype", "non_finite", "too_large", "unknown_task", "malformed",
                 "bad_version")
#: Failures (``internal``, ``unavailable``, a broken session) after which a worker is excluded from the job.
MAX_FAILURES = 2
#: A chunk still running after this many times the recent seconds per roll-out times its size ...
SLOW_FACTOR = 10.0
#: ... and at least this many seconds is also sent to an idle healthy worker (its worker, if beaten, excluded).
SLOW_MIN_S = 2.0
#: Recent chunks whose seconds per roll-out say how long a chunk should take.
DURATIONS_KEPT = 64


class _BadReply(Exception):
    """A worker's reply that answers something else than the chunk asked (the message says what)."""


@dataclass
class _Chunk:
    start: int
    stop: int
    worker: str
    attempt: int  # id of this query: a late reply of an abandoned one is ignored
    group: int  # the dispatch of the range [start, stop): a chunk and its copy on a faster worker share it
    sent: float  # time.monotonic() when queried
    copy_of: int | None = None  # the attempt this one copies (sent because that one was slow)
    copied: bool = False  # a copy of this one was sent
    role: str = "run"  # "run": its results are the batch's; "check", "referee": a cross-check's

    @property
    def span(self) -> str:
        return f"roll-outs {self.start}..{self.stop - 1}"


class RemoteEvaluator:
    """Evaluate trajectories on remote workers; implements :class:`acnmp_core.rollout.RolloutEvaluator`.

    Parameters
    ----------
    session : an open zenoh session (not closed here).
    keys : the deployment's :class:`Keyspace` (or its namespace name).
    robot : whose workers to use (``acnmp/<ns>/worker/<robot>/*``).
    task, task_config : the registry task the workers run and its parameters.
    timeout : seconds one chunk may take before its worker is excluded and the chunk goes to another.
    discover_timeout : seconds to wait for a live (healthy) worker when there is none.
    max_attempts : chunk re-sends per batch before giving up (RuntimeError).
    stop : when set (the learner shutting down), a batch in flight is abandoned at once with
        InterruptedError instead of waiting for its replies.
    exclusions : the learner's registry of workers its jobs excluded lately (shared by its
        evaluators; None: this evaluator's own).
    slow_min_s : the least seconds a chunk runs before it counts as slow (:data:`SLOW_MIN_S`).
    cross_check : the fraction of answered chunks run again on another worker (0: none; the module
        docstring). check_success : also every chunk reporting a success. check_seed : seeds the
        choice of the chunks checked (None: from the system).

    ``excluded`` lists the workers this evaluator excluded (its job's), in order.
    """

    def __init__(self, session: zenoh.Session, keys: Keyspace | str, robot: str, task: str,
                 task_config: dict | None = None, *, timeout: float = 60.0, discover_timeout: float = 10.0,
                 max_attempts: int = 20, stop: threading.Event | None = None,
                 exclusions: WorkerExclusions | None = None, slow_min_s: float = SLOW_MIN_S,
                 cross_check: float = 0.0, check_success: bool = False, check_seed: int | None = None):
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
        self.exclusions = exclusions if exclusions is not None else WorkerExclusions()
        self.slow_min_s = float(slow_min_s)
        self._pattern = self.keys.worker_token(self.robot)
        self.ignored_tokens = 0  # liveliness tokens that named no worker (wildcards, bad ids)
        self._turn = random.randrange(1 << 30)  # which worker a batch starts on (round robin)
        #: the workers excluded from this evaluator's job, in order
        self.excluded: list[Exclusion] = []
        self._failures: dict[str, int] = {}
        self._per_rollout: deque[float] = deque(maxlen=DURATIONS_KEPT)  # seconds per roll-out, recent chunks
        if not 0.0 <= cross_check <= 1.0:
            raise ValueError(f"cross_check: expected a fraction in [0, 1], got {cross_check!r}")
        self.cross_check, self.check_success = float(cross_check), bool(check_success)
        self._check_rng = random.Random(check_seed)
        #: chunks answered (their results used), chunks run again to check them, the roll-outs
        #: those ran, and the checks whose results disagreed
        self.chunks = self.checks = self.check_rollouts = self.disagreements = 0

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

    # ----- exclusions ------------------------------------------------------------------------
    def _exclude(self, worker: str, reason: str) -> None:
        if any(e.worker == worker for e in self.excluded):
            return
        exclusion = Exclusion(worker, reason)
        self.excluded.append(exclusion)
        self.exclusions.exclude(exclusion)
        log.warning("worker %s failed (%s): excluded from the job", worker, reason)

    def _is_excluded(self, worker: str) -> bool:
        return any(e.worker == worker for e in self.excluded)

    def _no_healthy_worker(self) -> RuntimeError:
        why = "; ".join(e.line() for e in self.excluded) or "none excluded"
        return RuntimeError(f"no healthy {self.robot} worker left in namespace {self.keys.namespace} "
                            f"(excluded: {why})")

    def _slow_after(self, n: int) -> float | None:
        """Seconds after which a chunk of ``n`` roll-outs counts as slow (None: no chunk finished yet)."""
        if not self._per_rollout:
            return None
        return max(self.slow_min_s, SLOW_FACTOR * statistics.median(self._per_rollout) * n)

    # ----- one reply -------------------------------------------------------------------------
    @staticmethod
    def _read_reply(reply: dict, chunk: _Chunk, tag: str, steps: int) -> RolloutBatch:
        """The batch of a reply to ``chunk`` (tag ``tag``, ``steps`` per roll-out); :class:`_BadReply`
        when it answers something else."""
        if reply.get("chunk") != tag:
            raise _BadReply(f"a reply for another chunk ({reply.get('chunk')!r}, asked {tag!r})")
        if reply.get("worker") != chunk.worker:
            raise _BadReply(f"a reply naming worker {reply.get('worker')!r}")
        try:
            batch = batch_from_reply(reply)
        except WireError as exc:
            raise _BadReply(exc.message) from None
        n = chunk.stop - chunk.start
        if len(batch) != n:
            raise _BadReply(f"{len(batch)} roll-outs for {n}")
        if batch.rewards.shape[1] != steps:
            raise _BadReply(f"rewards of shape {batch.rewards.shape} for {n} roll-outs of {steps} steps")
        return batch

    def evaluate(self, trajectories, times, task_params=None) -> ExecutedBatch:
        """trajectories (B, T, D), times (T,), task_params (P,) or None -> the B roll-outs in order,
        with the worker that executed each (``batch.workers``). ValueError when the request itself
        is refused (by two workers); RuntimeError when no healthy worker is left."""
        trajs = np.asarray(trajectories, dtype=np.float64)
        if trajs.ndim != 3 or trajs.shape[0] < 1:
            raise ValueError(f"trajectories: expected shape (B, T, D) with B >= 1, got {trajs.shape}")
        times = np.asarray(times, dtype=np.float64)
        tp = None if task_params is None else np.asarray(task_params, dtype=np.float64).reshape(-1)
        b, steps = trajs.shape[0], trajs.shape[1]
        results: list[RolloutBatch | None] = [None] * b  # one slot per roll-out
        done_by: list[str] = [""] * b
        host_of: list[str] = [""] * b
        cond = threading.Condition()
        live: set[str] = set()
        dead: set[str] = set()
        inflight: dict[int, _Chunk] = {}  # chunk attempt id -> chunk
        outcomes: list[tuple[_Chunk, str, object]] = []  # (chunk, kind, detail) from the query threads
        refusals: list[tuple[_Chunk, str]] = []  # client-error refusals not yet contradicted
        counter = [0]
        batch_tag = uuid.uuid4().hex[:12]

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
            tag = f"{batch_tag}-{chunk.attempt}"
            req = rollout_request(self.task, self.task_config, trajs[chunk.start:chunk.stop], times, tp, chunk=tag)
            key = self.keys.worker_rollout(self.robot, chunk.worker)
            try:
                reply = call(self.session, key, req, timeout=self.timeout)
                outcome = ("ok", (self._read_reply(reply, chunk, tag, steps), str(reply.get("host") or "")))
            except UnreadableReply as exc:  # NaN in its arrays, not msgpack, ...: its fault, not ours
                outcome = ("bad", f"{exc.code}: {exc.message}")
            except _BadReply as exc:
                outcome = ("bad", str(exc))
            except WireError as exc:
                if exc.code == "timeout":
                    outcome = ("slow", f"no answer within {self.timeout:g} s")
                elif exc.code in REFUSAL_CODES:
                    outcome = ("refused", f"{exc.code}: {exc.message}")
                else:
                    outcome = ("failed", f"{exc.code}: {exc.message}")
            except Exception as exc:  # the session closing under us
                outcome = ("failed", f"{type(exc).__name__}: {exc}")
            with cond:
                outcomes.append((chunk, *outcome))
                cond.notify_all()

        def send(start: int, stop: int, worker: str, group: int | None = None, copy_of: int | None = None,
                 role: str = "run") -> _Chunk:
            counter[0] += 1
            chunk = _Chunk(start, stop, worker, counter[0], counter[0] if group is None else group, time.monotonic(),
                           copy_of, role=role)
            inflight[chunk.attempt] = chunk
            threading.Thread(target=run_chunk, args=(chunk,), daemon=True, name=f"rollout-{worker}").start()
            return chunk

        def healthy() -> list[str]:
            return sorted(w for w in live if not self._is_excluded(w))

        def candidates(avoid: set[str]) -> list[str]:
            """The workers to send to: healthy ones no other job excluded lately, outside ``avoid``;
            else healthy ones outside ``avoid``; else (``avoid`` holds only failed ones) any healthy."""
            ok = healthy()
            others = self.exclusions.excluded()
            for pool in ([w for w in ok if w not in avoid and w not in others], [w for w in ok if w not in avoid]):
                if pool:
                    return pool
            return ok

        def dispatch(start: int, stop: int, avoid: set[str]) -> None:
            # cut [start, stop) over the candidates; caller holds `cond`
            pool = candidates(avoid)
            if not pool:
                if not self._wait_for(cond, lambda: bool(healthy()), self.discover_timeout):
                    raise self._no_healthy_worker()
                pool = candidates(avoid)
            n = min(len(pool), stop - start)
            first, self._turn = self._turn % len(pool), self._turn + n
            for idx, part in enumerate(np.array_split(np.arange(start, stop), n)):
                send(int(part[0]), int(part[-1]) + 1, pool[(first + idx) % len(pool)])

        def drop_worker(worker: str) -> list[_Chunk]:
            """Abandon every chunk in flight on ``worker`` (excluded or gone); returns those that
            have no copy still running elsewhere (to be sent again)."""
            mine = [c for c in inflight.values() if c.worker == worker]
            for c in mine:
                inflight.pop(c.attempt)
            for c in mine:
                if c.role != "run":
                    abandon_check(c)
            return [c for c in mine if c.role == "run" and not any(o.group == c.group for o in inflight.values())]

        resends = [0]

        def again(chunk: _Chunk, why: str, avoid: set[str]) -> None:
            resends[0] += 1
            if resends[0] > self.max_attempts:
                raise RuntimeError(f"{chunk.span} failed {resends[0]} times; last: {why}")
            log.warning("worker %s failed (%s): re-sending %s", chunk.worker, why, chunk.span)
            dispatch(chunk.start, chunk.stop, avoid)

        def settle(chunk: _Chunk, kind: str, detail) -> None:
            """Act on one query's outcome (caller holds ``cond``)."""
            if chunk.attempt not in inflight:
                return  # abandoned (its worker excluded or gone, or a copy answered first)
            if chunk.role != "run":
                settle_check(chunk, kind, detail)
                return
            if kind == "ok":
                batch, host = detail
                for c in [c for c in inflight.values() if c.group == chunk.group]:
                    inflight.pop(c.attempt)
                    if c is not chunk and chunk.copy_of == c.attempt:  # the copy beat the slow original
                        self._exclude(c.worker, f"too slow: {c.span} unanswered after "
                                                f"{time.monotonic() - c.sent:.1f} s, another worker answered them "
                                                f"in {time.monotonic() - chunk.sent:.2f} s")
                        for left in drop_worker(c.worker):
                            again(left, "excluded", {c.worker})
                self._per_rollout.append((time.monotonic() - chunk.sent) / (chunk.stop - chunk.start))
                for i in range(chunk.start, chunk.stop):
                    results[i] = take(batch, i - chunk.start, i - chunk.start + 1)
                    done_by[i], host_of[i] = chunk.worker, host
                for refused, why in list(refusals):  # someone else ran what it refused: its fault
                    if refused.start < chunk.stop and chunk.start < refused.stop and refused.worker != chunk.worker:
                        refusals.remove((refused, why))
                        self._exclude(refused.worker, f"refused {refused.span} ({why}), which {chunk.worker} ran")
                self.chunks += 1
                if self._check_rng.random() < self.cross_check or (self.check_success and bool(batch.success.any())):
                    check(chunk, batch, host)
                return
            inflight.pop(chunk.attempt)
            copy_running = any(c.group == chunk.group for c in inflight.values())
            if kind in ("bad", "slow"):
                self._exclude(chunk.worker, f"{'answered' if kind == 'bad' else 'too slow'} for {chunk.span}: {detail}")
                pending = ([] if copy_running else [chunk]) + drop_worker(chunk.worker)
                for c in pending:
                    again(c, str(detail), {chunk.worker})
                return
            if kind == "refused":
                others = {c.worker for c, _ in refusals} - {chunk.worker}
                if others:  # a second worker refuses it too: the request is at fault
                    raise ValueError(f"worker {chunk.worker}: {detail}")
                refusals.append((chunk, str(detail)))
                if copy_running:
                    return
                if not [w for w in healthy() if w != chunk.worker]:
                    raise ValueError(f"worker {chunk.worker}: {detail}")  # nobody to ask whether it is the request
                again(chunk, str(detail), {chunk.worker})
                return
            # failed: a worker that keeps failing is excluded, one failure is re-sent elsewhere
            self._failures[chunk.worker] = self._failures.get(chunk.worker, 0) + 1
            if self._failures[chunk.worker] >= MAX_FAILURES:
                self._exclude(chunk.worker, f"failed {self._failures[chunk.worker]} times; last for {chunk.span}: "
                                            f"{detail}")
                pending = ([] if copy_running else [chunk]) + drop_worker(chunk.worker)
            else:
                pending = [] if copy_running else [chunk]
            for c in pending:
                again(c, str(detail), {chunk.worker})

        # cross-checks: the group of a check (or referee) chunk -> what it checks: the original chunk,
        # its results and host, and for a referee the checker's chunk and results
        checking: dict[int, tuple] = {}

        def others(*but: str) -> list[str]:
            """Healthy workers other than ``but``, those no other job excluded lately first."""
            pool = [w for w in healthy() if w not in but]
            avoided = self.exclusions.excluded()
            return [w for w in pool if w not in avoided] or pool

        def check(chunk: _Chunk, batch: RolloutBatch, host: str) -> None:
            """Run ``chunk``'s roll-outs again on another healthy worker (none: no check)."""
            pool = others(chunk.worker)
            if not pool:
                return
            worker = pool[self._check_rng.randrange(len(pool))]
            c = send(chunk.start, chunk.stop, worker, role="check")
            checking[c.group] = (chunk, batch, host)
            self.checks += 1
            self.check_rollouts += chunk.stop - chunk.start

        def referee(chunk: _Chunk, batch: RolloutBatch, host: str, checker: _Chunk, checked: RolloutBatch,
                    why: str) -> None:
            """A third worker runs the roll-outs two workers disagree on; none: both are excluded."""
            pool = others(chunk.worker, checker.worker)
            if pool:
                c = send(chunk.start, chunk.stop, pool[self._check_rng.randrange(len(pool))], role="referee")
                checking[c.group] = (chunk, batch, host, checker, checked, why)
                self.check_rollouts += chunk.stop - chunk.start
                return
            for worker, other in ((chunk.worker, checker.worker), (checker.worker, chunk.worker)):
                exclude_liar(worker, f"its results for {chunk.span} disagree with {other}'s ({why}); no third "
                                     "worker to tell which is right")
            # the batch must not rest on either: the roll-outs run again elsewhere (or the job fails, naming both)
            again(chunk, "its results are disputed", {chunk.worker, checker.worker})

        def exclude_liar(worker: str, reason: str) -> None:
            if self._is_excluded(worker):
                return
            self._exclude(worker, reason)
            for left in drop_worker(worker):
                again(left, "excluded", {worker})

        def settle_check(c: _Chunk, kind: str, detail) -> None:
            """Act on a check's or referee's outcome (caller holds ``cond``)."""
            inflight.pop(c.attempt)
            if kind != "ok":  # the checking worker failed: its own bookkeeping, and the check given up
                if kind in ("bad", "slow"):
                    exclude_liar(c.worker, f"{'answered' if kind == 'bad' else 'too slow'} for {c.span}: {detail}")
                else:
                    self._failures[c.worker] = self._failures.get(c.worker, 0) + 1
                    if self._failures[c.worker] >= MAX_FAILURES:
                        exclude_liar(c.worker, f"failed {self._failures[c.worker]} times; last for {c.span}: {detail}")
                abandon_check(c)
                return
            got, host = detail
            what = checking.pop(c.group, None)
            if what is None:
                return
            if c.role == "check":
                chunk, batch, orig_host = what
                why = disagreement(batch, got)
                if why is not None:
                    self.disagreements += 1
                    log.warning("workers %s and %s disagree on %s (%s)", chunk.worker, c.worker, chunk.span, why)
                    referee(chunk, batch, orig_host, c, got, why)
                return
            chunk, batch, _orig_host, checker, checked, _why = what
            for worker, theirs in ((chunk.worker, batch), (checker.worker, checked)):
                why = disagreement(theirs, got)
                if why is not None:
                    exclude_liar(worker, f"its results for {chunk.span} disagree with {c.worker}'s and "
                                         f"{checker.worker if worker == chunk.worker else chunk.worker}'s ({why})")
            if disagreement(batch, got) is not None:  # the batch takes the referee's results instead
                for i in range(chunk.start, chunk.stop):
                    results[i] = take(got, i - chunk.start, i - chunk.start + 1)
                    done_by[i], host_of[i] = c.worker, host

        def abandon_check(c: _Chunk) -> None:
            """A check or referee chunk that will not answer (caller holds ``cond``): a check is given
            up; a referee is asked of another worker (none: both disputed workers are excluded)."""
            what = checking.pop(c.group, None)
            if what is None or c.role == "check":
                if what is not None:
                    log.warning("the check of %s on %s was given up (%s did not answer it)", c.span, what[0].worker,
                                c.worker)
                return
            chunk, batch, host, checker, checked, why = what
            referee(chunk, batch, host, checker, checked, why)

        def copy_slow_chunks() -> None:
            """Send each chunk running far longer than its peers to an idle healthy worker too."""
            busy = {c.worker for c in inflight.values()}
            others = self.exclusions.excluded()
            idle = [w for w in healthy() if w not in busy and w not in others]
            for c in list(inflight.values()):
                if not idle:
                    return
                limit = self._slow_after(c.stop - c.start)
                if c.role != "run" or c.copied or c.copy_of is not None or limit is None \
                        or time.monotonic() - c.sent < limit:
                    continue
                c.copied = True
                worker = idle.pop(0)
                log.warning("worker %s: %s still running after %.1f s; also sent to %s", c.worker, c.span,
                            time.monotonic() - c.sent, worker)
                send(c.start, c.stop, worker, group=c.group, copy_of=c.attempt)

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
                while True:
                    self._check_stop()
                    while outcomes:
                        settle(*outcomes.pop(0))
                    for c in [c for c in inflight.values() if c.worker in dead]:  # its worker died: re-send
                        if c.attempt in inflight:
                            for left in drop_worker(c.worker):
                                again(left, "worker disappeared", {c.worker})
                    if not inflight and not outcomes:
                        break
                    copy_slow_chunks()
                    cond.wait(timeout=0.1)
                    if time.monotonic() > deadline + self.timeout * (self.max_attempts + 1):
                        raise RuntimeError("roll-out batch did not complete")
        finally:
            with contextlib.suppress(Exception):
                sub.undeclare()
        missing = [i for i, r in enumerate(results) if r is None]
        if missing:  # cannot happen when the loop above ends normally; guard the invariant
            raise RuntimeError(f"roll-outs {missing} have no result")
        return ExecutedBatch.of(RolloutBatch.concat(results), done_by, host_of)
