"""An adaptation job as one typed value, and the plain-dict codec of everything it carries.

:class:`AdaptJob` is what a caller asks for: adapt a skill to an :class:`AdaptTarget` on a task
run by a robot kind, with an :class:`AdaptConfig`, a seed, and whether to assimilate the solution.
It is built once per process — by the client from its arguments, by the learner from a request
(:meth:`AdaptJob.from_dict`) — and passed as it is from there on; ``to_dict`` gives the plain map
that goes on the wire (numpy arrays as they are; the wire codec encodes them) and, through one
JSON helper, into the learner's job record. The result travels back the same way
(:func:`result_to_dict` / :func:`result_from_dict`).

The dict layout is the adapt request of docs/PROTOCOL.md::

    {"target": {"obs_times": (N,), "obs_values": (N, D), "task_params": (P,) | None,
                "query_times": (T,), "obs_dims_mask"?: (N, D) bool},
     "task": str, "task_config": map, "robot": str, "config": AdaptConfig fields (any subset),
     "seed": int, "commit": bool, "assimilate_steps": int}

Every check raises a typed error of :mod:`acnmp_core.errors` naming the field.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..adaptation.config import AdaptConfig, AdaptResult, AdaptTarget, AssimilationConfig, IterationLog
from ..errors import InputError, TooLargeError
from ..robots.registry import robot
from ..validation import check_array, check_positive_int, check_type

#: Bounds on a job's target, so an absurd request is refused before any work.
MAX_OBS = 10_000
MAX_OBS_VALUES = 1_000_000
MAX_QUERY_STEPS = 100_000
MAX_TASK_PARAMS = 1024
#: Training steps after a solution joins the demonstrations, when the job does not say.
DEFAULT_ASSIMILATE_STEPS = AssimilationConfig().steps


def _bounded(name: str, value, limit: int, **checks) -> np.ndarray:
    arr = check_array(name, value, **checks)
    if arr.size > limit:
        raise TooLargeError(f"{name}: {arr.size} values, at most {limit}")
    return arr


def check_target(target: AdaptTarget) -> AdaptTarget:
    """``target`` with float64 arrays, checked for shapes, finiteness and size (typed errors)."""
    obs_t = _bounded("target.obs_times", target.obs_times, MAX_OBS, ndim=1)
    obs_v = _bounded("target.obs_values", target.obs_values, MAX_OBS_VALUES, shape=(obs_t.shape[0], None))
    tp = None if target.task_params is None else _bounded("target.task_params", target.task_params,
                                                          MAX_TASK_PARAMS, ndim=1)
    q_t = _bounded("target.query_times", target.query_times, MAX_QUERY_STEPS, ndim=1, min_size=1)
    mask = None if target.obs_dims_mask is None else check_array(
        "target.obs_dims_mask", target.obs_dims_mask, shape=obs_v.shape, dtype=bool)
    return AdaptTarget(obs_t, obs_v, tp, q_t, mask)


def target_to_dict(target: AdaptTarget) -> dict[str, Any]:
    """The target's plain map (arrays as they are); ``obs_dims_mask`` only when set."""
    out = {"obs_times": target.obs_times, "obs_values": target.obs_values, "task_params": target.task_params,
           "query_times": target.query_times}
    if target.obs_dims_mask is not None:
        out["obs_dims_mask"] = target.obs_dims_mask
    return out


def target_from_dict(d: Mapping[str, Any]) -> AdaptTarget:
    """Inverse of :func:`target_to_dict` (lists or arrays), checked by :func:`check_target`."""
    check_type("target", d, Mapping)
    try:
        return check_target(AdaptTarget(d["obs_times"], d["obs_values"], d.get("task_params"), d["query_times"],
                                        d.get("obs_dims_mask")))
    except KeyError as exc:
        raise InputError(f"target: missing field {exc.args[0]!r}") from None


