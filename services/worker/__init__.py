"""The worker wing: executes roll-outs of one robot kind, and the evaluator that spreads them.

========================  =========================================================
module                    one job
========================  =========================================================
``core``                  zenoh-free: :class:`Worker`, the roll-out request/reply codec,
                          :class:`ExecutedBatch` (a RolloutBatch with its worker ids)
``remote``                :class:`RemoteEvaluator`: a RolloutEvaluator over the live workers
``service``               :class:`WorkerConfig`: the worker process
========================  =========================================================
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from services.transport.lazy import lazy_exports

if TYPE_CHECKING:  # what a type checker sees; at run time the names come from __getattr__
    from .core import ExecutedBatch, Worker, batch_from_reply, rollout_reply, rollout_request
    from .remote import RemoteEvaluator
    from .service import WorkerConfig

__all__ = [
    "ExecutedBatch", "Worker", "batch_from_reply", "rollout_reply", "rollout_request", "RemoteEvaluator",
    "WorkerConfig",
]
__getattr__ = lazy_exports(__name__, {
    "ExecutedBatch": "core", "Worker": "core", "batch_from_reply": "core", "rollout_reply": "core",
    "rollout_request": "core", "RemoteEvaluator": "remote", "WorkerConfig": "service",
})
