"""The adaptation sweep: one AdaptConfig default for every task, chosen on E1, E2 and E3 together.

Each setting below is the library default with a few fields changed. Every setting runs ACNMP on
E1 (10 seeds), on E2's extrapolation target (10 seeds) and on a shortened E3 (200 new
environments, 200 test environments); the numbers go to benchmarks/results/adapt_sweep.json and
the table on docs/experiments/adaptation.md. Usage::

    python benchmarks/studies/adaptation/adapt_sweep.py [--seeds 10] [--e3-envs 200] [--jobs 2] [--only NAME ...]
                                     [--experiments e1 e2 e3] [--out FILE]

Several result files (e.g. one per invocation, ``adapt_sweep*.json``) are read together by the
docs' table; a setting measured in more than one keeps the experiments of each.

About an hour with two processes on the 2-core development machine.
"""
from __future__ import annotations

import argparse
import copy
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

#: name -> (what it is, AdaptConfig fields changed from the default)
SETTINGS: dict[str, tuple[str, dict]] = {
    "default": ("the library default", {}),
    "authors": ("the authors' update: REINFORCE on one noisy roll-out, 50 SL steps before and 20 before each "
                "reuse, reuse until the mean moved 1 std (at most 50), iid-like noise (20 knots), lr 5e-5",
                dict(advantage="reinforce", noisy_per_iter=1, sl_steps=50, sl_steps_reuse=20, max_reuse=50,
                     reuse_threshold=1.0, lr=5e-5, sl_lr=5e-5, n_knots=20)),
    "authors_lr10": ("the authors' update as above with a 10x policy rate (lr 5e-4): with 5e-5 its mean hardly "
                     "moved (adapt_sweep_authors.json)",
                     dict(advantage="reinforce", noisy_per_iter=1, sl_steps=50, sl_steps_reuse=20, max_reuse=50,
                          reuse_threshold=1.0, lr=5e-4, sl_lr=5e-5, n_knots=20)),
    "sl_lr_as_rl": ("supervised steps at the RL rate (sl_lr 1e-4)", dict(sl_lr=1e-4)),
    "knots_20": ("finer exploration noise (20 knots)", dict(n_knots=20)),
    "knots_8": ("smoother exploration noise (8 knots)", dict(n_knots=8)),
    "noisy_2": ("2 noisy roll-outs per iteration", dict(noisy_per_iter=2)),
    "explore_0.4": ("wider initial exploration (0.4 demo std)", dict(explore_scale=0.4)),
    "fast_fit": ("at most 15 RL steps per iteration, fit to 0.2 std", dict(max_reuse=15, fit_tolerance=0.2)),
    "explore_min_0.1": ("exploration may shrink to 0.1 of its initial std (the authors' E3 setting stops at "
                        "0.05, which the 0.3 floor's noise hides)", dict(explore_min=0.1)),
    "sl_more": ("more supervised steps (30 before an iteration, 5 before each reuse)",
                dict(sl_steps=30, sl_steps_reuse=5)),
    "sl_strong": ("more supervised steps at the RL rate (30 and 5, sl_lr 1e-4): does SL keep E1's shape?",
                  dict(sl_steps=30, sl_steps_reuse=5, sl_lr=1e-4)),
}


def _e1(fields: dict, seeds: list[int]) -> dict:
    import torch

    from acnmp_core.adaptation.loop import adapt
    from acnmp_core.adaptation.config import AdaptConfig
    from acnmp_core.experiments.viapoint import make_setup, train_lfd, trajectory_metrics

    torch.set_num_threads(1)
    setup = make_setup()
    runs = []
    for seed in seeds:
        model = train_lfd(setup.demos, seed, 3000)
        res = adapt(model, setup.demos, setup.target, setup.task,
                    AdaptConfig.paper(**{"max_rollouts": 100, **fields}), seed=seed)
        runs.append({"rollouts": res.rollouts, **trajectory_metrics(setup, res.trajectory)})
    ok = [r["success"] for r in runs]
    return {"success_rate": float(np.mean(ok)), "rollouts_median": float(np.median([r["rollouts"] for r in runs])),
            "within_35_rate": float(np.mean([r["success"] and r["rollouts"] <= 35 for r in runs])),
            "shape_error_median": float(np.median([r["shape_error"] for r in runs])),
            "endpoint_error_max": float(max(r["endpoint_error"] for r in runs)),
            "rollouts": [r["rollouts"] for r in runs]}


