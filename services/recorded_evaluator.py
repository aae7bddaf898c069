"""An evaluator that publishes every roll-out it executes as a ``rollout`` event for the recorder.

Experiments that drive the adaptation loop themselves (E2, E3 with ``--distributed``) execute their
roll-outs through a :class:`~services.remote_evaluator.RemoteEvaluator`; wrapping it in a
:class:`RecordedEvaluator` puts each roll-out in the recording too, numbered per job, with the arm
and the object when the robot is a planar arm (see :func:`services.events.batch_rollout_events`).
"""
from __future__ import annotations

from acnmp_core.rollout import RolloutBatch
from services.events import EventPublisher, arm_drawing, batch_rollout_events


class RecordedEvaluator:
    """Wrap an evaluator; implements :class:`acnmp_core.rollout.RolloutEvaluator`.

    Parameters
    ----------
    inner : the evaluator that executes (a RemoteEvaluator, or any evaluator; worker ids are read
        from its ``last_workers`` when it has them, else ``"local"``).
    publisher : where the events go. job : the events' job name (one per adaptation run).
    robot : the robot kind; planar arms are recorded in joint space with the arm drawn.

    ``rollouts`` counts what has been executed and published; indices are 0, 1, ... per instance.
    """

    def __init__(self, inner, publisher: EventPublisher, job: str, robot: str):
        self.inner, self.publisher, self.job = inner, publisher, job
        self.arm = arm_drawing(robot)
        self.rollouts = 0

    def evaluate(self, trajectories, times, task_params=None) -> RolloutBatch:
        """trajectories (B, T, D), times (T,), task_params (P,) or None -> the inner RolloutBatch,
        after one rollout event per trajectory has been published."""
        batch = self.inner.evaluate(trajectories, times, task_params)
        n = len(batch.rewards)
        workers = list(getattr(self.inner, "last_workers", None) or ["local"] * n)
        for ev in batch_rollout_events(self.job, self.rollouts, trajectories, times, batch, workers,
                                       task_params=task_params, arm=self.arm):
            self.publisher.publish(ev)
        self.rollouts += n
        return batch
