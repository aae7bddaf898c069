"""ACNMP beside its peers on Meta-World (reach, push, pick-place): LfD only, ACNMP, ProMP + RL,
black-box ProMP + CMA-ES, stable-baselines3 PPO / SAC with and without behaviour cloning.

Writes benchmarks/results/peers.json (provenance, the result of ``run_peers``) and peers.png.

Usage:
  python benchmarks/experiments/peers.py [--methods M,..] [--tasks T,..] [--seeds 0,1,..] [--cases C,..]
         [--out FILE] [--resume] [--budgets-from FILE]
  python benchmarks/experiments/peers.py --merge A.json B.json [--planned PLANS.json] [--out FILE]

The sizes are the library's defaults (the same as ``acnmp experiment peers``). The result is
written after every run, so a stopped run is usable (its ``not_run`` lists what is missing) and
``--resume`` continues it. The published result was made by two processes side by side, the
trajectory methods in one and the stable-baselines3 ones (their budgets read from the first's
ACNMP runs with ``--budgets-from``) in the other, merged with ``--merge``; its ``parts`` record both.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from acnmp_core.errors import InputError  # noqa: E402
from acnmp_core.experiments.peers import METHODS, PeersConfig, merge_results, plot_peers, run_line, run_peers  # noqa: E402
from benchmarks._results import provenance, save_result  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "peers.json"
TASKS = ("metaworld-reach", "metaworld-push", "metaworld-pick-place")
CASES = ("extrapolation", "interpolation")


def _names(text: str) -> tuple[str, ...]:
    return tuple(n.strip() for n in text.split(",") if n.strip())


def _seeds(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(s) for s in _names(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}") from None


def main(argv: list[str] | None = None) -> int:
    """Run (or merge) the comparison; print one line per run and the summary."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", type=_names, default=TASKS, metavar="T,..",
                    help=f"comma-separated Meta-World tasks (default: all: {','.join(TASKS)})")
    ap.add_argument("--methods", type=_names, default=METHODS, metavar="M,..",
                    help=f"comma-separated methods (default: all: {','.join(METHODS)})")
    ap.add_argument("--seeds", type=_seeds, default=(0, 1, 2, 3, 4), metavar="S,..",
                    help="comma-separated seeds, each a CNMP and one test position per case (default 0,1,2,3,4)")
    ap.add_argument("--cases", type=_names, default=CASES, metavar="C,..",
                    help=f"comma-separated cases (default: both: {','.join(CASES)})")
    ap.add_argument("--out", default=str(OUT), metavar="FILE",
                    help="write the result here after every run, peers.png beside it at the end "
                         "(default benchmarks/results/peers.json)")
    ap.add_argument("--resume", action="store_true", help="keep the runs already in --out, run the rest")
    ap.add_argument("--budgets-from", default=None, metavar="FILE",
                    help="set the SB3 budgets from the ACNMP runs of this earlier result (default: this run's)")
    ap.add_argument("--merge", nargs="+", default=None, metavar="JSON",
                    help="run nothing; merge these partial results (e.g. of processes run side by side) into --out")
    ap.add_argument("--planned", default=None, metavar="JSON",
                    help="with --merge: a list of plans {tasks, methods, seeds, cases}; their runs that no part made "
                         "are listed under not_run")
    args = ap.parse_args(argv)
    if args.merge:
        try:
            parts = [json.loads(Path(p).read_text()) for p in args.merge]
            planned = json.loads(Path(args.planned).read_text()) if args.planned else None
        except (OSError, ValueError) as exc:
            ap.error(f"--merge/--planned: {exc}")
        result = merge_results(parts, {"provenance": provenance()}, planned)
    else:
        torch.set_num_threads(1)
        try:
            config = PeersConfig(tasks=args.tasks, methods=args.methods, seeds=args.seeds, cases=args.cases)
        except InputError as exc:
            ap.error(str(exc))
        result = run_peers(config, out=args.out, resume=args.resume, header={"provenance": provenance()},
                           on_run=lambda r: print(run_line(r), flush=True), budgets_from=args.budgets_from)
    save_result(result, args.out, plot_peers, ("summary", "wall_time_s"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
