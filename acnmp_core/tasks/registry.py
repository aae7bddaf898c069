"""Named tasks: a registry from a task name and plain parameters to a RolloutEvaluator.

Services receive a task by name over the wire (an adaptation job, a worker's roll-out request), so
every evaluator they can run is built here from JSON-like parameters.
"""
from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..rollout import RolloutEvaluator

_FACTORIES: dict[str, Callable[[dict[str, Any]], RolloutEvaluator]] = {}
_CREDITS: dict[str, str] = {}


def register_task(name: str, credit: str = "step"):
    """Decorator: register ``factory(params: dict) -> RolloutEvaluator`` under ``name``.

    ``credit`` is the task's credit for :func:`~acnmp_core.adapt.adaptation.adapt` ("step" or "future",
    the ``credit`` attribute of the evaluators it builds), so an evaluator that only forwards
    roll-outs to where the task runs (a remote worker) can carry it too.
    """

    def deco(factory):
        add_task(name, factory, credit)
        return factory

    return deco


def add_task(name: str, factory: Callable[[dict[str, Any]], RolloutEvaluator], credit: str = "step") -> None:
    """Register ``factory(params: dict) -> RolloutEvaluator`` under ``name`` with its ``credit``
    ("step" or "future"); ValueError for a name already taken (a robot plugin cannot replace a task)."""
    if name in _FACTORIES:
        raise ValueError(f"task: {name!r} is already registered")
    if credit not in ("step", "future"):
        raise ValueError(f"credit: expected 'step' or 'future', got {credit!r}")
    _FACTORIES[name] = factory
    _CREDITS[name] = credit


def task_credit(name: str) -> str:
    """The credit ("step" or "future") of the registered task ``name``; ValueError if unknown."""
    if name not in _CREDITS:
        raise ValueError(f"task: unknown task {name!r}; known tasks: {', '.join(task_names())}")
    return _CREDITS[name]


def task_names() -> list[str]:
    """Sorted names of the registered tasks."""
    return sorted(_FACTORIES)


def make_task(name: str, params: dict[str, Any] | None = None) -> RolloutEvaluator:
    """Build the evaluator ``name`` with ``params``; ValueError for an unknown name or bad params."""
    if name not in _FACTORIES:
        raise ValueError(f"task: unknown task {name!r}; known tasks: {', '.join(task_names())}")
    try:
        return _FACTORIES[name](dict(params or {}))
    except KeyError as exc:
        doc = (_FACTORIES[name].__doc__ or "").strip().splitlines()
        needs = f" ({' '.join(line.strip() for line in doc)})" if doc else ""
        raise ValueError(f"params: task {name!r} needs the parameter {exc.args[0]!r}{needs}") from None
    except TypeError as exc:
        raise ValueError(f"params: bad parameters for task {name!r}: {exc}") from None


@register_task("viapoint")
def _viapoint(p: dict) -> RolloutEvaluator:
    """params: t_v (float or K floats), point (D floats or K lists of D), tolerance (float or K floats)."""
    from .viapoint.task import ViaPointTask

    return ViaPointTask(np.asarray(p["t_v"], dtype=np.float64), np.asarray(p["point"], dtype=np.float64),
                        np.asarray(p["tolerance"], dtype=np.float64))


@register_task("wall")
def _wall(p: dict) -> RolloutEvaluator:
    """params: optional hole_width, wall_thickness, start_tolerance, goal_tolerance (floats)."""
    from .wall.task import WallTask

    return WallTask(**{k: float(v) for k, v in p.items()})


@register_task("push", credit="future")
def _push(p: dict) -> RolloutEvaluator:
    """params: n_joints (int, default 3), tolerance (float, metres, default 0.03), reward
    ("distance", the default, or "final"; see PlanarPushTask)."""
    from .push.task import PlanarPushTask

    return PlanarPushTask(int(p.get("n_joints", 3)), tolerance=float(p.get("tolerance", 0.03)),
                          reward=str(p.get("reward", "distance")))


@register_task("pick_place")
def _pick_place(p: dict) -> RolloutEvaluator:
    """params: optional place_tolerance, lift_tolerance (floats, metres, default 0.02 each)."""
    from .ur10_pick_place.task import UR10PickPlaceTask

    _known(p, "place_tolerance", "lift_tolerance")
    return UR10PickPlaceTask(**{k: float(p[k]) for k in ("place_tolerance", "lift_tolerance") if k in p})


@register_task("pour", credit="future")
def _pour(p: dict) -> RolloutEvaluator:
    """params: optional tolerance_g (float, grams, default 30), max_worlds (int, default 2)."""
    from .pour.task import PourTask

    _known(p, "tolerance_g", "max_worlds")
    return PourTask(tolerance_g=float(p.get("tolerance_g", 30.0)), max_worlds=int(p.get("max_worlds", 2)))


def _known(params: dict, *names: str) -> None:
    """ValueError naming the parameters in ``params`` that are not among ``names``."""
    unknown = sorted(set(params) - set(names))
    if unknown:
        raise ValueError(f"params: unknown parameter(s) {', '.join(unknown)}; expected some of {', '.join(names)}")


@register_task("cube_gap", credit="future")
def _cube_gap(p: dict) -> RolloutEvaluator:
    """params: n_joints (int, default 3). E4's scene: a cube pushed through the gap between two
    walls to a goal (see acnmp_core.tasks.transfer.scene.CubeGapTask)."""
    from .transfer.scene import CubeGapTask

    return CubeGapTask(int(p.get("n_joints", 3)))
