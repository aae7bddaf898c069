"""``acnmp experiment peers``: ACNMP beside the peers a robot-learning user would pick instead
(stable-baselines3 PPO and SAC, with and without behaviour cloning; fancy_gym's black-box ProMP +
CMA-ES; the project's ProMP + RL) on Meta-World's reach, push, pick-place, window-open and
button-press, the paper's E1 and E2, and Gymnasium's Pusher-v5."""
from __future__ import annotations

import argparse
import sys

from services.transport.argtypes import check_output_path, int_at_least, non_empty

from .common import add_seeds_argument, seed_list

#: --quick: every method once on one task and one seed with tiny budgets (the accounting, not the outcome)
QUICK = dict(tasks="metaworld-reach", seeds=1, cases="extrapolation", train_steps=200, budget=10, eval_every=1,
             bc_steps=50)


def _names(text: str) -> tuple[str, ...]:
    """An argparse type: comma-separated names (checked against the known ones when the run starts)."""
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if not names:
        raise argparse.ArgumentTypeError("expected comma-separated names")
    return names


def add_arguments(p) -> None:
    """Add the ``peers`` experiment's options to its parser ``p`` (made from its catalog entry)."""
    from acnmp_core.experiments.peers import METHODS, TASK_NAMES

    p.add_argument("--tasks", type=_names, default=None, help=f"comma-separated tasks (default: all: {', '.join(TASK_NAMES)})")
    p.add_argument("--methods", type=_names, default=None,
                   help=f"comma-separated methods among {', '.join(METHODS)} (default: all; a method that does "
                        "not apply to a task, e.g. PPO on E1, is left out there and named in the result)")
    add_seeds_argument(p, 5, "seeds (a CNMP of each kind and one test position per case each)")
    p.add_argument("--cases", type=_names, default=None, help="extrapolation, interpolation (default: both, where "
                                                              "the task has them)")
    p.add_argument("--train-steps", type=int_at_least(1), default=None, help="CNMP training steps (default 3000)")
    p.add_argument("--budget", type=int_at_least(1), default=None,
                   help="every adaptive method's episode budget per test position (default 1000)")
    p.add_argument("--eval-every", type=int_at_least(1), default=None,
                   help="SB3 training episodes between evaluations of the deterministic policy (default 10)")
    p.add_argument("--quick", action="store_true",
                   help="every method once on metaworld-reach, one seed, extrapolation, tiny budgets (a test of "
                        "the accounting, not of the outcome), each unless given")
    p.add_argument("--out", "--json", dest="json", type=non_empty, metavar="FILE",
                   help="write the result here, after every run (a partial run is usable)")
    p.add_argument("--resume", action="store_true", help="with --out: keep the runs already there, run the rest")
    p.add_argument("--plot", type=non_empty, metavar="FILE", help="write success against episodes (PNG)")
    p.add_argument("--quiet", action="store_true", help="no per-run lines, no progress bar")


def run(args) -> int:
    """Run the comparison as asked by ``args``, print the table; returns the exit code."""
    import torch

    from acnmp_core.experiments.peers import BUDGET, METHODS, TASK_NAMES, PeersConfig, plot_peers, run_line, run_peers

    if args.resume and not args.json:
        raise ValueError("--resume: only with --out FILE (the runs to keep are read from it)")
    check_output_path(args.plot, "--plot")
    q = QUICK if args.quick else {}
    pick = lambda value, key, default: value if value is not None else q.get(key, default)  # noqa: E731
    config = PeersConfig(
        tasks=args.tasks or (_names(q["tasks"]) if q else TASK_NAMES), methods=args.methods or METHODS,
        seeds=tuple(seed_list(args, q.get("seeds", 5))),
        cases=args.cases or (_names(q["cases"]) if q else ("extrapolation", "interpolation")),
        train_steps=pick(args.train_steps, "train_steps", 3000), budget=pick(args.budget, "budget", BUDGET),
        eval_every=pick(args.eval_every, "eval_every", 10), bc_steps=q.get("bc_steps", 3000))
    torch.set_num_threads(1)  # small networks; threads only contend with the simulator
    from clients.provenance import provenance

    header = {"provenance": provenance(), "quick": bool(args.quick)}
    result = run_peers(config, out=args.json, resume=args.resume, header=header, progress=not args.quiet,
                       on_run=None if args.quiet else (lambda r: print(run_line(r), flush=True)))
    print_table(result)
    if args.json:
        print(f"wrote {args.json}")
    if args.plot:
        print(f"wrote {plot_peers(result, args.plot)}", flush=True)
    return 0


def print_table(result: dict) -> None:
    """The summary: per task and case, each method's successes, median episodes ("> budget" when
    censored) and median wall time."""
    print(f"{'task':<22} {'case':<13} {'method':<11} {'success':>8} {'episodes (median)':>18} {'time (median)':>14}")
    for task, cases in result["summary"].items():
        for case, methods in cases.items():
            for method, s in methods.items():
                print(f"{task:<22} {case:<13} {method:<11} {s['successes']:>4}/{s['runs']:<3} {s['median_shown']:>18} "
                      f"{s['median_time_s']:>12.1f} s")
    if result["not_run"]:
        print(f"not run: {len(result['not_run'])} planned run(s)", file=sys.stderr)
