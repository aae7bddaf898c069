"""E3 diagnosis: how well does the CNMP fit the wall task from many clean demonstrations, by training budget?

No RL and no self-improvement: the first training of ``run_wall`` on ``n_initial`` expert
demonstrations (one per random environment), then the test success and errors on the 1000 test
environments and on the demonstrated environments themselves, for a few supervised budgets (steps x
batch x targets per episode, a decaying rate, episodes whose targets include their observations).
It separates the skill's fitting precision from what adaptation and assimilation add, and the fit
(the demonstrated environments) from the generalisation (the test environments). Writes
``benchmarks/studies/e3_wall/results/e3_fit_precision.json``. Usage:
``python benchmarks/studies/e3_wall/e3_fit_precision.py [--demos 30 300] [--seed 0] [--out FILE]``.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments import wall as E  # noqa: E402
from acnmp_core.model.training import TrainConfig, train  # noqa: E402
from benchmarks._results import save_result, start_run, study_results  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402

#: TrainConfig fields per budget: E3's default first training, then larger budgets, a rate decayed
#: to 1e-5 (cosine), and episodes whose targets include their observations.
BUDGETS = (dict(steps=3000, batch_size=32, n_targets=10), dict(steps=10000, batch_size=32, n_targets=10),
           dict(steps=3000, batch_size=128, n_targets=30),
           dict(steps=10000, batch_size=32, n_targets=10, lr_final=1e-5),
           dict(steps=3000, batch_size=32, n_targets=10, targets_include_obs=True),
           dict(steps=10000, batch_size=32, n_targets=10, lr_final=1e-5, targets_include_obs=True))


def main(argv: list[str] | None = None) -> int:
    """Train once per (demonstrations, budget) and score on the test environments."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--demos", type=int, nargs="+", default=[30, 300], metavar="N",
                    help="demonstrated environments, one fit each (default 30 300)")
    ap.add_argument("--seed", type=int, default=0, help="the seed of the environments and the model (default 0)")
    add_run_arguments(ap, out=str(study_results("e3_wall") / "e3_fit_precision.json"))
    args, meta = start_run(ap, argv)
    t0 = time.perf_counter()
    runs = []
    for n in args.demos:
        setup = E.make_setup(1, args.seed, n_initial=n)
        demonstrated = np.stack([d.task_params for d in setup.initial])
        for budget in BUDGETS:
            t1 = time.perf_counter()
            model = E.make_wall_cnmp(args.seed)
            cfg = TrainConfig(**budget)
            train(model, setup.initial, cfg, seed=args.seed, progress=False)
            train_time = time.perf_counter() - t1
            def generate(c):
                return E.cnmp_trajectories(model, c, setup.times)

            scores, fit = E.evaluate_test(generate, setup.test), E.evaluate_test(generate, demonstrated)
            runs.append({"demos": n, "steps": cfg.steps, "batch_size": cfg.batch_size, "n_targets": cfg.n_targets,
                         "lr_final": cfg.lr_final, "targets_include_obs": cfg.targets_include_obs, **scores,
                         "demonstrated": fit, "time_s": round(train_time, 2)})
            print(runs[-1], flush=True)
    return save_result({"provenance": meta, "experiment": "e3_fit_precision", "seed": args.seed, "runs": runs,
                 "wall_time_s": round(time.perf_counter() - t0, 2)}, args.out)


if __name__ == "__main__":
    sys.exit(main())
