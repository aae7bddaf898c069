"""E1 benchmark: LfD-only, RL-only and ACNMP on the extrapolated via-point over several seeds.

Writes benchmarks/results/e1_viapoint.json (per-seed summaries, aggregates, provenance) and the
figures of one seed; with ``--recipe default`` (the product's default method instead of the
paper's, acnmp_core/experiments/recipe.py) e1_viapoint_default.json beside it. Usage:
    python benchmarks/experiments/e1_viapoint.py [--seeds 10] [--recipe paper|default] [--json FILE] [--figure-seed 0]
The settings are the library's defaults, the same as ``acnmp experiment viapoint --seeds N``.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.viapoint import (  # noqa: E402
    ASSIMILATION_STEPS, METHODS, adapt_config, run_viapoint, summarise_seeds)
from acnmp_core.experiments.plots import plot_viapoint  # noqa: E402
from benchmarks._results import RESULTS, provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments, output_path, recipe_of, seed_list  # noqa: E402

BUDGET, TRAIN_STEPS = 100, 3000


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_run_arguments(ap, seeds=10, recipe=True, out=RESULTS / "e1_viapoint.json")
    ap.add_argument("--figure-seed", type=int, default=0,
                    help="seed whose figures are written beside the JSON (default 0)")
    args = ap.parse_args(argv)
    seeds = seed_list(args, 10)
    recipe, out = recipe_of(args), output_path(args)
    torch.set_num_threads(1)
    meta = provenance()
    t0 = time.perf_counter()
    runs = []
    for seed in seeds:
        run = run_viapoint(seed, budget=BUDGET, train_steps=TRAIN_STEPS, progress=False, recipe=recipe)
        s = run.summary
        runs.append(s)
        print(seed, {m: (r["rollouts"], r["success"], round(r["shape_error"], 4)) for m, r in s["methods"].items()},
              f"{s['wall_time_s']:.1f}s", flush=True)
        if seed == args.figure_seed:
            stem = Path(out).with_suffix("")
            plot_viapoint(run, f"{stem}_seed{seed}.png")
    result = {
        "experiment": "viapoint",
        "provenance": meta,
        "recipe": recipe.to_dict(),
        "config": {"seeds": len(seeds), "variant": "2d", "budget": BUDGET, "train_steps": TRAIN_STEPS,
                   "assimilation_steps": ASSIMILATION_STEPS,
                   "adapt": {m: adapt_config(m, BUDGET, recipe).to_dict() for m in METHODS}},
        **summarise_seeds(runs),
        "wall_time_s": round(time.perf_counter() - t0, 1),
        "wall_time_per_seed_s_median": sorted(r["wall_time_s"] for r in runs)[len(runs) // 2],
        "runs": runs,
    }
    return save_result(result, out, headline=("methods", "shape_error_ratio_rl_only_over_acnmp", "assimilation",
                                             "wall_time_s"))


if __name__ == "__main__":
    sys.exit(main())
