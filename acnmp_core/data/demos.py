"""Demonstrations and demonstration sets.

A demonstration is a trajectory sampled at its own times: ``times`` (T_i,), ``values`` (T_i, D) and
task parameters (P,). Demonstrations may have different lengths and need not be time-aligned.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np

from ..validation import check_array


@dataclass
class Demonstration:
    """One trajectory: times (T,) strictly increasing, values (T, D), task_params (P,)."""

    times: np.ndarray
    values: np.ndarray
    task_params: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        self.times = check_array("times", self.times, ndim=1, min_size=2)
        self.values = check_array("values", self.values, ndim=2)
        self.task_params = check_array("task_params", self.task_params, ndim=1)
        if self.values.shape[0] != self.times.shape[0]:
            raise ValueError(
                f"values: expected {self.times.shape[0]} rows (one per time), got {self.values.shape[0]}"
            )
        if np.any(np.diff(self.times) <= 0):
            raise ValueError("times: expected strictly increasing times")


class DemoSet:
    """An ordered collection of demonstrations sharing D outputs and P task parameters.

    Parameters
    ----------
    demos : list of :class:`Demonstration`; at least one.
    """

    def __init__(self, demos: list[Demonstration]):
        if not demos:
            raise ValueError("demos: expected at least one demonstration")
        d0 = demos[0]
        for i, d in enumerate(demos):
            if d.values.shape[1] != d0.values.shape[1]:
                raise ValueError(
                    f"demos[{i}].values: expected {d0.values.shape[1]} output dims, got {d.values.shape[1]}"
                )
            if d.task_params.shape != d0.task_params.shape:
                raise ValueError(
                    f"demos[{i}].task_params: expected {d0.task_params.shape[0]} task parameters, "
                    f"got {d.task_params.shape[0]}"
                )
        self.demos = list(demos)

    @classmethod
    def from_arrays(cls, times, values, task_params=None) -> "DemoSet":
        """Build from arrays: times (N, T) or (T,), values (N, T, D), task_params (N, P) or None."""
        values = check_array("values", values, ndim=3)
        n, t, _ = values.shape
        times = check_array("times", times, ndim=(1, 2))
        if times.ndim == 1:
            times = np.broadcast_to(times, (n, times.shape[0]))
        if times.shape != (n, t):
            raise ValueError(f"times: expected shape ({n}, {t}) or ({t},), got {times.shape}")
        if task_params is None:
            task_params = np.zeros((n, 0))
        task_params = check_array("task_params", task_params, ndim=2)
        if task_params.shape[0] != n:
            raise ValueError(f"task_params: expected {n} rows, got {task_params.shape[0]}")
        return cls([Demonstration(times[i], values[i], task_params[i]) for i in range(n)])

    def __len__(self) -> int:
        return len(self.demos)

    def __getitem__(self, i: int) -> Demonstration:
        return self.demos[i]

    @property
    def n_outputs(self) -> int:
        return self.demos[0].values.shape[1]

    @property
    def n_task_params(self) -> int:
        return self.demos[0].task_params.shape[0]

    def added(self, demo: Demonstration) -> "DemoSet":
        """A new DemoSet with ``demo`` appended (this one is unchanged)."""
        return DemoSet(self.demos + [demo])

    def subset(self, idx) -> "DemoSet":
        """A new DemoSet with the demonstrations at indices ``idx``."""
        return DemoSet([self.demos[i] for i in idx])

    def all_times(self) -> np.ndarray:
        """(sum T_i,) every time stamp."""
        return np.concatenate([d.times for d in self.demos])

    def all_values(self) -> np.ndarray:
        """(sum T_i, D) every value."""
        return np.concatenate([d.values for d in self.demos])

    def all_task_params(self) -> np.ndarray:
        """(N, P) task parameters, one row per demonstration."""
        return np.stack([d.task_params for d in self.demos])

    def extent(self) -> float:
        """The largest per-dimension range of the values (raw units): the demos' spatial extent."""
        v = self.all_values()
        return float(np.max(v.max(axis=0) - v.min(axis=0)))

    def content_hash(self) -> str:
        """SHA-256 of every array in order: identifies the training data in a checkpoint."""
        h = hashlib.sha256()
        for d in self.demos:
            for a in (d.times, d.values, d.task_params):
                h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
                h.update(str(a.shape).encode())
        return h.hexdigest()
