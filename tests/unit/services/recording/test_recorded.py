"""Roll-out events built from executed batches: the robot's drawing, the worker of each roll-out,
per-roll-out task parameters (no zenoh: the publisher is a list)."""
from __future__ import annotations

import numpy as np

from acnmp_core.sim.planar_arm import DEFAULT_LINK_LENGTHS

from acnmp_core.tasks.push.task import PlanarPushTask
from acnmp_core.tasks.wall.task import WallTask
from services.recording.events import batch_rollout_events, robot_drawing
from services.recording.recorded import RecordedEvaluator
from services.worker.core import ExecutedBatch

T = 30


def _arm_trajectories(b: int) -> np.ndarray:
    """(b, T, 3) joint trajectories: a slow sweep from a folded pose, away from the cylinder."""
    base = np.array([-0.8, 1.2, -1.0])
    sweep = np.linspace(0.0, 0.3, T)[:, None] * np.array([1.0, -0.5, 0.2])
    return np.stack([base + (1 + 0.2 * i) * sweep for i in range(b)])


def _wall_trajectories(b: int) -> np.ndarray:
    """(b, T, 2) straight lines from the start (0, 5) to different heights at x = 10."""
    s = np.linspace(0, 1, T)[:, None]
    return np.stack([np.hstack([10 * s, 5 + (i - 1) * s]) for i in range(b)])


class _Collect:
    def __init__(self):
        self.events = []

    def publish(self, msg):
        self.events.append(msg)


def test_events_carry_the_executed_arm_and_object():
    task = PlanarPushTask(3)
    try:
        rec = _Collect()
        ev = RecordedEvaluator(task, rec, "push-a", "planar3")
        traj, times = _arm_trajectories(2), np.linspace(0, 1, T)
        batch = ev.evaluate(traj, times, np.array([0.4, 0.1]))
        batch2 = ev.evaluate(traj[:1], times, np.array([0.4, 0.1]))
    finally:
        task.close()
    assert [e["rollout_index"] for e in rec.events] == [0, 1, 2] and ev.rollouts == 3
    e = rec.events[1]
    assert e["space"] == "joint" and e["worker"] == "local" and e["drawing"] == "planar_chain"
    np.testing.assert_allclose(e["joint_angles"], batch.states["joint_angles"][1])
    np.testing.assert_allclose(e["object_xy"], batch.states["object_xy"][1])
    np.testing.assert_allclose(e["link_lengths"], DEFAULT_LINK_LENGTHS[3])
    np.testing.assert_allclose(e["task_params"], [0.4, 0.1])
    assert e["return"] == float(batch.rewards[1].sum())
    assert rec.events[2]["return"] == float(batch2.rewards[0].sum())


def test_per_rollout_task_params_and_no_arm_for_point_robots():
    traj = _wall_trajectories(3)
    params = np.array([[5.0, 5.0, 9.0, 5.0], [5.0, 4.0, 9.0, 6.0], [5.0, 6.0, 9.0, 5.5]])
    batch = ExecutedBatch.of(WallTask().evaluate_batch(traj, np.linspace(0, 1, T), params), ["a", "b", "c"])
    events = batch_rollout_events("w", 4, traj, np.linspace(0, 1, T), batch, task_params=params,
                                  drawing=robot_drawing("point2d"))
    assert [e["rollout_index"] for e in events] == [4, 5, 6]
    assert [e["worker"] for e in events] == ["a", "b", "c"]  # the batch says who ran each roll-out
    for e, p in zip(events, params):
        np.testing.assert_allclose(e["task_params"], p)
        assert "joint_angles" not in e and "drawing" not in e and e["space"] == "cartesian"