def result_to_dict(result: AdaptResult) -> dict[str, Any]:
    """``{"success", "rollouts", "trajectory" (T, D), "times" (T,), "history": [IterationLog fields]}``."""
    return {"success": bool(result.success), "rollouts": int(result.rollouts),
            "trajectory": np.asarray(result.trajectory, dtype=np.float64),
            "times": np.asarray(result.times, dtype=np.float64),
            "history": [dataclasses.asdict(h) for h in result.history]}


#: Values for IterationLog fields that job records written before the full log was kept lack.
_LEGACY_HISTORY = {"noisy_returns": [], "explore_std": []}


def result_from_dict(d: Mapping[str, Any]) -> AdaptResult:
    """Inverse of :func:`result_to_dict` (lists or arrays); unknown history fields are dropped."""
    names = {f.name for f in dataclasses.fields(IterationLog)}
    history = [IterationLog(**{**_LEGACY_HISTORY, **{k: v for k, v in h.items() if k in names}})
               for h in d.get("history", [])]
    return AdaptResult(bool(d["success"]), int(d["rollouts"]), np.asarray(d["trajectory"], dtype=np.float64),
                       np.asarray(d["times"], dtype=np.float64), history)


@dataclass(frozen=True)
class AdaptJob:
    """What to adapt, where and how (see the module docstring for the dict layout).

    target : the conditioning query to adapt to (raw units).
    task : the registry task that scores roll-outs. robot : the robot kind that executes them
        (acnmp_core.robots.registry); it must run ``task``.
    task_config : the task's parameters; the robot's fixed ones are merged in at construction.
    config : the adaptation settings. seed : of exploration and supervised sampling.
    commit : assimilate a successful solution into the skill (a new version).
    assimilate_steps : training steps of that assimilation.
    """

    target: AdaptTarget
    task: str
    robot: str = "point2d"
    task_config: Mapping[str, Any] = field(default_factory=dict)
    config: AdaptConfig = field(default_factory=AdaptConfig)
    seed: int = 0
    commit: bool = False
    assimilate_steps: int = DEFAULT_ASSIMILATE_STEPS

    def __post_init__(self) -> None:
        check_type("task", self.task, str)
        check_type("robot", self.robot, str)
        check_type("config", self.config, AdaptConfig)
        check_type("seed", self.seed, int)
        check_type("commit", self.commit, bool)
        check_positive_int("assimilate_steps", self.assimilate_steps)
        object.__setattr__(self, "target", check_target(check_type("target", self.target, AdaptTarget)))
        object.__setattr__(self, "task_config", robot(self.robot).task_config(self.task, self.task_config))

    def to_dict(self) -> dict[str, Any]:
        """The plain map of this job (arrays as numpy arrays; :func:`services.transport.wire.jsonable`
        turns them into lists for JSON)."""
        return {"target": target_to_dict(self.target), "task": self.task, "task_config": dict(self.task_config),
                "robot": self.robot, "config": self.config.to_dict(), "seed": self.seed, "commit": self.commit,
                "assimilate_steps": self.assimilate_steps}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "AdaptJob":
        """Build and check a job from its map: ``target`` and ``task`` are required, the other
        fields take the defaults above; keys this version does not know are ignored (a newer
        client's extra fields), except inside ``config``, where they are an error."""
        check_type("job", d, Mapping)
        for key in ("target", "task"):
            if d.get(key) is None:
                raise InputError(f"{key}: missing")
        config = check_type("config", d.get("config") or {}, Mapping)
        try:
            config = AdaptConfig.from_dict(dict(config))
        except ValueError as exc:  # an unknown field, or a value AdaptConfig refuses (the message names it)
            raise InputError(str(exc)) from None
        except TypeError as exc:  # a value of a type AdaptConfig's checks cannot compare
            raise InputError(f"config: {exc}") from None
        optional = {k: d[k] for k in ("robot", "seed", "commit", "assimilate_steps") if d.get(k) is not None}
        return cls(target=target_from_dict(d["target"]), task=d["task"],
                   task_config=check_type("task_config", d.get("task_config") or {}, Mapping),
                   config=config, **optional)
