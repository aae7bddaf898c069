"""Named tasks: a registry from a task name and plain parameters to a RolloutEvaluator.

Services receive a task by name over the wire (an adaptation job, a worker's roll-out request), so
every evaluator they can run is built here from JSON-like parameters.
"""
from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..rollout import RolloutEvaluator

_FACTORIES: dict[str, Callable[[dict[str, Any]], RolloutEvaluator]] = {}


def register_task(name: str):
    """Decorator: register ``factory(params: dict) -> RolloutEvaluator`` under ``name``."""

    def deco(factory):
        _FACTORIES[name] = factory
        return factory

    return deco


def task_names() -> list[str]:
    """Sorted names of the registered tasks."""
    return sorted(_FACTORIES)


def make_task(name: str, params: dict[str, Any] | None = None) -> RolloutEvaluator:
    """Build the evaluator ``name`` with ``params``; ValueError for an unknown name or bad params."""
    if name not in _FACTORIES:
        raise ValueError(f"task: unknown task {name!r}; known tasks: {', '.join(task_names())}")
    try:
        return _FACTORIES[name](dict(params or {}))
    except (TypeError, KeyError) as exc:
        raise ValueError(f"params: bad parameters for task {name!r}: {exc}") from None


@register_task("viapoint")
def _viapoint(p: dict) -> RolloutEvaluator:
    """params: t_v (float or K floats), point (D floats or K lists of D), tolerance (float or K floats)."""
    from .viapoint import ViaPointTask

    return ViaPointTask(np.asarray(p["t_v"], dtype=np.float64), np.asarray(p["point"], dtype=np.float64),
                        np.asarray(p["tolerance"], dtype=np.float64))


@register_task("wall")
def _wall(p: dict) -> RolloutEvaluator:
    """params: optional hole_width, wall_thickness, start_tolerance, goal_tolerance (floats)."""
    from .wall import WallTask

    return WallTask(**{k: float(v) for k, v in p.items()})


@register_task("push")
def _push(p: dict) -> RolloutEvaluator:
    """params: n_joints (int, default 3), tolerance (float, metres, default 0.03), reward
    ("distance", the default, or "final"; see PlanarPushTask)."""
    from ..robots.planar_arm import PlanarPushTask

    return PlanarPushTask(int(p.get("n_joints", 3)), tolerance=float(p.get("tolerance", 0.03)),
                          reward=str(p.get("reward", "distance")))
