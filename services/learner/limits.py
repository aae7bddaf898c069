"""Server-side limits on what one train or adapt request may cost the learner.

The learner runs one training and one job at a time: a request with ``steps: 10**9`` would hold it
for good. Every bound here is checked when the request arrives, from its settings alone (nothing
is trained or allocated first), and refused with ``too_large`` naming the setting and the limit
(docs/PROTOCOL.md, "Limits of the learner"). The defaults are generous for the paper's experiments
(E1 trains 3000 steps; an E1 job makes ~6 500 updates) and can be raised per learner
(:class:`LearnerLimits` is a field of the learner's config).

:class:`StateLimits` bounds what the learner keeps over time: unfinished jobs (a new one beyond
the limit is refused with ``busy``), finished job records (by count and age) and checkpoints per
skill.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from typing import TYPE_CHECKING

from services.transport.wire import WireError
from services.worker.core import MAX_BATCH as WORKER_MAX_BATCH
from services.worker.core import MAX_ELEMENTS as WORKER_MAX_ELEMENTS

if TYPE_CHECKING:  # the learner's options read the defaults below without importing torch
    from acnmp_core.jobs.adapt import AdaptJob
    from acnmp_core.jobs.transfer import PairTrainJob
    from acnmp_core.model.cnmp import CNMPConfig
    from acnmp_core.model.training import TrainConfig


@dataclass(frozen=True)
class LearnerLimits:
    """Bounds on one request (all counts; see the module docstring).

    max_train_steps : ``train.steps`` of a train request, and an adapt request's ``assimilate_steps``.
    max_batch_size : ``train.batch_size`` and ``config.sl_batch_size``.
    max_step_points : points through the network per training step, batch_size * (max_obs + n_targets).
    max_train_points : points of a whole training, steps * batch_size * (max_obs + n_targets).
    max_val_episodes : ``train.val_episodes``.
    max_rollouts : ``config.max_rollouts`` of an adaptation job.
    max_adapt_updates : an upper bound on a job's network updates, iterations * (sl_steps +
        (max_reuse + 1) * (sl_steps_reuse + 1)) with iterations = ceil(max_rollouts / (noisy_per_iter + 1)).
    """

    max_train_steps: int = 100_000
    max_batch_size: int = 1024
    max_step_points: int = 1_000_000
    max_train_points: int = 50_000_000
    max_val_episodes: int = 10_000
    max_rollouts: int = 10_000
    max_adapt_updates: int = 200_000


def _refuse(setting: str, value: int, limit: int) -> None:
    if value > limit:
        raise WireError("too_large", f"{setting}: {value}, at most {limit} on this learner")


def check_train(model: CNMPConfig, train: TrainConfig, limits: LearnerLimits) -> None:
    """Refuse a training whose model or cost is over ``limits`` (WireError ``too_large``)."""
    from services.model.weights import MAX_PARAMETERS

    _refuse("model: parameters (from encoder_widths, decoder_widths)", model.n_parameters, MAX_PARAMETERS)
    check_steps("train.steps", train.steps, limits)
    _refuse("train.batch_size", train.batch_size, limits.max_batch_size)
    _refuse("train.val_episodes", train.val_episodes, limits.max_val_episodes)
    per_episode = train.max_obs + train.n_targets
    _refuse("train: points per step, batch_size * (max_obs + n_targets)", train.batch_size * per_episode,
            limits.max_step_points)
    _refuse("train: points in all, steps * batch_size * (max_obs + n_targets)",
            train.steps * train.batch_size * per_episode, limits.max_train_points)


def check_steps(setting: str, steps: int, limits: LearnerLimits) -> None:
    """Refuse ``steps`` training steps over ``limits.max_train_steps`` (WireError ``too_large``)."""
    _refuse(setting, steps, limits.max_train_steps)


def check_job(job: AdaptJob, limits: LearnerLimits) -> None:
    """Refuse an adaptation job whose budget or batches are over ``limits`` (WireError ``too_large``)."""
    cfg = job.config
    _refuse("config.max_rollouts", cfg.max_rollouts, limits.max_rollouts)
    _refuse("config.sl_batch_size", cfg.sl_batch_size, limits.max_batch_size)
    check_steps("assimilate_steps", job.assimilate_steps, limits)
    batch = cfg.noisy_per_iter + 1
    _refuse("config.noisy_per_iter + 1 (roll-outs per batch)", batch, WORKER_MAX_BATCH)
    values = batch * len(job.target.query_times) * job.target.obs_values.shape[1]
    _refuse("roll-outs per batch * query steps * dimensions", values, WORKER_MAX_ELEMENTS)
    iterations = math.ceil(cfg.max_rollouts / batch)
    updates = iterations * (cfg.sl_steps + (cfg.max_reuse + 1) * (cfg.sl_steps_reuse + 1))
    _refuse("config: updates, ceil(max_rollouts / (noisy_per_iter + 1)) * "
            "(sl_steps + (max_reuse + 1) * (sl_steps_reuse + 1))", updates, limits.max_adapt_updates)


def check_pair(job: PairTrainJob, limits: LearnerLimits) -> None:
    """Refuse a paired skill's training whose models or cost are over ``limits`` (WireError
    ``too_large``): each robot's CNMP as a train request's model, and the training counted for
    both robots (every step draws an episode of each)."""
    from acnmp_core.model.cnmp import CNMPConfig
    from services.model.weights import MAX_PARAMETERS

    cfg = job.config
    for side, n in (("a", job.n_a), ("b", job.n_b)):
        model = CNMPConfig(n, 0, cfg.widths, cfg.widths)
        _refuse(f"config.widths: parameters of robot {side.upper()}'s model", model.n_parameters, MAX_PARAMETERS)
    check_steps("config.steps", cfg.steps, limits)
    _refuse("config.batch_size", cfg.batch_size, limits.max_batch_size)
    per_step = 2 * cfg.batch_size * (cfg.max_obs + cfg.n_targets)
    _refuse("config: points per step, 2 * batch_size * (max_obs + n_targets)", per_step, limits.max_step_points)
    _refuse("config: points in all, steps * 2 * batch_size * (max_obs + n_targets)", cfg.steps * per_step,
            limits.max_train_points)


@dataclass(frozen=True)
class StateLimits:
    """Bounds on what the learner keeps (docs/STATE.md).

    max_queued_jobs : unfinished jobs (queued, running, interrupted) the learner holds; a new job
        beyond it is refused with ``busy`` (nothing is written). One learner serves a deployment,
        so this is the deployment's bound.
    keep_finished_jobs : finished jobs (done, failed, cancelled) whose records are kept; older ones
        are removed as new ones finish.
    keep_finished_days : a finished job's record is removed this many days after its last change.
    keep_versions : checkpoints kept per skill (the newest; an unreadable newest falls back to the
        one before).
    """

    max_queued_jobs: int = 100
    keep_finished_jobs: int = 1000
    keep_finished_days: float = 30.0
    keep_versions: int = 3

    def __post_init__(self) -> None:
        if self.max_queued_jobs < 1 or self.keep_finished_jobs < 0 or self.keep_finished_days < 0 \
                or self.keep_versions < 1:
            raise ValueError(f"state limits: inconsistent settings {self}")


def busy_message(limit: int) -> str:
    """The message of a ``busy`` refusal: the learner already holds ``limit`` unfinished jobs."""
    return (f"the learner already holds {limit} unfinished jobs, its limit (--max-queued-jobs {limit}); "
            "nothing was queued: send it again once some have finished")
