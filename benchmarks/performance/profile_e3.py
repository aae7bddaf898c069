"""Where ACNMP's E3 time goes: cProfile over a short E3 run (ACNMP only), grouped by stage.

Writes ``benchmarks/studies/e3_wall/results/e3_profile.json``: the run's size, its wall time, and for each stage
(first training, adaptation and its supervised steps, assimilation, every executed roll-out, test
evaluation) the cumulative seconds and their share of the run. Usage::

    python benchmarks/performance/profile_e3.py [--envs 40] [--test 1000]
"""
from __future__ import annotations

import cProfile
import pstats
import sys
import time
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks._results import benchmark_args, provenance, save_result, study_results  # noqa: E402

#: stage -> (module file suffix, function name) whose cumulative time is the stage's.
STAGES = {
    "first_training": ("acnmp_core/model/training.py", "train"),
    "adaptation": ("acnmp_core/adaptation/loop.py", "adapt"),
    "adaptation_supervised_steps": ("acnmp_core/adaptation/loop.py", "sl"),
    "rollouts": ("acnmp_core/tasks/wall/task.py", "evaluate"),
    "assimilation": ("acnmp_core/adaptation/assimilation.py", "assimilate"),
    "test_evaluation": ("acnmp_core/experiments/wall.py", "evaluate_test"),
}


def main(argv: list[str] | None = None) -> int:
    from acnmp_core.experiments.wall import run_wall

    args = benchmark_args(__doc__, "e3_profile", argv, results=study_results("e3_wall"), envs=40,
                          test=(1000, "test environments"))
    torch.set_num_threads(1)
    meta = provenance()
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    r = run_wall(args.envs, 0, n_test=args.test, eval_every=args.envs, methods=("acnmp",))
    prof.disable()
    wall = time.perf_counter() - t0
    stats = pstats.Stats(prof).stats
    stages = {}
    for name, (file, func) in STAGES.items():
        cum = sum(v[3] for (f, _, fn), v in stats.items() if f.endswith(file) and fn == func)
        stages[name] = {"seconds": round(cum, 2), "share": round(cum / wall, 3)}
    s = r["methods"]["acnmp"]
    result = {"experiment": "e3_profile", "provenance": meta,
              "config": {"envs": args.envs, "n_test": args.test, "seed": 0, "n_initial": r["n_initial"]},
              "adaptations": s["adaptations"], "trajectories_total": s["trajectories_total"],
              "wall_time_s": round(wall, 2), "stages": stages,
              "note": "cProfile adds overhead to every Python call; shares are the useful part"}
    return save_result(result, args.out, headline=("wall_time_s", "stages"))


if __name__ == "__main__":
    sys.exit(main())
