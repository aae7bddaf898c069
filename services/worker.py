"""A roll-out worker: one robot kind plus an id, executing batches of trajectories over zenoh.

Declared entities: queryable ``acnmp/<ns>/worker/<robot>/<id>/rollout``, then liveliness token
``acnmp/<ns>/worker/<robot>/<id>`` (the learner's RemoteEvaluator finds workers by it).

Request ``{"v":1, "task": str, "task_config": map, "trajectories": (B,T,D) float,
"times": (T,) float, "task_params": (P,) float | nil}`` -> reply ``{"v":1, "rewards": (B,T),
"success": (B,) bool, "states": {name: array}, "worker": id}``. Bad input gets a ``reply_err``
(``unknown_task``, ``bad_request``, ``bad_shape``, ...) and the worker keeps serving.

The robot kind decides which registry tasks (acnmp_core.tasks.registry) a worker runs and fixes
some of their parameters (a planar3 worker always pushes with a 3-joint arm). Evaluators are
cached per (task, task_config): building a PyBullet world costs far more than one roll-out.
Requests are served one at a time on one thread: a worker is one robot, and a PyBullet client
must stay on the thread that uses it.
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import threading
import time
from collections import OrderedDict
from typing import Any, Callable, Sequence

import numpy as np

from services import keys
from services.session import (add_session_arguments, declare_rpc, install_shutdown_handlers,
                              open_session, session_kwargs, wait_until_stopped)
from services.wire import WireError, array_field, field

log = logging.getLogger(__name__)

#: Robot kind -> {task name: parameters the robot fixes}. Request parameters may repeat a fixed
#: one with the same value but never contradict it.
ROBOT_TASKS: dict[str, dict[str, dict[str, Any]]] = {
    "point2d": {"viapoint": {}, "wall": {}},
    "planar3": {"push": {"n_joints": 3}},
    "planar4": {"push": {"n_joints": 4}},
}
ROBOTS = tuple(ROBOT_TASKS)

#: Bounds on one request, so an absurd batch is refused before any work (roll-outs x steps x dims).
MAX_ELEMENTS = 20_000_000
MAX_BATCH = 10_000
#: Evaluators kept alive (each may hold a PyBullet physics client).
CACHE_SIZE = 8


def task_config_for(robot: str, task: str, task_config: dict | None) -> dict:
    """Merge a request's ``task_config`` with what robot kind ``robot`` fixes for ``task``.

    Returns the effective parameters. Raises WireError ``unknown_task`` when the robot does not
    run ``task``, ``bad_request`` when the request contradicts a fixed parameter or is not a map
    of plain values.
    """
    tasks = ROBOT_TASKS.get(robot)
    if tasks is None:
        raise WireError("bad_request", f"robot kind {robot!r} is not one of {ROBOTS}")
    if task not in tasks:
        raise WireError("unknown_task", f"a {robot} worker runs {sorted(tasks)}, not {task!r}")
    cfg = dict(task_config or {})
    for k, v in tasks[task].items():
        if k in cfg and cfg[k] != v:
            raise WireError("bad_request", f"task_config.{k}: a {robot} worker has {k}={v!r}, got {cfg[k]!r}")
        cfg[k] = v
    try:
        json.dumps(cfg, sort_keys=True)
    except (TypeError, ValueError) as exc:
        raise WireError("bad_request", f"task_config: must hold plain values ({exc})") from None
    return cfg


class Worker:
    """Executes roll-out requests for one robot kind; the zenoh-free core of the worker process.

    ``delay`` (seconds per roll-out) simulates a slow robot, for tests and benchmarks.
    """

    def __init__(self, robot: str, worker_id: str, *, delay: float = 0.0):
        if robot not in ROBOT_TASKS:
            raise ValueError(f"robot: expected one of {ROBOTS}, got {robot!r}")
        self.robot = robot
        self.worker_id = keys.check_name("worker id", worker_id)
        self.delay = float(delay)
        self._cache: OrderedDict[str, Any] = OrderedDict()
        self.rollouts = 0

    def evaluator(self, task: str, cfg: dict):
        """The cached evaluator of ``task`` with effective parameters ``cfg`` (built on first use)."""
        from acnmp_core.tasks.registry import make_task

        key = json.dumps([task, cfg], sort_keys=True)
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        try:
            ev = make_task(task, cfg)
        except ValueError as exc:
            raise WireError("bad_request", str(exc)) from None
        self._cache[key] = ev
        while len(self._cache) > CACHE_SIZE:
            _, old = self._cache.popitem(last=False)
            if hasattr(old, "close"):
                old.close()
        return ev

    def handle(self, request: dict | None) -> dict:
        """Run one decoded roll-out request and return the reply map (see the module docstring).

        Raises WireError for bad input; ValueError from the task becomes ``bad_request``.
        """
        if request is None:
            raise WireError("bad_request", "a roll-out request needs a payload")
        task = field(request, "task", str)
        cfg = task_config_for(self.robot, task, field(request, "task_config", dict, default={}))
        trajs = array_field(request, "trajectories", ndim=3, max_elements=MAX_ELEMENTS)
        b, t, _ = trajs.shape
        if b < 1 or b > MAX_BATCH or t < 2:
            raise WireError("bad_shape", f"field 'trajectories': shape {trajs.shape}, need 1<=B<={MAX_BATCH}, T>=2")
        times = array_field(request, "times", shape=(t,))
        tp = array_field(request, "task_params", ndim=1, default=None, max_elements=1024)
        ev = self.evaluator(task, cfg)
        try:
            batch = ev.evaluate(trajs.astype(np.float64), times.astype(np.float64), tp)
        except ValueError as exc:  # the task's own validation: wrong D, bad task params, ...
            raise WireError("bad_request", f"task {task!r}: {exc}") from None
        if self.delay > 0:
            time.sleep(self.delay * b)
        self.rollouts += b
        return {"v": 1, "rewards": np.asarray(batch.rewards, dtype=np.float64),
                "success": np.asarray(batch.success, dtype=bool),
                "states": {k: np.asarray(v) for k, v in batch.states.items()}, "worker": self.worker_id}

    def close(self) -> None:
        """Close every cached evaluator that holds resources (PyBullet clients)."""
        while self._cache:
            _, ev = self._cache.popitem()
            if hasattr(ev, "close"):
                ev.close()


def run(robot: str, worker_id: str | None = None, namespace: str = keys.DEFAULT_NAMESPACE, *,
        delay: float = 0.0, mode: str | None = "peer", listen: Sequence[str] | None = None,
        connect: Sequence[str] | None = None, config_file: str | None = None,
        stop: threading.Event | None = None, ready: Callable[[str], None] | None = None) -> int:
    """Serve roll-outs until ``stop`` is set (default: SIGTERM/SIGINT); return exit code 0.

    ``worker_id`` defaults to ``<robot>-<pid>``. ``ready`` gets the liveliness key once live.
    """
    if stop is None:
        stop = install_shutdown_handlers()
    import torch

    torch.set_num_threads(1)
    worker = Worker(robot, worker_id or f"{robot}-{os.getpid()}", delay=delay)
    try:
        with open_session(mode, listen, connect, config_file) as session:
            # one handler thread: requests run one after the other, PyBullet stays on one thread
            rpc = declare_rpc(session, keys.worker_rollout_key(namespace, robot, worker.worker_id),
                              lambda req, _q: worker.handle(req), workers=1)
            token_key = keys.worker_token_key(namespace, robot, worker.worker_id)
            token = session.liveliness().declare_token(token_key)
            if ready is not None:
                ready(token_key)
            wait_until_stopped(stop)
            token.undeclare()
            rpc.close()
    finally:
        worker.close()
    log.info("worker %s stopped after %d roll-outs", worker.worker_id, worker.rollouts)
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add --robot, --id, --delay and the shared session options."""
    parser.add_argument("--robot", choices=ROBOTS, default="point2d",
                        help="robot kind: point2d runs viapoint and wall, planar3/planar4 run push (default: %(default)s)")
    parser.add_argument("--id", default=None, help="worker id (default: <robot>-<pid>)")
    parser.add_argument("--delay", type=float, default=0.0, metavar="S",
                        help="sleep S seconds per roll-out, to simulate a slow robot (default: 0)")
    add_session_arguments(parser)


def run_from_args(args: argparse.Namespace) -> int:
    """Run with options parsed by :func:`add_arguments`."""
    return run(args.robot, args.id, args.namespace, delay=args.delay, **session_kwargs(args),
               ready=lambda key: print(f"worker live as {key}", flush=True))


def main(argv: list[str] | None = None) -> int:
    """``python -m services.worker --robot point2d [--id ID] [--namespace NS] [--connect EP] ...``."""
    parser = argparse.ArgumentParser(prog="acnmp serve worker", description=__doc__.splitlines()[0])
    add_arguments(parser)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s worker %(levelname)s %(message)s")
    return run_from_args(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
