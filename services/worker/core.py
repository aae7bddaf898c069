"""The worker's logic without zenoh: the roll-out request/reply codec and :class:`Worker`.

Request ``{"v":1, "task": str, "task_config": map, "trajectories": (B,T,D) float,
"times": (T,) float, "task_params": (P,) float | nil, "chunk": str (optional)}`` -> reply
``{"v":1, "worker": id, "chunk": the request's chunk, <every field of the RolloutBatch>}``: ``rewards`` (B,T), ``success`` (B,) bool, ``states``
{name: (B,T,...)} and any field the library's RolloutBatch grows (e.g. ``errors`` (B,)), which then
travels without a change here. Bad input gets a ``reply_err`` (``unknown_task``, ``bad_request``,
``bad_shape``, ...) and the worker keeps serving.

The robot kind (acnmp_core.robots.registry) decides which tasks a worker runs and fixes some of
their parameters (a planar3 worker always pushes with a 3-joint arm). Evaluators are cached per
(task, task_config): building a PyBullet world costs far more than one roll-out.
"""
from __future__ import annotations

import dataclasses
import json
import time
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import numpy as np

from acnmp_core.robots.registry import robot
from acnmp_core.rollout import RolloutBatch
from services.transport.keys import check_name
from services.transport.wire import WireError, array_field, field, require_payload

#: Bounds on one request, so an absurd batch is refused before any work (roll-outs x steps x dims).
MAX_ELEMENTS = 20_000_000
MAX_BATCH = 10_000
#: Evaluators kept alive (each may hold a PyBullet physics client).
CACHE_SIZE = 8

_BATCH_FIELDS = tuple(f.name for f in dataclasses.fields(RolloutBatch))


@dataclass
class ExecutedBatch(RolloutBatch):
    """A :class:`~acnmp_core.rollout.RolloutBatch` that also says which worker executed each roll-out:
    ``workers`` (B,) worker ids (``"local"`` for an in-process evaluator) and ``hosts`` (B,) their
    hosts (services/transport/about.py; empty when not known)."""

    workers: tuple[str, ...] = ()
    hosts: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        super().__post_init__()
        self.workers = tuple(str(w) for w in self.workers)
        self.hosts = tuple(str(h) for h in self.hosts)
        if len(self.workers) != len(self):
            raise ValueError(f"workers: expected {len(self)} worker ids, got {len(self.workers)}")
        if self.hosts and len(self.hosts) != len(self):
            raise ValueError(f"hosts: expected {len(self)} host names, got {len(self.hosts)}")

    @classmethod
    def of(cls, batch: RolloutBatch, workers, hosts=()) -> "ExecutedBatch":
        """``batch`` with its worker ids and hosts (every field of the library's RolloutBatch is kept)."""
        return cls(**{name: getattr(batch, name) for name in _BATCH_FIELDS}, workers=tuple(workers),
                   hosts=tuple(hosts))


def take(batch: RolloutBatch, start: int, stop: int) -> RolloutBatch:
    """Roll-outs ``start:stop`` of ``batch`` (every array field and state sliced along axis 0)."""
    def cut(value):
        if isinstance(value, dict):
            return {k: v[start:stop] for k, v in value.items()}
        return None if value is None else value[start:stop]

    return RolloutBatch(**{name: cut(getattr(batch, name)) for name in _BATCH_FIELDS})


def rollout_request(task: str, task_config: dict, trajectories, times, task_params=None,
                    chunk: str | None = None) -> dict:
    """The request map asking a worker to execute ``trajectories`` (B, T, D) at ``times`` (T,);
    ``chunk`` names this request, and the reply must name it too (a reply for another chunk is
    a bad reply: services/worker/remote.py)."""
    request = {"v": 1, "task": task, "task_config": task_config, "trajectories": trajectories, "times": times,
               "task_params": task_params}
    if chunk is not None:
        request["chunk"] = chunk
    return request


def rollout_reply(batch: RolloutBatch, worker_id: str, host: str = "", chunk: str | None = None) -> dict:
    """The reply map of an executed batch: every RolloutBatch field that is set, the worker, its
    host and the request's ``chunk`` (when it named one)."""
    reply: dict[str, Any] = {"v": 1, "worker": worker_id, "host": host}
    if chunk is not None:
        reply["chunk"] = chunk
    for name in _BATCH_FIELDS:
        value = getattr(batch, name)
        if isinstance(value, dict):
            reply[name] = {k: np.asarray(v) for k, v in value.items()}
        elif value is not None:
            reply[name] = np.asarray(value)
    return reply


def batch_from_reply(reply: dict) -> RolloutBatch:
    """The RolloutBatch of a decoded reply; WireError ``internal`` if the reply does not make one."""
    try:
        return RolloutBatch(**{name: reply[name] for name in _BATCH_FIELDS if reply.get(name) is not None})
    except (TypeError, ValueError) as exc:
        raise WireError("internal", f"worker {reply.get('worker')!r} sent a bad reply: {exc}") from None


