"""Roll-out throughput: in-process evaluation vs RemoteEvaluator over 1 and 2 local workers.

For each task (E1 via-point on point2d workers; optionally push on planar3 workers) and batch size,
it times ``repeats`` batches of random trajectories through the in-process evaluator and through
a RemoteEvaluator on a LocalDeployment of 1 and 2 workers, and reports roll-outs per second and
the ratios remote / in-process and 2 workers / 1 worker. Usage::

    python benchmarks/performance/bench_rollouts.py [--tasks viapoint push] [--batches 3 32] [--repeats 20]
                                        [--out benchmarks/results/bench_rollouts.json]
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from acnmp_core.tasks.registry import make_task  # noqa: E402
from clients.experiments.common import write_json  # noqa: E402
from services.launcher import LocalDeployment  # noqa: E402
from services.worker.remote import RemoteEvaluator  # noqa: E402

TASKS = {  # task -> (robot kind, task_config, D, T, task_params)
    "viapoint": ("point2d", {"t_v": 0.25, "point": [0.25, 0.8], "tolerance": 0.02}, 2, 101, None),
    "push": ("planar3", {"n_joints": 3}, 3, 100, np.array([0.5, 0.2])),
}


def throughput(evaluator, trajs: np.ndarray, times: np.ndarray, tp, repeats: int) -> float:
    """Roll-outs per second of ``repeats`` calls of ``evaluator.evaluate(trajs, times, tp)`` (after one warm-up)."""
    evaluator.evaluate(trajs, times, tp)  # warm-up: builds cached evaluators / PyBullet worlds
    t0 = time.perf_counter()
    for _ in range(repeats):
        evaluator.evaluate(trajs, times, tp)
    return repeats * len(trajs) / (time.perf_counter() - t0)


def trajectories(task: str, b: int, d: int, t: int, rng) -> np.ndarray:
    """Random but plausible trajectories (B, T, D): smooth for push (joint angles), noise for via-point."""
    if task == "push":
        base = np.linspace(0, 1, t)[None, :, None] * np.array([0.6, -0.9, 0.5])[None, None, :d]
        return base + 0.05 * rng.normal(size=(b, 1, d))
    return rng.normal(scale=0.3, size=(b, t, d))


def main(argv=None) -> int:
    """Run the benchmark and write its JSON; returns 0."""
    from clients.experiments.common import add_run_arguments

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tasks", nargs="+", default=["viapoint", "push"], choices=sorted(TASKS),
                   help=f"the tasks timed, among {', '.join(sorted(TASKS))} (default viapoint push)")
    p.add_argument("--batches", nargs="+", type=int, default=[3, 32], metavar="N",
                   help="batch sizes, roll-outs per batch (default 3 32)")
    p.add_argument("--repeats", type=int, default=20, help="batches timed per size and evaluator (default 20)")
    add_run_arguments(p, out="benchmarks/results/bench_rollouts.json")
    args = p.parse_args(argv)
    torch.set_num_threads(1)
    os.environ.setdefault("RERUN_ANALYTICS", "0")
    rng = np.random.default_rng(0)
    results = []
    for task in args.tasks:
        robot, cfg, d, t, tp = TASKS[task]
        times = np.linspace(0, 1, t)
        local = make_task(task, cfg)
        rows = {b: {"task": task, "robot": robot, "batch": b, "in_process": throughput(
            local, trajectories(task, b, d, t, rng), times, tp, args.repeats)} for b in args.batches}
        if hasattr(local, "close"):
            local.close()
        for n in (1, 2):
            with LocalDeployment(f"bench{n}", workers=n, robot=robot, model=False, learner=False) as dep:
                remote = RemoteEvaluator(dep.session, dep.keys, robot, task, cfg)
                for b in args.batches:
                    rows[b][f"workers_{n}"] = throughput(remote, trajectories(task, b, d, t, rng), times, tp, args.repeats)
        for row in rows.values():
            row["ratio_1_worker_vs_in_process"] = row["workers_1"] / row["in_process"]
            row["ratio_2_workers_vs_in_process"] = row["workers_2"] / row["in_process"]
            row["ratio_2_vs_1_workers"] = row["workers_2"] / row["workers_1"]
            results.append(row)
            print(json.dumps({k: round(v, 3) if isinstance(v, float) else v for k, v in row.items()}), flush=True)
    out = {"benchmark": "rollout_throughput", "unit": "roll-outs per second", "repeats": args.repeats,
           "machine": {"cpus": os.cpu_count(), "python": platform.python_version()}, "results": results}
    write_json(out, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
