"""The one interface through which every roll-out is evaluated.

In-process tasks, PyBullet robots and remote workers all implement :class:`RolloutEvaluator`, so the
adaptation code never knows where a trajectory is executed.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Protocol, Self, runtime_checkable

import numpy as np

from .errors import TooLargeError
from .validation import check_array

#: The largest magnitude a roll-out may report in any number (rewards, returns, errors, states):
#: beyond every task's scale, and small enough that what the adaptation computes from them
#: (returns, differences, squares and their sums over a batch: advantages and their std) stays
#: finite. A worker answering rewards of -1e308 (finite) made a job's summed return -inf
#: (issue 66): such a batch is refused where it enters, naming the field.
MAX_MAGNITUDE = 1e150


def check_magnitude(name: str, arr: np.ndarray) -> np.ndarray:
    """``arr`` (finite) if every element is at most :data:`MAX_MAGNITUDE` in magnitude, else
    :class:`~acnmp_core.errors.TooLargeError` naming ``name`` and the largest element."""
    if arr.size and arr.dtype.kind == "f":
        largest = float(np.max(np.abs(arr)))
        if largest > MAX_MAGNITUDE:
            raise TooLargeError(f"{name}: a value of magnitude {largest:.3g} is beyond {MAX_MAGNITUDE:g}, "
                                "no task's number")
    return arr


@dataclass
class RolloutBatch:
    """Outcome of executing a batch of B trajectories of T steps.

    Attributes
    ----------
    rewards : (B, T) float64
        Per-step reward; the return of a roll-out is ``rewards.sum(axis=1)``. Every reward, return,
        error and state is finite and at most :data:`MAX_MAGNITUDE` in magnitude (else ValueError:
        :class:`~acnmp_core.errors.NonFiniteError` or :class:`~acnmp_core.errors.TooLargeError`).
    success : (B,) bool
        Whether each roll-out satisfies the task's success criterion.
    states : dict of str -> (B, T, ...) arrays
        Executed states (e.g. joint angles, end-effector and object positions), task-specific.
    errors : (B,) float64 or None
        The task's remaining error per roll-out in its own units (what its success tolerance
        bounds, e.g. metres from a via-point); None when the task does not report one.
    """

    rewards: np.ndarray
    success: np.ndarray
    states: dict[str, np.ndarray] = field(default_factory=dict)
    errors: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.rewards = check_magnitude("rewards", check_array("rewards", self.rewards, ndim=2))
        check_magnitude("returns", self.rewards.sum(axis=1))
        b = self.rewards.shape[0]
        self.success = np.asarray(self.success, dtype=bool).reshape(-1)
        if self.success.shape != (b,):
            raise ValueError(f"success: expected shape ({b},), got {self.success.shape}")
        if self.errors is not None:
            self.errors = check_magnitude("errors", check_array("errors", self.errors, shape=(b,)))
        for name, value in self.states.items():
            arr = np.asarray(value)
            if arr.dtype.kind == "f":
                check_magnitude(f"states[{name!r}]", check_array(f"states[{name!r}]", arr, dtype=arr.dtype))
            if arr.ndim < 1 or arr.shape[0] != b:
                raise ValueError(f"states[{name!r}]: expected {b} roll-outs along its first axis, got shape {arr.shape}")

    @property
    def returns(self) -> np.ndarray:
        """(B,) sum of per-step rewards."""
        return self.rewards.sum(axis=1)

    def remaining_errors(self) -> np.ndarray:
        """(B,) the task's remaining error per roll-out: ``errors`` when the task reports them,
        else minus the return (for rewards that are minus distances)."""
        return self.errors if self.errors is not None else -self.returns

    def __len__(self) -> int:
        return self.rewards.shape[0]

    @staticmethod
    def concat(batches: list["RolloutBatch"]) -> "RolloutBatch":
        """Concatenate batches along the roll-out axis (states: keys common to all batches; errors
        only when every batch has them). Batches of one subclass give that subclass, its own
        fields (per-roll-out sequences of length B, e.g. the worker of each roll-out) joined too."""
        if not batches:
            raise ValueError("batches: expected at least one RolloutBatch")
        keys = set(batches[0].states)
        for b in batches[1:]:
            keys &= set(b.states)
        base = dict(
            rewards=np.concatenate([b.rewards for b in batches]),
            success=np.concatenate([b.success for b in batches]),
            states={k: np.concatenate([b.states[k] for b in batches]) for k in sorted(keys)},
            errors=(np.concatenate([b.errors for b in batches])
                    if all(b.errors is not None for b in batches) else None),
        )
        kind = type(batches[0])
        if kind is RolloutBatch or any(type(b) is not kind for b in batches):
            return RolloutBatch(**base)
        extra = {f.name: tuple(x for b in batches for x in getattr(b, f.name))
                 for f in fields(kind) if f.name not in base}
        return kind(**base, **extra)


@runtime_checkable
class RolloutEvaluator(Protocol):
    """Executes trajectories and scores them.

    ``evaluate(trajectories, times, task_params)`` takes trajectories (B, T, D) in the task's raw
    units, their times (T,) and the task parameters (P,) (empty when the task has none), and returns
    a :class:`RolloutBatch` with B roll-outs in the same order.
    """

    def evaluate(
        self, trajectories: np.ndarray, times: np.ndarray, task_params: np.ndarray | None = None
    ) -> RolloutBatch: ...


class ClosedAtExit:
    """An evaluator that holds a simulator: ``with task:`` calls :meth:`close` at the end, which
    frees what the subclass holds (its ``close``)."""

    def close(self) -> None:
        """Free the simulator (the subclass says what)."""

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
