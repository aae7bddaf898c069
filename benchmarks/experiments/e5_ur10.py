"""E5 benchmark: UR10 pick and place at (8, 10) and (9, 11) cm, LfD only vs ACNMP, several seeds.

Writes benchmarks/results/e5_ur10.json (with its provenance and the time of one roll-out) and
e5_ur10.png (per-joint trajectories of the first seed, like the paper's supplementary figure).
Usage: ``python benchmarks/experiments/e5_ur10.py [--seeds N] [--recipe paper|default] [--out FILE]``
(``--recipe default``: the product's default method, acnmp_core/experiments/recipe.py, into
e5_ur10_default.json). The settings are the library's
defaults, the same as ``acnmp experiment ur10``, so the CLI's first N seeds give the benchmark's first N.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.ur10 import CASES, make_setup, plot_ur10, run_ur10  # noqa: E402
from benchmarks._results import benchmark_args, provenance, save_result  # noqa: E402
from clients.experiments.common import recipe_of  # noqa: E402


def rollout_seconds(n: int = 5) -> dict:
    """Wall and CPU time (s) of one 625-step roll-out of the expert at (9, 11) cm, in-process
    (median over ``n``, after one warm-up roll-out that builds the object and the obstacle)."""
    from acnmp_core.tasks.ur10_pick_place.task import UR10PickPlaceTask

    setup = make_setup()
    traj, tp = setup.experts["9_11"][None], np.asarray(CASES["9_11"])
    wall, cpu = [], []
    with UR10PickPlaceTask() as task:
        task.evaluate(traj, setup.times, tp)
        for _ in range(n):
            w, c = time.perf_counter(), time.process_time()
            task.evaluate(traj, setup.times, tp)
            wall.append(time.perf_counter() - w)
            cpu.append(time.process_time() - c)
    return {"wall_s_median": float(np.median(wall)), "cpu_s_median": float(np.median(cpu)), "n": n,
            "steps": int(traj.shape[1])}


def main(argv: list[str] | None = None) -> int:
    """Run E5 with the default settings; print one line per run and the summary."""
    args = benchmark_args(__doc__, "e5_ur10", argv, seeds=5, recipe=True)
    torch.set_num_threads(1)
    meta = provenance()
    result = {"provenance": meta, **run_ur10(args.seeds, log=lambda s: print(s, flush=True), recipe=recipe_of(args)),
              "rollout": rollout_seconds()}
    return save_result(result, args.out, plot_ur10, ("cases", "rollout", "wall_time_s"))


if __name__ == "__main__":
    sys.exit(main())