#: Two executions of the same roll-outs agree when their floats are this close (relative, absolute):
#: a simulator given the same trajectory gives the same numbers (bit for bit on one machine; the
#: margin is for another CPU's rounding), a lying worker numbers of its own.
AGREE_RTOL, AGREE_ATOL = 1e-6, 1e-9


def disagreement(a: RolloutBatch, b: RolloutBatch) -> str | None:
    """What differs between two executions of the same roll-outs, ``a`` and ``b``, beyond the
    simulators' determinism (:data:`AGREE_RTOL`, :data:`AGREE_ATOL`; success must be the same), in
    one line; None when they agree. Two workers given the same trajectories agree unless one of
    them lies (services/worker/remote.py, cross-checks)."""
    def close(x, y) -> bool:
        return x.shape == y.shape and bool(np.allclose(x, y, rtol=AGREE_RTOL, atol=AGREE_ATOL))

    if len(a) != len(b):
        return f"{len(a)} roll-outs against {len(b)}"
    if not np.array_equal(a.success, b.success):
        i = int(np.argmax(a.success != b.success))
        return f"success {bool(a.success[i])} against {bool(b.success[i])} (roll-out {i})"
    if not close(a.rewards, b.rewards):
        if a.rewards.shape != b.rewards.shape:
            return f"rewards of shape {a.rewards.shape} against {b.rewards.shape}"
        i = int(np.argmax(~np.all(np.isclose(a.rewards, b.rewards, rtol=AGREE_RTOL, atol=AGREE_ATOL), axis=1)))
        return f"return {a.returns[i]:.6g} against {b.returns[i]:.6g} (roll-out {i})"
    if (a.errors is None) != (b.errors is None) or (a.errors is not None and not close(a.errors, b.errors)):
        return "errors differ"
    if set(a.states) != set(b.states):
        return f"states {sorted(a.states)} against {sorted(b.states)}"
    for name in sorted(a.states):
        x, y = np.asarray(a.states[name]), np.asarray(b.states[name])
        if not (close(x, y) if x.dtype.kind == "f" and y.dtype.kind == "f" else np.array_equal(x, y)):
            return f"states[{name!r}] differ"
    return None


class Worker:
    """Executes roll-out requests for one robot kind; the zenoh-free core of the worker process.

    ``delay`` (seconds per roll-out) simulates a slow robot, for tests and benchmarks; ``host`` is
    the host every reply names (the process's, services/transport/about.py).
    """

    def __init__(self, robot_kind: str, worker_id: str, *, delay: float = 0.0, host: str = ""):
        self.robot = robot(robot_kind)
        self.worker_id = check_name("worker id", worker_id)
        self.host = str(host)
        self.delay = float(delay)
        self._cache: OrderedDict[str, Any] = OrderedDict()
        self.rollouts = 0

    def evaluator(self, task: str, cfg: dict):
        """The cached evaluator of ``task`` with effective parameters ``cfg`` (built on first use)."""
        key = json.dumps([task, cfg], sort_keys=True)
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        ev = self.robot.make_evaluator(task, cfg)
        self._cache[key] = ev
        while len(self._cache) > CACHE_SIZE:
            _, old = self._cache.popitem(last=False)
            if hasattr(old, "close"):
                old.close()
        return ev

    def handle(self, request: dict | None) -> dict:
        """Run one decoded roll-out request and return the reply map (see the module docstring).

        Raises WireError for a bad request; the task's own ValueErrors (wrong D, bad task
        parameters) are answered by their type's code, ``bad_request`` when untyped.
        """
        request = require_payload(request, "a roll-out request")
        task = field(request, "task", str)
        cfg = self.robot.task_config(task, field(request, "task_config", dict, default={}))
        trajs = array_field(request, "trajectories", ndim=3, max_elements=MAX_ELEMENTS)
        b, t, _ = trajs.shape
        if b < 1 or b > MAX_BATCH or t < 2:
            raise WireError("bad_shape", f"field 'trajectories': shape {trajs.shape}, need 1<=B<={MAX_BATCH}, T>=2")
        times = array_field(request, "times", shape=(t,))
        tp = array_field(request, "task_params", ndim=1, default=None, max_elements=1024)
        chunk = field(request, "chunk", str, default=None)
        ev = self.evaluator(task, cfg)
        try:
            batch = ev.evaluate(trajs.astype(np.float64), times.astype(np.float64), tp)
        except ValueError as exc:  # the task's own validation: wrong D, bad task params, ...
            raise WireError("bad_request", f"task {task!r}: {exc}") from None
        if self.delay > 0:
            time.sleep(self.delay * b)
        self.rollouts += b
        return rollout_reply(batch, self.worker_id, self.host, chunk)

    def close(self) -> None:
        """Close every cached evaluator that holds resources (PyBullet clients)."""
        while self._cache:
            _, ev = self._cache.popitem()
            if hasattr(ev, "close"):
                ev.close()
