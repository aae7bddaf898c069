"""E6 benchmark: pour 1322 g from a 1400 g cup, LfD only vs ACNMP, then assimilation, several seeds.

Writes benchmarks/results/e6_pour.json (with its provenance; the CPU time per roll-out is measured
on the in-process roll-outs of the run) and e6_pour.png (the error of every roll-out per seed).
Usage: ``python benchmarks/experiments/e6_pour.py [--seeds N] [--jobs J] [--recipe paper|default] [--out FILE]``
(``--recipe default``: the product's default method, acnmp_core/experiments/recipe.py, into
e6_pour_default.json).
The settings are the experiment's defaults (:func:`~acnmp_core.experiments.pour.e6_adapt_config`),
the same as ``acnmp experiment pour``, so the CLI's first N seeds give the benchmark's first N;
``--jobs`` (default 2) runs that many seeds at once in separate processes, with the serial run's
result.
"""
from __future__ import annotations

import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.pour import plot_pour, run_pour  # noqa: E402
from benchmarks._results import benchmark_args, provenance, save_result  # noqa: E402
from clients.experiments.common import recipe_of  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    """Run E6 with the default settings; print one line per seed and the summary."""
    args = benchmark_args(__doc__, "e6_pour", argv, seeds=5, jobs=2, recipe=True)
    torch.set_num_threads(1)
    meta = provenance()
    result = {"provenance": meta, **run_pour(args.seeds, jobs=args.jobs, log=lambda s: print(s, flush=True),
                                             recipe=recipe_of(args))}
    return save_result(result, args.out, plot_pour,
                ("lfd_only", "assimilation", "rollout_cpu_s_median", "wall_time_s"))


if __name__ == "__main__":
    sys.exit(main())
