"""How good is the Pusher-v5 expert, and is the extrapolation a real one (issue 33)?

Executes the scripted expert (acnmp_core/tasks/pusher/scene.py) through the pusher robot at the
12 demonstration positions, at 100 random positions of the training region and 100 of the
extrapolation region; and, at the extrapolation positions, the nearest demonstration's
trajectory (what a method that only recalls its demonstrations would do). Also the feasibility
map behind the regions: the expert's final distance over object x, y and push angle.
Writes benchmarks/studies/pusher_expert/results/study_pusher_expert.json. Usage: ``python benchmarks/studies/pusher_expert/study_pusher_expert.py``.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.robots.registry import robot  # noqa: E402
from acnmp_core.tasks.pusher import scene  # noqa: E402
from benchmarks._results import provenance, save_result, study_results  # noqa: E402


def stats(errors: list[float]) -> dict:
    """Success rate at the threshold, median and max of final distances (m)."""
    e = np.asarray(errors)
    return {"n": int(e.size), "success_rate": float(np.mean(e <= scene.PUSHER_SUCCESS_M)),
            "median_m": round(float(np.median(e)), 4), "max_m": round(float(e.max()), 4)}


def main() -> int:
    """Measure and write the JSON."""
    meta = provenance()
    ev = robot("pusher").make_evaluator("pusher_push")
    times = np.linspace(0.0, 1.0, scene.N_STEPS)
    rng = np.random.default_rng(0)

    def final(traj, params) -> float:
        return float(ev.evaluate(traj[None], times, params).errors[0])

    demos = scene.training_params()
    demo_trajs = [scene.pusher_expert(p) for p in demos]
    train_random = scene.TRAINING_REGION.sample(100, rng)
    extrap = scene.extrapolation_params(100, rng)
    nearest = [demo_trajs[int(np.argmin(np.linalg.norm(demos - p, axis=1)))] for p in extrap]
    grid = {}
    for x in (0.24, 0.28, 0.32, 0.36, 0.40):
        for y in (-0.35, -0.25, -0.15, -0.05, 0.05):
            for a in (-15.0, 0.0, 15.0):
                p = scene.TRAINING_REGION.params(x, y, a)
                grid[f"{x:.2f},{y:.2f},{a:.0f}"] = round(final(scene.pusher_expert(p), p), 4)
    result = {
        "provenance": meta, "success_m": scene.PUSHER_SUCCESS_M,
        "kp": scene.PUSHER_KP.tolist(), "kd": scene.PUSHER_KD.tolist(),
        "regions": {"training": vars(scene.TRAINING_REGION), "extrapolation": vars(scene.EXTRAPOLATION_REGION)},
        "expert_at_demonstrations": stats([final(t, p) for t, p in zip(demo_trajs, demos)]),
        "expert_training_region": stats([final(scene.pusher_expert(p), p) for p in train_random]),
        "expert_extrapolation_region": stats([final(scene.pusher_expert(p), p) for p in extrap]),
        "nearest_demonstration_at_extrapolation": stats([final(t, p) for t, p in zip(nearest, extrap)]),
        "feasibility_map_final_m": {"key": "object x, object y, push angle deg", "values": grid},
    }
    ev.close()
    return save_result(result, study_results("pusher_expert") / "study_pusher_expert.json", None,
                ("expert_training_region", "expert_extrapolation_region", "nearest_demonstration_at_extrapolation"))


if __name__ == "__main__":
    sys.exit(main())
