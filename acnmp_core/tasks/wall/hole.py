"""E3's wall with the hole's position as the condition, for the comparison of record.

The paper's E3 environment (:mod:`.task`: start (0, 5), a wall of thickness 0.2 with a hole 1.0
wide, the authors' reward) with the goal fixed at :data:`GOAL` and the hole's centre ``(x_c, y_c)``
as the task parameters. Sixteen demonstrations (E3's own generator, :func:`~.task.demonstrate`,
with its random variation) cross holes on a 4 x 4 grid of the training region; the extrapolated
holes lie beyond one of its corners (``x_c`` 0.4-1.0 and ``y_c`` 0.6-1.6 beyond it, the corner drawn
per seed), the interpolated ones inside. The demonstrations are sampled at equal arc length, so the time the
wall is crossed, and every point's height, move non-linearly with the hole.
"""
from __future__ import annotations

import numpy as np

from ...rollout import RolloutBatch
from ...validation import check_array
from .task import WallTask, demonstrate, wall_success

#: the goal every path ends at (world units)
GOAL = (9.0, 5.0)
#: the training region of the hole's centre: x_c, y_c (world units)
TRAINING = np.array([[3.0, 6.0], [3.0, 7.0]])
#: how far beyond the training region an extrapolated hole's x_c and y_c lie (world units)
BEYOND = ((0.4, 1.0), (0.6, 1.6))
#: the demonstrations' random variation (E3's) comes from this seed
DEMO_SEED = 3
N_STEPS = 100
PARAM_NAMES = ("x_c", "y_c")


def demo_conditions() -> np.ndarray:
    """(16, 2) the demonstrations' hole centres: a 4 x 4 grid over :data:`TRAINING`."""
    xs, ys = (np.linspace(lo, hi, 4) for lo, hi in TRAINING)
    return np.array([(x, y) for x in xs for y in ys])


def full_params(hole) -> np.ndarray:
    """(4,) E3's task parameters ``(x_c, y_c, x_g, y_g)`` of a hole centre (2,)."""
    return np.concatenate([check_array("hole", hole, shape=(2,)), GOAL])


def hole_demos() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """times (16, T), values (16, T, 2) positions, task parameters (16, 2): E3's demonstrations
    through the holes of :func:`demo_conditions`, with its random variation (seed :data:`DEMO_SEED`)."""
    rng = np.random.default_rng(DEMO_SEED)
    conds = demo_conditions()
    paths = [demonstrate(full_params(c), N_STEPS, rng) for c in conds]
    return np.stack([p[0] for p in paths]), np.stack([p[1] for p in paths]), conds


def expert_path(hole) -> np.ndarray:
    """(T, 2) E3's demonstration without variation (through the hole's centre) for ``hole`` (2,)."""
    return demonstrate(full_params(hole), N_STEPS)[1]


def sample_hole(case: str, rng: np.random.Generator) -> np.ndarray:
    """(2,) a hole centre: "extrapolation" beyond a corner of the training region (the corner and
    the distances drawn, :data:`BEYOND`); "interpolation" inside it, 0.3 from its edges. Drawn
    until E3's expert solves it (every one does: the check keeps the promise)."""
    while True:
        if case == "extrapolation":
            hole = np.array([hi + rng.uniform(*d) if rng.random() < 0.5 else lo - rng.uniform(*d)
                             for (lo, hi), d in zip(TRAINING, BEYOND)])
        else:
            hole = np.array([rng.uniform(lo + 0.3, hi - 0.3) for lo, hi in TRAINING])
        if wall_success(expert_path(hole)[None], full_params(hole))[0]:
            return hole


class HoleTask:
    """E3's :class:`~.task.WallTask` with the goal fixed: task parameters are the hole's centre
    (2,). Implements :class:`~acnmp_core.rollout.RolloutEvaluator`."""

    def __init__(self) -> None:
        self.wall = WallTask()

    def evaluate(self, trajectories, times, task_params=None) -> RolloutBatch:
        """trajectories (B, T, 2), times (T,), the hole's centre (2,) -> E3's RolloutBatch."""
        if task_params is None:
            raise ValueError("task_params: the wall task needs the hole's centre (x_c, y_c), got None")
        return self.wall.evaluate(trajectories, times, full_params(task_params))
