"""A recording audits itself: run its roll-outs again and compare the returns.

Every roll-out of a job whose ``job`` event names its robot, task and task configuration is
executed again, in this process (the robot kind's own evaluator, as a worker builds it) or on a
deployment's workers (any :class:`~acnmp_core.rollout.RolloutEvaluator` factory), with the recorded
trajectory, times and task parameters. The project's robots are deterministic, so the returns are
equal; a difference means the recording, the robot or the task changed.
"""
from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from acnmp_core.robots.registry import robot as robot_spec
from acnmp_core.rollout import RolloutEvaluator

from .tables import RecordingTables

__all__ = ["Reexecution", "local_evaluator", "reexecute"]


@dataclass(frozen=True)
class Reexecution:
    """One roll-out run again: its job and index, the recorded and the re-executed return and
    success."""

    job: str
    attempt: int
    rollout_index: int
    recorded_return: float
    return_now: float
    recorded_success: bool
    success_now: bool

    @property
    def equal(self) -> bool:
        """The same return (bit for bit) and the same success."""
        return self.recorded_return == self.return_now and self.recorded_success == self.success_now


def local_evaluator(robot: str, task: str, task_config: dict) -> RolloutEvaluator:
    """The evaluator a worker of ``robot`` builds for ``task`` with ``task_config``, in this process."""
    spec = robot_spec(robot)
    return spec.make_evaluator(task, spec.task_config(task, task_config))


def reexecute(tables: RecordingTables, *, job: str | None = None, limit: int | None = None,
              evaluator_for: Callable[[str, str, dict], RolloutEvaluator] = local_evaluator,
              on_done: Callable[[Reexecution], None] | None = None) -> tuple[list[Reexecution], dict[str, str]]:
    """Run the roll-outs of ``tables`` (of ``job`` only; at most ``limit`` per job) again.

    ``evaluator_for(robot, task, task_config)`` builds an evaluator per job (default: in this
    process). Returns (one :class:`Reexecution` per roll-out, in recording order; ``{job: why}``
    for the jobs that could not be run again: no job event, data recorded before 0.2, an unknown
    robot kind or task). ``on_done`` is called after each roll-out (a progress bar).
    """
    about = {row["job"]: row for row in tables.jobs.to_pylist()}
    by_job: dict[str, list[dict]] = defaultdict(list)
    for row in tables.rollout_rows(job):
        by_job[row["job"]].append(row)
    results: list[Reexecution] = []
    skipped: dict[str, str] = {}
    for name, rows in by_job.items():
        described = about.get(name)
        if described is None or not described.get("robot") or not described.get("task"):
            skipped[name] = "no job event (robot, task and configuration unknown)"
            continue
        if any(r["trajectory"] is None for r in rows):
            skipped[name] = "recorded without its data (a recording older than 0.2)"
            continue
        try:
            task_config = json.loads(described["task_config"]) if described.get("task_config") else {}
            evaluator = evaluator_for(described["robot"], described["task"], task_config)
        except (ValueError, KeyError) as exc:
            skipped[name] = str(exc)
            continue
        try:
            for row in rows[:limit]:
                tp = row["task_params"]
                batch = evaluator.evaluate(row["trajectory"][None], row["times"], None if tp is None or not len(tp) else tp)
                again = Reexecution(name, row["attempt"], row["rollout_index"], float(row["return"]),
                                    float(np.sum(batch.rewards[0])), bool(row["success"]), bool(batch.success[0]))
                results.append(again)
                if on_done is not None:
                    on_done(again)
        finally:
            if hasattr(evaluator, "close"):
                evaluator.close()
    return results, skipped
