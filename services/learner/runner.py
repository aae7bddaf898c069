"""Where a job's adaptation computes: on the learner's job thread, or in a child process of its own.

The supervised and policy steps of :func:`acnmp_core.adaptation.loop.adapt` are many small torch
operations whose Python overhead holds the GIL, so jobs on threads of one process take turns on
one core (``benchmarks/results/bench_jobs.json``: two E1 jobs on two threads take about as long as
one after the other). :class:`ProcessRunner` runs the adaptation in a child process instead,
one per job slot, reused from job to job. A learner process forks its children at its start
(:func:`fork_children`, before it opens its zenoh session or starts a thread), so they share its
imported torch; a child that replaces a dead one comes from a fork server (a fresh interpreter
that imports torch once). Only the arithmetic moves there: the child has no zenoh session, no
state directory and no events. It asks its parent for every roll-out batch
(the parent's evaluator runs it, on the learner's session) and hands it every iteration (the
parent's ``on_iteration`` persists the job's progress and publishes its events), so recording,
progress, cancel and restart behave as on a thread. An exception the parent's side raises (a
cancel, a shutdown, a worker error) is raised inside the child's ``adapt`` at the same point and
comes back to the caller as the same exception.

Results do not depend on the runner: the child computes with the same model (pickled exactly),
seed and single torch thread, so the job's result and its adapted weights are bit-equal to those
of the same job run on a thread, alone or beside other jobs.

A child that dies (killed, out of memory) fails the job it ran with a one-line error and is
replaced for the next one; a learner that stops kills its children at once (the iteration in
flight is dropped: the next attempt starts over, as on a thread). A child whose parent died sees
its pipe close at its next batch and exits.
"""
from __future__ import annotations

import logging
import multiprocessing
import pickle
import signal
import threading
from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np

from acnmp_core.adaptation.config import AdaptConfig, AdaptResult, AdaptTarget, IterationLog
from acnmp_core.adaptation.loop import adapt
from acnmp_core.model.cnmp import CNMP
from acnmp_core.data.demos import DemoSet
from acnmp_core.rollout import RolloutBatch, RolloutEvaluator

from .config import RUNNERS

log = logging.getLogger(__name__)

#: Seconds between looks at the learner's stop flag while a child computes.
STOP_POLL = 0.1


@dataclass(frozen=True)
class AdaptTask:
    """One adaptation as a runner gets it: the arguments of :func:`~acnmp_core.adaptation.loop.adapt`
    (``model`` is adapted in place by the runner; ``credit`` is the evaluator's credit rule)."""

    model: CNMP
    demos: DemoSet
    target: AdaptTarget
    config: AdaptConfig
    seed: int
    credit: str = "step"


OnIteration = Callable[[IterationLog, np.ndarray, RolloutBatch], None]


class AdaptRunner(Protocol):
    """Runs one adaptation at a time; :meth:`run` has the contract of
    :func:`~acnmp_core.adaptation.loop.adapt` (``task.model`` holds the adapted weights afterwards)."""

    def run(self, task: AdaptTask, evaluator: RolloutEvaluator, on_iteration: OnIteration,
            stop: threading.Event) -> AdaptResult:
        """Adapt ``task.model`` with ``evaluator``'s roll-outs; InterruptedError once ``stop`` is set."""

    def start(self) -> "AdaptRunner":
        """Get ready ahead of the first job (a child process starts and imports torch); returns self."""

    def close(self) -> None:
        """Release what the runner holds (a child process)."""


class ThreadRunner:
    """:func:`~acnmp_core.adaptation.loop.adapt` on the calling thread (jobs share the GIL)."""

    def run(self, task: AdaptTask, evaluator: RolloutEvaluator, on_iteration: OnIteration,
            stop: threading.Event) -> AdaptResult:
        """See :class:`AdaptRunner`; ``stop`` is seen by ``on_iteration`` and the evaluator."""
        return adapt(task.model, task.demos, task.target, evaluator, task.config, seed=task.seed,
                     on_iteration=on_iteration)

    def start(self) -> "ThreadRunner":
        """Nothing to start; returns self."""
        return self

    def close(self) -> None:
        """Nothing to release."""


class _ChildEvaluator:
    """The child's evaluator: asks the parent for each batch (``("evaluate", args)``)."""

    def __init__(self, conn, credit: str):
        self.conn, self.credit = conn, credit

    def evaluate(self, trajectories, times, task_params=None) -> RolloutBatch:
        return _ask(self.conn, ("evaluate", (trajectories, times, task_params)))


def _put(conn, message) -> None:
    """Send ``message`` pickled by value. Not ``conn.send``: its pickler hands each torch tensor over
    as shared memory, one socket connection and handshake per tensor, slower than copying the small
    tensors of a job (its model, its weights)."""
    conn.send_bytes(pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL))


def _get(conn):
    """Receive what :func:`_put` sent."""
    return pickle.loads(conn.recv_bytes())


def _ask(conn, message):
    """Send ``message`` to the parent and return its answer, raising the exception it sends back."""
    _put(conn, message)
    kind, value = _get(conn)
    if kind == "raise":
        raise value
    return value


def _send(conn, message: tuple) -> None:
    """Send ``(kind, value)``; a value that does not pickle (an exception of an exotic type) is
    sent as a RuntimeError holding its line, of the same kind."""
    try:
        _put(conn, message)
    except (EOFError, OSError):
        raise
    except Exception:  # pickling failed before anything was written
        kind, value = message
        _put(conn, (kind, RuntimeError(f"{type(value).__name__}: {value}")))


