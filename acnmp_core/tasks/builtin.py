"""The built-in tasks' entries in the task registry (:mod:`acnmp_core.tasks.registry`): each builds
its task's evaluator from plain parameters, importing the task only when asked for."""
from __future__ import annotations

import numpy as np

from ..rollout import RolloutEvaluator
from .registry import register_task


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
