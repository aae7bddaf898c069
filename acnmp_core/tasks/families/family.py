"""A family of paths over a condition (:class:`PathFamily`) and its checkpoint task (:class:`FamilyTask`)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ...rollout import RolloutBatch
from ...validation import check_array


@dataclass(frozen=True)
class PathFamily:
    """Paths ``path(t, c)`` (T, D) over the phase ``t`` (T,) in [0, 1] and a condition ``c`` (P,).

    name : the family's name. output_names (D,), param_names (P,) : labels. path : the family.
    checkpoints : ``checkpoints(c)`` (K,) the phases its task checks a path at. tolerance : success
    radius at every checkpoint (the outputs' units). training : (P, 2) the region its
    demonstrations cover, ``demo_params`` (N, P) the demonstrations' conditions in it.
    extrapolation, interpolation : (P, 2) the boxes test conditions are drawn from, beyond and
    inside the training region. n_steps : T, the demonstrations' length.
    """

    name: str
    output_names: tuple[str, ...]
    param_names: tuple[str, ...]
    path: Callable[[np.ndarray, np.ndarray], np.ndarray]
    checkpoints: Callable[[np.ndarray], np.ndarray]
    tolerance: float
    training: np.ndarray
    demo_params: np.ndarray
    extrapolation: np.ndarray
    interpolation: np.ndarray
    n_steps: int = 100
    times: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "times", np.linspace(0.0, 1.0, self.n_steps))
        box = np.asarray(self.training, dtype=np.float64)
        demos = np.asarray(self.demo_params, dtype=np.float64)
        if np.any(demos < box[:, 0] - 1e-12) or np.any(demos > box[:, 1] + 1e-12):
            raise ValueError(f"{self.name}: demonstration conditions outside the training region {box.tolist()}")

    def demonstrations(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """times (N, T), values (N, T, D), task parameters (N, P): the family at ``demo_params``."""
        values = np.stack([self.path(self.times, c) for c in self.demo_params])
        return np.tile(self.times, (len(values), 1)), values, np.asarray(self.demo_params, dtype=np.float64).copy()

    def sample(self, case: str, rng: np.random.Generator) -> np.ndarray:
        """(P,) a condition drawn uniformly from the ``case`` box ("extrapolation": beyond the
        training region, "interpolation": inside it)."""
        box = {"extrapolation": self.extrapolation, "interpolation": self.interpolation}[case]
        box = np.asarray(box, dtype=np.float64)
        return box[:, 0] + rng.random(len(box)) * (box[:, 1] - box[:, 0])

    def task(self) -> "FamilyTask":
        """The family's checkpoint task (a :class:`~acnmp_core.rollout.RolloutEvaluator`)."""
        return FamilyTask(self)


class FamilyTask:
    """Follow the family's path at the roll-out's condition through its checkpoints.

    The per-step reward is minus the distance to the family's path at the step nearest each
    checkpoint, zero elsewhere (E1's form, :class:`~acnmp_core.tasks.viapoint.task.ViaPointTask`);
    success: every checkpoint within the family's tolerance. The executed states are the
    trajectories themselves (the family is kinematic). Implements
    :class:`~acnmp_core.rollout.RolloutEvaluator`.
    """

    def __init__(self, fam: PathFamily) -> None:
        self.family = fam

    def distances(self, trajectories, times, task_params) -> tuple[np.ndarray, np.ndarray]:
        """(B, K) the distance of each trajectory (B, T, D) to the family's path at condition
        ``task_params`` (P,) at each checkpoint, and the steps (K,) of the checkpoints."""
        fam = self.family
        trajectories = check_array("trajectories", trajectories, ndim=3, shape=(None, None, len(fam.output_names)))
        times = check_array("times", times, ndim=1, shape=(trajectories.shape[1],))
        c = check_array("task_params", task_params, shape=(len(fam.param_names),))
        phase = (times - times[0]) / (times[-1] - times[0])
        marks = np.clip(fam.checkpoints(c), 0.0, 1.0)
        steps = np.abs(phase[None, :] - marks[:, None]).argmin(axis=1)
        want = fam.path(phase[steps], c)  # (K, D)
        return np.linalg.norm(trajectories[:, steps] - want[None], axis=-1), steps

    def evaluate(self, trajectories, times, task_params=None) -> RolloutBatch:
        """trajectories (B, T, D), times (T,), the condition (P,) -> RolloutBatch with rewards (B, T)
        and errors (B,): the largest checkpoint distance."""
        dist, steps = self.distances(trajectories, times, task_params)
        trajectories = np.asarray(trajectories, dtype=np.float64)
        rewards = np.zeros(trajectories.shape[:2])
        np.add.at(rewards, (slice(None), steps), -dist)
        return RolloutBatch(rewards, np.all(dist <= self.family.tolerance, axis=1), {"path": trajectories},
                            errors=dist.max(axis=1))
