"""E1: obstacle avoidance with an extrapolated via-point (paper Sec. 4.1, Fig. 3 and 4).

Six demonstrations travel from a common start (0, 0) to a common end (1, 0) around two round
obstacles at (0.25, 0) and (0.75, 0), passing above or below them with different clearances. The
authors' 1-D variant keeps only the lateral coordinate as a function of time ("two bumps").
A via-point on a path wider than any demonstration is the extrapolation case.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..data import DemoSet
from ..rollout import RolloutBatch
from ..validation import check_array

#: Lateral amplitudes of the six demonstrations (the authors' values).
DEMO_AMPLITUDES = (0.2, 0.4, 0.6, -0.2, -0.4, -0.6)
#: Amplitude of the path the extrapolated via-point lies on (the authors' seventh value).
EXTRAPOLATION_AMPLITUDE = 0.8
OBSTACLES = ((0.25, 0.0), (0.75, 0.0))
OBSTACLE_RADIUS = 0.1
BUMP_WIDTH = 0.15


def two_bump(s: np.ndarray, amplitude: float) -> np.ndarray:
    """Lateral offset at progress ``s`` (any shape, in [0, 1]) of a path with ``amplitude``:
    two Gaussian bumps over the obstacles, about zero at both ends."""
    g = lambda c: np.exp(-((s - c) ** 2) / (2 * BUMP_WIDTH**2))  # noqa: E731
    return amplitude * (g(0.25) + g(0.75) - 0.25)


def _progress(t: np.ndarray, k: int) -> np.ndarray:
    """Progress along x of demo k: monotone in t, 0 -> 1, each demo with its own timing so the
    demonstrations are not time-aligned in x."""
    warp = 0.06 * np.sin(np.pi * t) * (1 if k % 2 == 0 else -1) * (1 + k % 3) / 3
    return t + warp


def obstacle_demos(n_steps: int = 100, amplitudes=DEMO_AMPLITUDES) -> DemoSet:
    """The 2-D demonstrations: times (T,) in [0, 1] s, values (T, 2) = (x, y) in metres."""
    t = np.linspace(0.0, 1.0, n_steps)
    vals = []
    for k, a in enumerate(amplitudes):
        s = _progress(t, k)
        vals.append(np.stack([s, two_bump(s, a)], axis=1))
    return DemoSet.from_arrays(t, np.stack(vals))


def two_bump_demos(n_steps: int = 100, amplitudes=DEMO_AMPLITUDES) -> DemoSet:
    """The authors' 1-D variant: times (T,) in [0, 1], values (T, 1) = the lateral offset."""
    t = np.linspace(0.0, 1.0, n_steps)
    return DemoSet.from_arrays(t, np.stack([two_bump(t, a)[:, None] for a in amplitudes]))


def extrapolated_viapoint(variant: str = "2d", t_v: float = 0.25) -> tuple[float, np.ndarray]:
    """(t_v, point (D,)) on the path of amplitude EXTRAPOLATION_AMPLITUDE, outside every demo."""
    y = float(two_bump(np.asarray(t_v), EXTRAPOLATION_AMPLITUDE))
    if variant == "2d":
        return t_v, np.array([t_v, y])
    if variant == "1d":
        return t_v, np.array([y])
    raise ValueError(f"variant: expected '1d' or '2d', got {variant!r}")


@dataclass
class ViaPointTask:
    """Reward for passing a via-point: implements :class:`~acnmp_core.rollout.RolloutEvaluator`.

    The per-step reward is minus the Euclidean distance to ``point`` (raw units) at the step
    nearest ``t_v``, zero elsewhere. Success: that distance is at most ``tolerance``.
    The executed states are the trajectories themselves (a point mass follows them exactly).
    """

    t_v: float
    point: np.ndarray
    tolerance: float

    def __post_init__(self) -> None:
        self.point = check_array("point", self.point, ndim=1, min_size=1)
        if not self.tolerance > 0:
            raise ValueError(f"tolerance: expected > 0, got {self.tolerance}")

    def errors(self, trajectories: np.ndarray, times: np.ndarray) -> np.ndarray:
        """(B,) distance of each trajectory (B, T, D) at the step nearest t_v to the via-point."""
        trajectories = check_array("trajectories", trajectories, ndim=3, shape=(None, None, len(self.point)))
        times = check_array("times", times, ndim=1, shape=(trajectories.shape[1],))
        i = int(np.argmin(np.abs(times - self.t_v)))
        return np.linalg.norm(trajectories[:, i] - self.point, axis=-1)

    def evaluate(self, trajectories, times, task_params=None) -> RolloutBatch:
        """trajectories (B, T, D), times (T,) -> RolloutBatch with rewards (B, T)."""
        err = self.errors(trajectories, times)
        times = np.asarray(times, dtype=np.float64)
        rewards = np.zeros(np.asarray(trajectories).shape[:2])
        rewards[:, int(np.argmin(np.abs(times - self.t_v)))] = -err
        return RolloutBatch(rewards, err <= self.tolerance, {"path": np.asarray(trajectories, dtype=np.float64)})


def shape_error(trajectory: np.ndarray, times: np.ndarray, demos: DemoSet) -> float:
    """How far a trajectory's shape departs from the demonstrations (raw units, RMS per value).

    The demonstrations are resampled at ``times``; the trajectory minus their mean is projected by
    least squares onto the span of the demonstrations' deviations from that mean. The RMS of what
    is left over is the shape error: zero for any linear combination of the demonstrations (a
    wider or narrower copy of their shape), large for wiggles or drifts that no demonstration has.

    trajectory (T, D), times (T,) -> float.
    """
    trajectory = check_array("trajectory", trajectory, ndim=2)
    times = check_array("times", times, ndim=1, shape=(trajectory.shape[0],))
    basis = np.stack(
        [np.stack([np.interp(times, d.times, d.values[:, j]) for j in range(d.values.shape[1])], 1) for d in demos]
    ).reshape(len(demos), -1)  # (N, T*D)
    mean = basis.mean(axis=0)
    dev = (basis - mean).T  # (T*D, N)
    target = trajectory.reshape(-1) - mean
    coef, *_ = np.linalg.lstsq(dev, target, rcond=None)
    resid = target - dev @ coef
    return float(np.sqrt(np.mean(resid**2)))