def _child_main(conn) -> None:
    """The child process: adaptations one after another until the parent closes the pipe."""
    import torch

    torch.set_num_threads(1)
    while True:
        try:
            task: AdaptTask = _get(conn)
        except (EOFError, OSError):  # the parent closed the pipe or died
            return
        try:
            result = adapt(task.model, task.demos, task.target, _ChildEvaluator(conn, task.credit), task.config,
                           seed=task.seed, on_iteration=lambda *args: _ask(conn, ("iteration", args)))
            answer = ("done", (result, task.model.state_dict()))
        except (EOFError, OSError):
            return
        except BaseException as exc:
            answer = ("raised", exc)
        try:
            _send(conn, answer)
        except (EOFError, OSError):
            return


def _context():
    """Children not forked ahead come from a fork server that imported torch once per learner: a
    child then starts in milliseconds instead of importing it again. Not a plain fork of the
    running learner, whose zenoh runtime threads may hold locks a forked child inherits."""
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload([__name__])
    return ctx


#: Children forked by :func:`fork_children`, each ``(process, parent's end of its pipe)``, waiting
#: for a :class:`ProcessRunner` of this process to adopt one.
_forked: list[tuple[multiprocessing.process.BaseProcess, object]] = []


def fork_children(n: int) -> None:
    """Fork ``n`` job children now, for the next ``n`` :class:`ProcessRunner` s of this process.

    Call it only while the process has no zenoh session and no thread of its own (a learner
    process at its start, :meth:`services.learner.service.LearnerConfig.prepare`): a fork copies
    the calling thread alone, with every lock as it was. A forked child shares the parent's
    imported modules (torch: about 3 s of CPU and 270 MB a fresh interpreter pays again).
    """
    ctx = multiprocessing.get_context("fork")
    parents = [conn for _, conn in _forked]
    for _ in range(n):
        parent, child = ctx.Pipe()
        # the child closes every parent end it inherits, so each sees EOF when the parent dies
        proc = ctx.Process(target=_forked_main, args=(child, [*parents, parent]), name="acnmp-job", daemon=True)
        proc.start()
        child.close()
        parents.append(parent)
        _forked.append((proc, parent))


def _forked_main(conn, inherited) -> None:
    """A forked child: close the pipe ends it inherited, leave SIGTERM and SIGINT to its learner
    (a Ctrl-C or a service manager signalling the whole group must not end a job before the learner
    saves it interrupted; the learner kills its children when it stops), then serve adaptations."""
    for other in inherited:
        other.close()
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _child_main(conn)


class ChildDied(RuntimeError):
    """The process that computed a job's adaptation ended before it answered."""


class ProcessRunner:
    """:func:`~acnmp_core.adaptation.loop.adapt` in a child process (see the module docstring).

    It adopts a child of :func:`fork_children` when one waits; otherwise the child is started by
    the first :meth:`run` (a runner that runs no job starts no process; the first job waits for the
    fork server to import torch, once per process) or by :meth:`start`. A child that died is
    replaced by one from the fork server.
    """

    def __init__(self, name: str = "job"):
        self.name = name
        self._proc, self._conn = _forked.pop(0) if _forked else (None, None)
        self._lock = threading.Lock()  # start() from two threads makes one child

    def start(self) -> "ProcessRunner":
        """Start the child now if none runs; returns self."""
        with self._lock:
            self._start()
        return self

    def _start(self) -> None:
        if self._proc is None or not self._proc.is_alive():
            self._discard()
            ctx = _context()  # only when a child is started here: an adopted one came from fork_children
            parent, child = ctx.Pipe()
            proc = ctx.Process(target=_child_main, args=(child,), name=f"acnmp-{self.name}", daemon=True)
            proc.start()
            child.close()
            self._proc, self._conn = proc, parent

    def run(self, task: AdaptTask, evaluator: RolloutEvaluator, on_iteration: OnIteration,
            stop: threading.Event) -> AdaptResult:
        """See :class:`AdaptRunner`. The parent serves the child's batches and iterations here;
        once ``stop`` is set the child is killed and InterruptedError raised. :class:`ChildDied`
        when the child ended unasked."""
        self.start()
        conn = self._conn
        pending: BaseException | None = None  # what the parent's side raised into the child
        try:
            _put(conn, task)
            while True:
                while not conn.poll(STOP_POLL):
                    if stop.is_set():
                        self._discard()
                        raise InterruptedError("learner is shutting down")
                kind, value = _get(conn)
                if kind == "done":
                    result, weights = value
                    task.model.load_state_dict(weights)
                    return result
                if kind == "raised":
                    raise pending if pending is not None else value
                try:
                    answer = ("value", evaluator.evaluate(*value) if kind == "evaluate" else on_iteration(*value))
                except BaseException as exc:
                    pending, answer = exc, ("raise", exc)
                _send(conn, answer)
        except (EOFError, OSError, BrokenPipeError):
            code = None if self._proc is None else self._proc.exitcode
            self._discard()
            if stop.is_set():
                raise InterruptedError("learner is shutting down") from None
            raise ChildDied(f"the job's adaptation process ended (exit code {code})") from None

    def _discard(self) -> None:
        proc, conn, self._proc, self._conn = self._proc, self._conn, None, None
        if conn is not None:
            conn.close()
        if proc is not None:
            if proc.is_alive():
                proc.kill()
            proc.join(5.0)

    def close(self) -> None:
        """Kill the child (a computation in flight is dropped) and wait for it."""
        self._discard()


def make_runner(kind: str, name: str = "job") -> AdaptRunner:
    """A runner of ``kind`` (one of :data:`RUNNERS`); ValueError for another."""
    if kind == "thread":
        return ThreadRunner()
    if kind == "process":
        return ProcessRunner(name)
    raise ValueError(f"job runner: expected one of {list(RUNNERS)}, got {kind!r}")
