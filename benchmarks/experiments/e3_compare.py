"""E3 comparison benchmark: ACNMP, ProMP + REPS and the baseline after Ewerton et al. 2019 in one run,
on the same environments, in one task setting (paper or authors).

Writes benchmarks/results/e3_compare_<setting>.json (with its provenance) and the curves beside it
(.png). Per method: test success (and, in the authors' setting, by their stopping criterion too),
mean test error, trajectories as measured (total, per-environment maximum) and as the paper counts
them (environments x the per-environment maximum), wall time. Usage:
``python benchmarks/experiments/e3_compare.py --setting paper|authors --envs N [--seed S] [--snap-outputs] [--out FILE]``;
``--snap-outputs`` moves every path of every method, the adaptations' roll-outs included, onto its
start and goal before it is executed or scored (``run_wall(snap_outputs=True, snap_rollouts=True)``:
what the end points cost, not the paper's method) and writes ``e3_compare_<setting>_snapped.json`` by
default.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.wall import ALL_METHODS, run_wall  # noqa: E402
from acnmp_core.experiments.plots import plot_wall  # noqa: E402
from acnmp_core.tasks.wall.settings import SETTING_NAMES, wall_setting  # noqa: E402
from benchmarks._results import provenance, save_result, study_results  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402

#: The numbers kept per method in the comparison table.
KEYS = ("test_success_rate", "test_success_rate_strict", "test_error_mean", "trajectories_total",
        "trajectories_per_env_max", "trajectories_paper_style", "adaptations", "adaptations_failed", "time_s")


def comparison(result: dict) -> dict:
    """Per method the table's numbers, and the total-trajectory ratios of each baseline over ACNMP."""
    methods = {m: {k: s[k] for k in KEYS if k in s} for m, s in result["methods"].items()}
    base = methods.get("acnmp", {}).get("trajectories_total")
    ratios = {f"{m}_over_acnmp": round(s["trajectories_total"] / base, 3)
              for m, s in methods.items() if m != "acnmp" and base}
    return {"methods": methods, "trajectory_ratios": ratios}


def main(argv: list[str] | None = None) -> int:
    """Run the three methods in one setting and write the JSON; returns the exit code."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--setting", choices=SETTING_NAMES, default="paper",
                    help=f"the task setting, one of {', '.join(SETTING_NAMES)} (default paper)")
    add_run_arguments(ap, seed=0, envs=1000, eval_every=50)
    ap.add_argument("--snap-outputs", action="store_true",
                    help="move every path onto its start and goal before it is executed or scored")
    ap.add_argument("--out", default=None, metavar="FILE",
                    help="write the result here, the curves beside it (default "
                         "benchmarks/studies/e3_wall/results/e3_compare_<setting>[_snapped].json)")
    args = ap.parse_args(argv)
    suffix = "_snapped" if args.snap_outputs else ""
    out = args.out or str(study_results("e3_wall") / f"e3_compare_{args.setting}{suffix}.json")
    torch.set_num_threads(1)
    meta = provenance()
    # The fast baselines first, so a stopped run has shown them.
    methods = ("ewerton", "promp_rl", "acnmp")
    assert set(methods) == set(ALL_METHODS)
    r = run_wall(args.envs, args.seed, eval_every=args.eval_every, methods=methods,
                 setting=wall_setting(args.setting), snap_outputs=args.snap_outputs,
                 snap_rollouts=args.snap_outputs,
                 log=lambda s: print(s, flush=True))
    result = {"provenance": meta, **r, "comparison": comparison(r)}
    return save_result(result, out, plot_wall, ("comparison", "wall_time_s"))


if __name__ == "__main__":
    sys.exit(main())
