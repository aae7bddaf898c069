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
from .core import ExecutedBatch, Worker, batch_from_reply, rollout_reply, rollout_request
from .remote import RemoteEvaluator
from .service import WorkerConfig

__all__ = ["ExecutedBatch", "Worker", "batch_from_reply", "rollout_reply", "rollout_request",
           "RemoteEvaluator", "WorkerConfig"]
