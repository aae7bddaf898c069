"""A roll-out worker process: one robot kind plus an id, executing batches of trajectories over zenoh.

Declared entities: queryable ``acnmp/<ns>/worker/<robot>/<id>/rollout`` (messages:
services/worker/core.py), then liveliness token ``acnmp/<ns>/worker/<robot>/<id>`` (the learner's
RemoteEvaluator finds workers by it). Requests are served one at a time on one thread: a worker is
one robot, and a PyBullet client must stay on the thread that uses it.
"""
from __future__ import annotations

import logging
import os
import threading
from dataclasses import dataclass
from typing import ClassVar

import zenoh

from services.transport import Keyspace, Ready, Service, declare_rpc, option, wait_until_stopped
from services.transport.about import host_name
from services.transport.argtypes import robot_help, robot_kind, seconds

from .core import Worker

log = logging.getLogger(__name__)


@dataclass
class WorkerConfig(Service):
    """A worker's options; :meth:`serve` runs it on an open session."""

    name: ClassVar[str] = "worker"
    summary: ClassVar[str] = "a roll-out worker of one robot kind"

    robot: str = option("point2d", robot_help("robot kind") + " (default: %(default)s)", type=robot_kind)
    worker_id: str | None = option(None, "worker id (default: <robot>-<pid>)", flag="--id", metavar="ID")
    delay: float = option(0.0, "sleep S seconds per roll-out, to simulate a slow robot (default: 0)", metavar="S",
                          type=seconds(zero=True))

    def serve(self, session: zenoh.Session, stop: threading.Event, ready: Ready) -> int:
        # no built-in task needs torch; a plugin's that imports it computes on one thread, since
        # a worker is one of several processes on its host
        os.environ.setdefault("OMP_NUM_THREADS", "1")
        keys = Keyspace(self.session.namespace)
        worker = Worker(self.robot, self.worker_id or f"{self.robot}-{os.getpid()}", delay=self.delay,
                        host=host_name())
        try:
            # one handler thread: requests run one after the other, PyBullet stays on one thread
            rpc = declare_rpc(session, keys.worker_rollout(self.robot, worker.worker_id),
                              lambda req, _q: worker.handle(req), workers=1)
            token_key = keys.worker_token(self.robot, worker.worker_id)
            token = session.liveliness().declare_token(token_key)
            ready(f"worker live as {token_key}")
            wait_until_stopped(stop)
            token.undeclare()
            rpc.close()
        finally:
            worker.close()
        log.info("worker %s stopped after %d roll-outs", worker.worker_id, worker.rollouts)
        return 0
