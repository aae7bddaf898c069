"""The model service's options (``acnmp serve model``, ``python -m services.model``): torch-free, so
a command line is built and checked without importing what the service runs;
:class:`~services.model.service.ModelConfig` adds what runs it (services/model/service.py)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from services.transport import Service, option
from services.transport.argtypes import device, int_at_least, seconds

#: Predict queries waiting for a handler thread before more are answered ``overloaded``.
MAX_QUEUE = 32
#: Predicts of one skill run in one forward pass at most (the service's ``--batch-max`` default).
DEFAULT_BATCH_MAX = 16
#: Seconds a batcher thread waits for more predicts once it has one (``--batch-window``, default 0:
#: it takes what is waiting, so a lone predict is never delayed; see benchmarks/performance/bench_predict.py).
DEFAULT_BATCH_WINDOW = 0.0


@dataclass
class ModelOptions(Service):
    """The model service's options; :meth:`serve` runs it on an open session."""

    name: ClassVar[str] = "model"
    summary: ClassVar[str] = "the model service: predict/info queries, hot-swapped weights"

    skills: list[str] | None = option(
        None, "serve only this skill (repeatable; default: every skill the learner publishes)",
        flag="--skill", metavar="NAME")
    checkpoints: list[str] = option(
        [], "start from a checkpoint file (acnmp_core.model.checkpoint format; skill name from SKILL=, the "
            "checkpoint's meta, or the file name). Repeatable", flag="--checkpoint", metavar="[SKILL=]FILE")
    workers: int = option(2, "threads answering predict queries with batching off (--batch-max 1); batched "
                                "predicts are computed on the --batch-threads (default: %(default)s)", metavar="N",
                          type=int_at_least(1))
    max_queue: int = option(MAX_QUEUE, "predict queries that may wait for a thread; more are answered "
                                       "'overloaded' (default: %(default)s)", metavar="N", type=int_at_least(1))
    batch_max: int = option(DEFAULT_BATCH_MAX, "concurrent predicts of one skill computed in one forward pass, "
                                               "at most N; 1 turns batching off (default: %(default)s)", metavar="N",
                            type=int_at_least(1))
    batch_window: float = option(DEFAULT_BATCH_WINDOW, "seconds to wait for more predicts to batch with the "
                                                       "first (default: %(default)s: only those already waiting)",
                                 metavar="SECONDS", type=seconds(zero=True))
    device: str = option("cpu", "where the networks run: cpu, cuda or auto (cuda when present) (default: %(default)s)",
                         type=device)
    batch_threads: int = option(1, "threads computing batched predicts; the work around a forward pass holds "
                                   "Python's GIL, so on 2 cores one is fastest (default: %(default)s)",
                                metavar="N", type=int_at_least(1))