def _e2(fields: dict, seeds: list[int]) -> dict:
    import torch

    from acnmp_core.adaptation.config import AdaptConfig
    from acnmp_core.experiments.push import ACNMP_BUDGET, run_push

    torch.set_num_threads(1)
    r = run_push(seeds, methods=("acnmp",), cases=("extrapolation",),
                 adapt_config=AdaptConfig.paper(**{"max_rollouts": ACNMP_BUDGET, **fields}))
    s = r["methods"]["acnmp"]["extrapolation"]
    return {k: s[k] for k in ("success_rate", "rollouts_median", "final_error_median", "rollouts")}


def _e3(fields: dict, envs: int) -> dict:
    import torch

    from acnmp_core.adaptation.config import AdaptConfig
    from acnmp_core.experiments.wall import ACNMP_BUDGET, run_wall

    torch.set_num_threads(1)
    r = run_wall(envs, 0, n_test=200, eval_every=envs, methods=("acnmp",),
                 adapt_config=AdaptConfig.paper(**{"max_rollouts": ACNMP_BUDGET, **fields}))
    s = r["methods"]["acnmp"]
    return {k: s[k] for k in ("test_success_rate", "test_error_mean", "trajectories_total",
                              "trajectories_per_env_max", "adaptations", "adaptations_failed", "time_s")}


def _run(task: tuple[str, str, dict, list[int], int]) -> tuple[str, str, dict, float]:
    name, exp, fields, seeds, envs = task
    t0 = time.perf_counter()
    out = _e1(fields, seeds) if exp == "e1" else _e2(fields, seeds) if exp == "e2" else _e3(fields, envs)
    return name, exp, out, round(time.perf_counter() - t0, 1)


def main(argv: list[str] | None = None) -> int:
    from acnmp_core.adaptation.config import AdaptConfig
    from benchmarks._results import provenance, save_result

    from clients.experiments.common import add_run_arguments

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10, help="seeds 0..N-1 of every setting and experiment (default 10)")
    ap.add_argument("--e3-envs", type=int, default=200, help="E3's new environments per run (default 200)")
    ap.add_argument("--jobs", type=int, default=2, help="runs in processes at once (default 2)")
    ap.add_argument("--only", nargs="*", choices=sorted(SETTINGS), help="run only these settings")
    ap.add_argument("--experiments", nargs="*", choices=("e1", "e2", "e3"), default=["e2", "e3", "e1"],
                    help="run only these experiments for every setting")
    add_run_arguments(ap, out=str(ROOT / "benchmarks" / "results" / "adapt_sweep.json"))
    args = ap.parse_args(argv)
    meta = provenance()
    names = args.only or list(SETTINGS)
    seeds = list(range(args.seeds))
    tasks = [(n, e, SETTINGS[n][1], seeds, args.e3_envs) for n in names for e in args.experiments]
    t0 = time.perf_counter()
    results: dict[str, dict] = {n: {"about": SETTINGS[n][0], "fields": SETTINGS[n][1]} for n in names}
    def result(done: int) -> dict:
        return {"experiment": "adapt_sweep", "provenance": meta,
                "config": {"seeds": args.seeds, "e3_envs": args.e3_envs, "e3_test": 200,
                           "default": AdaptConfig.paper().to_dict()},
                "settings": results, "complete": done == len(tasks),
                "wall_time_s": round(time.perf_counter() - t0, 1)}

    with ProcessPoolExecutor(args.jobs, mp_context=get_context("spawn")) as pool:
        # Written after every finished run, so an interrupted sweep keeps what it measured.
        for done, fut in enumerate(as_completed([pool.submit(_run, t) for t in tasks]), start=1):
            name, exp, out, secs = fut.result()
            results[name][exp] = {**out, "time_s": secs}
            print(name, exp, json.dumps({k: v for k, v in out.items() if k != "rollouts"}), f"{secs:.0f} s", flush=True)
            save_result(result(done), args.out)
    return save_result(result(len(tasks)), args.out, headline=("wall_time_s",))


if __name__ == "__main__":
    sys.exit(main())
