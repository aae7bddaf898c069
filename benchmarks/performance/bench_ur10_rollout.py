"""Time of one UR10 pick-and-place roll-out (625 steps, 5 s simulated) in-process.

Times, after one warm-up roll-out: the expert's demonstrations executed at their own heights, the
same trajectories with time-correlated exploration noise (as the adaptation sends them, some of
which hit the obstacle or drop the box), a heights change (the object and obstacle are rebuilt),
building the simulator, and generating one expert trajectory (IK). Reports milliseconds (median
and max over the roll-outs) and the demonstrations' success. Usage::

    python benchmarks/performance/bench_ur10_rollout.py [--repeats 3] [--out benchmarks/results/bench_ur10_rollout.json]
"""
from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from acnmp_core.tasks.ur10_pick_place.demos import expert_trajectory, make_ur10_demos  # noqa: E402
from acnmp_core.tasks.ur10_pick_place.task import N_STEPS, UR10PickPlaceTask  # noqa: E402
from benchmarks._results import benchmark_args  # noqa: E402


def _smooth_noise(rng, std: float, n_knots: int = 20) -> np.ndarray:
    """(N_STEPS, 6) noise: Gaussian knots (rad) linearly interpolated, zero at the start."""
    knots = np.linspace(0.0, 1.0, n_knots)
    eps = rng.normal(0.0, std, size=(n_knots, 6))
    eps[0] = 0.0
    t = np.linspace(0.0, 1.0, N_STEPS)
    return np.stack([np.interp(t, knots, eps[:, j]) for j in range(6)], axis=1)


def _ms(samples) -> dict:
    a = 1000.0 * np.asarray(samples)
    return {"median_ms": float(np.median(a)), "max_ms": float(a.max()), "n": int(a.size)}


def main(argv=None) -> int:
    """Run the benchmark, print and write its JSON; returns 0."""
    args = benchmark_args(__doc__, "bench_ur10_rollout", argv, repeats=(3, "passes over the 10 demonstrations"), noise=(0.01, "exploration noise std (rad)"))
    torch.set_num_threads(1)
    rng = np.random.default_rng(0)
    times = np.linspace(0.0, 1.0, N_STEPS)

    t0 = time.perf_counter()
    task = UR10PickPlaceTask()
    build_s = time.perf_counter() - t0
    with task:
        t0 = time.perf_counter()
        expert_trajectory((0.06, 0.08), sim=task.sim)
        ik_s = time.perf_counter() - t0
        demos, success, _ = make_ur10_demos(task=task)
        task.evaluate(demos.values[:1], times, demos.task_params[0])  # warm-up at the first heights
        clean, noisy, switch, noisy_ok = [], [], [], []
        for _ in range(args.repeats):
            for i in range(len(demos)):
                t0 = time.perf_counter()
                task.sim.set_heights(*demos.task_params[i])
                switch.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                task.evaluate(demos.values[i : i + 1], times, demos.task_params[i])
                clean.append(time.perf_counter() - t0)
                traj = demos.values[i] + _smooth_noise(rng, args.noise)
                t0 = time.perf_counter()
                batch = task.evaluate(traj[None], times, demos.task_params[i])
                noisy.append(time.perf_counter() - t0)
                noisy_ok.append(bool(batch.success[0]))
    result = {
        "benchmark": "ur10_rollout",
        "steps_per_rollout": N_STEPS,
        "physics_steps_per_rollout": N_STEPS * task.sim.substeps,
        "expert_rollout": _ms(clean),
        "noisy_rollout": {**_ms(noisy), "noise_std_rad": args.noise, "success_rate": float(np.mean(noisy_ok))},
        "heights_change": _ms(switch),
        "build_simulator_ms": 1000.0 * build_s,
        "expert_ik_trajectory_ms": 1000.0 * ik_s,
        "demo_success": [bool(s) for s in success],
        "within_1s": bool(max(max(clean), max(noisy)) <= 1.0),
        "machine": {"python": platform.python_version(), "cpu_count": os.cpu_count()},
    }
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2))
    print(json.dumps(result, indent=1))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
