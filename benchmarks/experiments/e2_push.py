"""E2 benchmark: ACNMP vs adaptive ProMP + RL on the pushing task, full budgets, several seeds.

Writes benchmarks/results/e2_push.json (with its provenance) and e2_push.png (Fig. 5(b)-like
learning curves). Usage: ``python benchmarks/experiments/e2_push.py [--seeds N] [--setting paper|authors]
[--recipe paper|default] [--out FILE]`` (the authors' setting writes e2_push_authors.json, the product's
default method, acnmp_core/experiments/recipe.py, e2_push_default.json, unless ``--out`` says otherwise). The settings are
the library's defaults, the same as ``acnmp experiment push``, so the CLI's first N seeds give the
benchmark's first N.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.push import run_push  # noqa: E402
from acnmp_core.experiments.plots import plot_push  # noqa: E402
from acnmp_core.tasks.push.settings import SETTING_NAMES, push_setting  # noqa: E402
from benchmarks._results import provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments, recipe_of, seed_list  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    """Run E2 with the default settings; print one line per run and the summary."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_run_arguments(ap, seeds=10, recipe=True)
    ap.add_argument("--setting", choices=SETTING_NAMES, default=SETTING_NAMES[0],
                    help=f"the task setting, one of {', '.join(SETTING_NAMES)} (default {SETTING_NAMES[0]})")
    ap.add_argument("--out", default=None, metavar="FILE",
                    help="write the result here, the figure beside it (default benchmarks/results/e2_push.json, "
                         "e2_push_<setting>.json for another setting, with _default before .json for --recipe default)")
    args = ap.parse_args(argv)
    recipe = recipe_of(args)
    stem = "e2_push" if args.setting == "paper" else f"e2_push_{args.setting}"
    out = args.out or str(ROOT / "benchmarks" / "results" / f"{recipe.result_name(stem)}.json")
    torch.set_num_threads(1)
    meta = provenance()
    result = {"provenance": meta, **run_push(seed_list(args, 10), setting=push_setting(args.setting),
                                             log=lambda s: print(s, flush=True), recipe=recipe)}
    return save_result(result, out, plot_push, ("methods", "rollout_ratio_promp_over_acnmp", "wall_time_s"))


if __name__ == "__main__":
    sys.exit(main())
