"""A paired-skill training job as one typed value, and the plain-dict codec of what it carries.

:class:`PairTrainJob` is what a caller asks a learner for: train a :class:`~acnmp_core.transfer.pair.TransferPair`
on two robots' paired demonstrations with a :class:`~acnmp_core.transfer.pair.TransferConfig` and a
seed. Like :class:`~acnmp_core.jobs.adapt.AdaptJob` it is built once per process (by the client
from its arguments, by the learner from a request with :meth:`PairTrainJob.from_dict`) and
``to_dict`` gives the plain map that goes on the wire and into the learner's job record. The
dict layout is the ``train_pair`` request of docs/PROTOCOL.md::

    {"demos_a": {"times": (N, T) | (T,), "values": (N, T, D_A)},
     "demos_b": {"times": (N, T) | (T,), "values": (N, T, D_B)},
     "config": TransferConfig fields (any subset), "robot_a": str | None, "robot_b": str | None,
     "seed": int}

Every check raises a typed error of :mod:`acnmp_core.errors` naming the field.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..data.demos import DemoSet
from ..errors import InputError, ShapeError, TooLargeError
from ..robots.registry import robot as registry_robot
from ..transfer.config import PairTrainResult, TransferConfig
from ..validation import check_array, check_type

#: Bound on each robot's demonstrations (N * T * D values), as the train request's.
MAX_DEMO_VALUES = 10_000_000


def demos_to_dict(demos: DemoSet) -> dict[str, np.ndarray]:
    """``{"times": (N, T), "values": (N, T, D)}`` of demonstrations of one length T (float64)."""
    lengths = {len(d.times) for d in demos}
    if len(lengths) != 1:
        raise InputError(f"demos: expected demonstrations of one length, got lengths {sorted(lengths)}")
    return {"times": np.stack([d.times for d in demos]).astype(np.float64),
            "values": np.stack([d.values for d in demos]).astype(np.float64)}


def demos_from_dict(name: str, d: Mapping[str, Any]) -> DemoSet:
    """Inverse of :func:`demos_to_dict` (lists or arrays; ``times`` may be one row (T,) for all).

    Raises ShapeError (values not (N, T, D) with N >= 1, T >= 2; times of another shape),
    TooLargeError (over :data:`MAX_DEMO_VALUES`), NonFiniteError, InputError (missing field, times
    not increasing)."""
    check_type(name, d, Mapping)
    for key in ("times", "values"):
        if d.get(key) is None:
            raise InputError(f"{name}.{key}: missing")
    values = np.asarray(d["values"]) if not isinstance(d["values"], np.ndarray) else d["values"]
    if values.size > MAX_DEMO_VALUES:
        raise TooLargeError(f"{name}.values: {values.size} values, at most {MAX_DEMO_VALUES}")
    values = check_array(f"{name}.values", values, ndim=3)
    n, t, dim = values.shape
    if n < 1 or t < 2 or dim < 1:
        raise ShapeError(f"{name}.values: shape {values.shape}, need N >= 1, T >= 2, D >= 1")
    times = check_array(f"{name}.times", d["times"])
    if times.shape not in ((t,), (n, t)):
        raise ShapeError(f"{name}.times: expected ({t},) or ({n}, {t}), got {times.shape}")
    try:
        return DemoSet.from_arrays(times, values)
    except ValueError as exc:
        raise InputError(f"{name}: {exc}") from None


@dataclass(frozen=True)
class PairTrainJob:
    """Train a transfer pair (see the module docstring for the dict layout).

    demos_a, demos_b : robot A's and robot B's demonstrations (raw units, time the only input);
        demonstration i of one pairs with demonstration i of the other.
    config : the pair's training. seed : weight initialisation and episode sampling.
    robot_a, robot_b : the robots' registry kinds (acnmp_core/robots/registry.py), or None; they
        label the latents in the recording.
    """

    demos_a: DemoSet
    demos_b: DemoSet
    config: TransferConfig = field(default_factory=TransferConfig)
    seed: int = 0
    robot_a: str | None = None
    robot_b: str | None = None

    def __post_init__(self) -> None:
        check_type("demos_a", self.demos_a, DemoSet)
        check_type("demos_b", self.demos_b, DemoSet)
        check_type("config", self.config, TransferConfig)
        check_type("seed", self.seed, int)
        if len(self.demos_a) != len(self.demos_b):
            raise InputError(f"demos_b: expected {len(self.demos_a)} demonstrations paired with demos_a, "
                             f"got {len(self.demos_b)}")
        for name, demos in (("demos_a", self.demos_a), ("demos_b", self.demos_b)):
            if demos.n_task_params:
                raise InputError(f"{name}: a transfer pair has no task parameters (time is its only input)")
            shortest = min(len(d.times) for d in demos)
            if self.config.max_obs + 1 > shortest:  # the sampler's own bound (it trims n_targets to fit)
                raise InputError(f"config.max_obs: the shortest demonstration of {name} has {shortest} points; "
                                 f"need max_obs < {shortest}")
        for name in ("robot_a", "robot_b"):
            value = getattr(self, name)
            if value is not None:
                registry_robot(check_type(name, value, str))  # UnknownRobotError for a kind not in the registry

    @property
    def n_a(self) -> int:
        """D_A, robot A's output dimensions."""
        return self.demos_a.n_outputs

    @property
    def n_b(self) -> int:
        """D_B, robot B's output dimensions."""
        return self.demos_b.n_outputs

    def to_dict(self) -> dict[str, Any]:
        """The plain map of this job (arrays as numpy arrays)."""
        return {"demos_a": demos_to_dict(self.demos_a), "demos_b": demos_to_dict(self.demos_b),
                "config": self.config.to_dict(), "seed": self.seed, "robot_a": self.robot_a,
                "robot_b": self.robot_b}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "PairTrainJob":
        """Build and check a job from its map: ``demos_a`` and ``demos_b`` are required, the other
        fields take the defaults above; unknown top-level keys are ignored (a newer client's
        additions), unknown ``config`` keys are an error."""
        check_type("job", d, Mapping)
        for key in ("demos_a", "demos_b"):
            if d.get(key) is None:
                raise InputError(f"{key}: missing")
        return cls(demos_from_dict("demos_a", d["demos_a"]), demos_from_dict("demos_b", d["demos_b"]),
                   TransferConfig.from_dict(d.get("config") or {}), seed=d.get("seed", 0),
                   robot_a=d.get("robot_a"), robot_b=d.get("robot_b"))


@dataclass(frozen=True)
class PairJobResult:
    """What a finished pair job reports: the skill ``version`` it committed, the ``steps`` trained
    and the last step's losses (``nll_a``, ``nll_b`` normalised units; ``align`` the unweighted
    latent MSE)."""

    version: int
    steps: int
    nll_a: float | None
    nll_b: float | None
    align: float | None

    @classmethod
    def from_losses(cls, version: int, losses: PairTrainResult) -> "PairJobResult":
        """The result of a training that gave ``losses`` and was committed as ``version``."""
        def last(xs):
            return float(xs[-1]) if xs else None
        return cls(int(version), len(losses.align), last(losses.nll_a), last(losses.nll_b), last(losses.align))

    def to_dict(self) -> dict[str, Any]:
        """``{"version", "steps", "nll_a", "nll_b", "align"}``."""
        return {"version": self.version, "steps": self.steps, "nll_a": self.nll_a, "nll_b": self.nll_b,
                "align": self.align}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "PairJobResult":
        """Inverse of :meth:`to_dict`."""
        return cls(int(d["version"]), int(d["steps"]), d.get("nll_a"), d.get("nll_b"), d.get("align"))
