"""In-process task speed: what the test suite used to assert with wall-clock limits.

- ``planar_push``: ms per 300-step roll-out of the expert's pushing demonstrations on the 3- and
  4-DoF planar arms (PyBullet, one physics client), after one warm-up roll-out;
- ``wall_scoring``: seconds to score 1000 wall-with-a-hole environments x 200 steps in one
  vectorised batch (E3's test set);
- ``e1_adaptation``: seconds of learner compute per adaptation iteration (network updates and the
  in-process roll-outs, which cost microseconds) with E1's ACNMP settings, and per roll-out: what
  one learner process sustains, since it runs one job at a time.

    python benchmarks/performance/bench_tasks.py [--repeats 5] [--out benchmarks/results/bench_tasks.json]
"""
from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from acnmp_core.robots.registry import robot  # noqa: E402
from acnmp_core.tasks.wall import task as W  # noqa: E402
from acnmp_core.tasks.push.demos import push_demos  # noqa: E402
from benchmarks._results import benchmark_args  # noqa: E402
from clients.experiments.common import write_json  # noqa: E402


def planar_push_ms(kind: str, repeats: int) -> float:
    """Mean ms per roll-out of ``repeats`` expert demonstrations on robot ``kind``."""
    spec = robot(kind)
    n = len(spec.joints)
    demos = push_demos(n_joints=n)
    times = np.linspace(0.0, 1.0, demos.values.shape[1])
    with spec.make_evaluator("push") as task:
        task.evaluate(demos.values[:1], times, demos.task_params[0])  # warm-up: URDF, world
        t0 = time.perf_counter()
        task.evaluate(demos.values[:repeats], times, demos.task_params[0])
        return (time.perf_counter() - t0) / repeats * 1000


def wall_scoring_s(n: int = 1000, steps: int = 200) -> tuple[float, bool]:
    """(seconds, all succeeded) to score ``n`` demonstrated environments x ``steps`` in one batch."""
    params = W.test_environments()[:n]
    _, values, _ = W.make_demo_set(n, np.random.default_rng(7), task_params=params)
    task = W.WallTask()
    t0 = time.perf_counter()
    batch = task.evaluate_batch(values, np.linspace(0, 1, steps), params)
    return time.perf_counter() - t0, bool(batch.success.all())


def e1_adaptation(budget: int = 30, train_steps: int = 1000) -> dict:
    """Seconds per iteration and per roll-out of E1's ACNMP adaptation (seed 0, in-process task)."""
    from acnmp_core.adaptation.loop import adapt
    from acnmp_core.experiments.viapoint import adapt_config, make_setup, train_lfd

    setup = make_setup()
    model = train_lfd(setup.demos, 0, train_steps)
    cfg = adapt_config("acnmp", budget, stop_on_success=False)
    t0 = time.perf_counter()
    res = adapt(model, setup.demos, setup.target, setup.task, cfg, seed=0)
    seconds = time.perf_counter() - t0
    return {"iterations": len(res.history), "rollouts": res.rollouts, "seconds": round(seconds, 2),
            "s_per_iteration": round(seconds / len(res.history), 3), "s_per_rollout": round(seconds / res.rollouts, 3)}


def main(argv: list[str] | None = None) -> int:
    """Run the measurements, print them, write JSON; returns 0."""
    args = benchmark_args(__doc__, "bench_tasks", argv, repeats=(5, "roll-outs timed per arm"))
    import torch

    torch.set_num_threads(1)
    push = {kind: round(planar_push_ms(kind, args.repeats), 2) for kind in ("planar3", "planar4")}
    seconds, ok = wall_scoring_s()
    result = {"benchmark": "tasks", "planar_push_ms_per_300_step_rollout": push,
              "wall_scoring_1000_envs_x_200_steps_s": round(seconds, 4), "wall_all_demos_succeed": ok,
              "e1_adaptation": e1_adaptation(),
              "repeats": args.repeats,
              "machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                          "note": "shared machine; numbers from one run"}}
    print(json.dumps(result, indent=1))
    write_json(result, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
