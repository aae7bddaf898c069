"""An evaluator that publishes every roll-out it executes as a ``rollout`` event for the recorder.

Experiments that drive the adaptation loop themselves (E2, E3 with ``--distributed``) execute their
roll-outs through a :class:`~services.worker.remote.RemoteEvaluator`; wrapping it in a
:class:`RecordedEvaluator` puts each roll-out in the recording too, numbered per job, with the robot
drawn when its registry entry has a drawing (see :func:`services.recording.events.batch_rollout_events`).
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from acnmp_core.rollout import RolloutBatch

from .events import batch_rollout_events, job_event, robot_drawing, validate_event
from .publisher import EventPublisher


class RecordedEvaluator:
    """Wrap an evaluator; implements :class:`acnmp_core.rollout.RolloutEvaluator`.

    Parameters
    ----------
    inner : the evaluator that executes (a RemoteEvaluator, whose batches name the worker of each
        roll-out, or any evaluator: its roll-outs are recorded as run by ``"local"``).
    publisher : where the events go. job : the events' job name (one per adaptation run).
    robot : the robot kind; robots with a drawing are recorded in joint space and drawn.

    extra : fields added to every event (flat arrays or scalars), e.g. ``reference_joint_angles``
        (T, N') and ``reference_link_lengths`` (N',) to draw another arm beside a planar arm's.

    about : the fields of the ``job`` event published before the first roll-out (``method``,
        ``task``, and optionally ``seed``, ``skill``, ``config``, ``task_config``), so the recording
        says what the job ran.

    ``rollouts`` counts what has been executed and published; indices are 0, 1, ... per instance.
    """

    def __init__(self, inner, publisher: EventPublisher, job: str, robot: str,
                 extra: Mapping[str, Any] | None = None, *, about: dict | None = None):
        self.inner, self.publisher, self.job = inner, publisher, job
        self.extra = dict(extra or {})
        self.credit = getattr(inner, "credit", "step")  # adapt() reads the inner task's credit
        self.drawing = robot_drawing(robot)
        self.rollouts = 0
        # the job event published before the first roll-out: method, task, task_config, seed, ...
        self._about = None if about is None else job_event(job, robot=robot, **about)

    def evaluate(self, trajectories, times, task_params=None) -> RolloutBatch:
        """trajectories (B, T, D), times (T,), task_params (P,) or None -> the inner RolloutBatch,
        after one rollout event per trajectory has been published."""
        if self._about is not None:
            self.publisher.publish(self._about)
            self._about = None
        batch = self.inner.evaluate(trajectories, times, task_params)
        for ev in batch_rollout_events(self.job, self.rollouts, trajectories, times, batch,
                                       task_params=task_params, drawing=self.drawing):
            ev.update(self.extra)
            self.publisher.publish(validate_event(ev))
        self.rollouts += len(batch)
        return batch
