"""E1: obstacle avoidance with an extrapolated via-point (paper Sec. 4.1, Fig. 3 and 4).

Six demonstrations travel from a common start (0, 0) to a common end (1, 0) around two round
obstacles at (0.25, 0) and (0.75, 0), passing above or below them with different clearances. The
authors' 1-D variant keeps only the lateral coordinate as a function of time ("two bumps").
A via-point on a path wider than any demonstration is the extrapolation case.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...data.demos import DemoSet
from ...rollout import RolloutBatch
from ...validation import check_array

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


def extrapolation_conditions(variant: str = "2d", t_v: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """The conditions of the extrapolation case as the authors set them: the common start, the
    extrapolated via-point and the common end. Returns times (3,) and values (3, D)."""
    times = np.array([0.0, t_v, 1.0])
    y = two_bump(times, EXTRAPOLATION_AMPLITUDE)
    if variant == "2d":
        return times, np.stack([times, y], axis=1)
    if variant == "1d":
        return times, y[:, None]
    raise ValueError(f"variant: expected '1d' or '2d', got {variant!r}")


@dataclass
class ViaPointTask:
    """Reward for passing through via-points: implements :class:`~acnmp_core.rollout.RolloutEvaluator`.

    Parameters
    ----------
    t_v : time of each via-point, a float or (K,) array.
    point : the via-points, (D,) for one or (K, D).
    tolerance : success radius (raw units), one for all via-points or (K,) one each.

    The per-step reward is minus the Euclidean distance to a via-point at the step nearest its
    time, zero elsewhere (the authors' form). Success: every via-point is passed within
    ``tolerance``. The executed states are the trajectories themselves (a point mass follows them).
    """

    t_v: float | np.ndarray
    point: np.ndarray
    tolerance: float | np.ndarray

    def __post_init__(self) -> None:
        self.t_v = check_array("t_v", np.atleast_1d(self.t_v), ndim=1, min_size=1)
        self.point = check_array("point", np.atleast_2d(self.point), ndim=2, shape=(len(self.t_v), None))
        tol = check_array("tolerance", self.tolerance, ndim=(0, 1))
        if np.any(tol <= 0) or tol.size not in (1, len(self.t_v)):
            raise ValueError(f"tolerance: expected one positive value or {len(self.t_v)}, got {tol}")
        self.tolerance = float(tol) if tol.size == 1 and tol.ndim == 0 else tol

    def distances(self, trajectories, times) -> np.ndarray:
        """(B, K) distance of each trajectory (B, T, D) to each via-point at its nearest step."""
        trajectories = check_array("trajectories", trajectories, ndim=3, shape=(None, None, self.point.shape[1]))
        times = check_array("times", times, ndim=1, shape=(trajectories.shape[1],))
        idx = self._steps(times)
        return np.linalg.norm(trajectories[:, idx] - self.point[None], axis=-1)

    def errors(self, trajectories, times) -> np.ndarray:
        """(B,) the largest via-point distance of each trajectory (B, T, D)."""
        return self.distances(trajectories, times).max(axis=1)

    def _steps(self, times: np.ndarray) -> np.ndarray:
        return np.abs(times[None, :] - self.t_v[:, None]).argmin(axis=1)

    def evaluate(self, trajectories, times, task_params=None) -> RolloutBatch:
        """trajectories (B, T, D), times (T,) -> RolloutBatch with rewards (B, T)."""
        dist = self.distances(trajectories, times)
        trajectories = np.asarray(trajectories, dtype=np.float64)
        rewards = np.zeros(trajectories.shape[:2])
        np.add.at(rewards, (slice(None), self._steps(np.asarray(times, dtype=np.float64))), -dist)
        return RolloutBatch(rewards, np.all(dist <= self.tolerance, axis=1), {"path": trajectories},
                            errors=dist.max(axis=1))


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
