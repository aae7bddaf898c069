"""E4 benchmark: a 3-DoF arm's skill transferred to a 4-DoF arm and refined by RL, with both controls.

Writes benchmarks/results/e4_transfer.json (with its provenance) and e4_transfer.png (success vs RL
iteration per condition, the paper's 23/73/90/100 % beside). Usage: ``python
benchmarks/experiments/e4_transfer.py [--runs N] [--minutes M] [--recipe paper|default] [--out FILE]``
(``--recipe default``: the product's default method, acnmp_core/experiments/recipe.py, into
e4_transfer_default.json). The settings are those of
``acnmp experiment transfer`` (:class:`~acnmp_core.experiments.transfer.TransferExperimentConfig`),
so the CLI's first N runs are the benchmark's first N. ``--minutes`` stops starting new runs after
that much wall time (the issue's limit for the whole benchmark is 30 min on the development machine);
the JSON then says how many of the requested runs finished.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.transfer import TransferExperimentConfig, run_transfer  # noqa: E402
from acnmp_core.experiments.plots import plot_transfer  # noqa: E402
from benchmarks._results import RESULTS, save_result, start_run  # noqa: E402
from clients.experiments.common import add_run_arguments, output_path, recipe_of  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    """Run E4 with the default settings; print one line per run and condition, then the summary."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=30, help="runs, seeds 0..N-1, each every condition (default 30)")
    ap.add_argument("--minutes", type=float, default=None, help="start no new run after this many minutes")
    add_run_arguments(ap, recipe=True, out=RESULTS / "e4_transfer.json")
    args, meta = start_run(ap, argv)
    budget = None if args.minutes is None else 60.0 * args.minutes
    result = {"provenance": meta, **run_transfer(args.runs, cfg=TransferExperimentConfig(recipe=recipe_of(args)),
                                                 log=lambda s: print(s, flush=True), time_budget_s=budget)}
    return save_result(result, output_path(args), plot_transfer,
                ("runs", "runs_requested", "success_by_iteration", "controls", "authors_data", "wall_time_s"))


if __name__ == "__main__":
    sys.exit(main())
