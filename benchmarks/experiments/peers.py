"""The comparison of record: ACNMP (the product's default and the paper's method) beside LfD only,
ProMP + RL, black-box ProMP + CMA-ES (basis count chosen on the demonstrations, and fancy_gym's 5;
on E2 also on ACNMP's dense reward) and stable-baselines3 PPO + BC on Meta-World's reach, push,
pick-place, window-open and button-press, the paper's E1, E2 and E3, Gymnasium's Pusher-v5 and two
path families that bend with their condition; SAC + BC on reach.

Seeds: the report seeds 5-14 (10 test positions per task and case), which no study, test or
tuning runs; the stable-baselines3 methods on 5-9 (minutes a run; docs/experiments/peers.md says
why). Writes benchmarks/results/peers.json (provenance, the result of ``run_peers``) and peers.png.

Usage:
  python benchmarks/experiments/peers.py                       # the whole plan, one process
  python benchmarks/experiments/peers.py --part 1/2 --out A.json   # every other task, for two processes
  python benchmarks/experiments/peers.py --merge A.json B.json     # the parts into benchmarks/results/peers.json

The sizes are the library's defaults (the same as ``acnmp experiment peers``). The result is written
after every run, so a stopped run is usable (its ``not_run`` lists what is missing) and ``--resume``
continues it at the commit its runs were made at (another commit is refused). Parts made by
processes side by side (``--part K/N``: the plan's tasks dealt out in turn) are merged only when
they were made at one commit.
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
from acnmp_core.experiments.peers import (CASES, REPORT_SEEDS, STEP_BASED_METHODS, TASK_NAMES,  # noqa: E402
                                          TRAJECTORY_METHODS, PeersConfig, merge_results, plot_peers, run_line,
                                          run_peers)
from benchmarks._results import RESULTS, provenance, save_result  # noqa: E402

OUT = RESULTS / "peers.json"
#: the methods of record: every trajectory method and PPO + BC everywhere it applies ...
METHODS = TRAJECTORY_METHODS + ("ppo_bc",)
#: ... and SAC + BC where it was measured before (reach; SB3 from scratch needs thousands of episodes)
EXTRA = {"metaworld-reach": ("sac_bc",)}
#: the stable-baselines3 methods run on the first half of the report seeds (minutes a run)
STEP_BASED_SEEDS = REPORT_SEEDS[:5]


def _names(text: str) -> tuple[str, ...]:
    return tuple(n.strip() for n in text.split(",") if n.strip())


def _seeds(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(s) for s in _names(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}") from None


def _part(text: str) -> tuple[int, int]:
    try:
        k, n = (int(x) for x in text.split("/"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected K/N, e.g. 1/2, got {text!r}") from None
    if not 1 <= k <= n:
        raise argparse.ArgumentTypeError(f"expected 1 <= K <= N, got {text!r}")
    return k, n


def configs(tasks: tuple[str, ...], methods: tuple[str, ...], seeds: tuple[int, ...],
            cases: tuple[str, ...]) -> list[PeersConfig]:
    """The plan as configs: the trajectory ``methods`` on every task and ``seeds``; the SB3 ones
    among them on the seeds of :data:`STEP_BASED_SEEDS` that are in ``seeds`` (all of ``seeds``
    when none is); the extra SB3 methods on their task."""
    traj = tuple(m for m in methods if m not in STEP_BASED_METHODS)
    steps = tuple(m for m in methods if m in STEP_BASED_METHODS)
    sb3_seeds = tuple(s for s in seeds if s in STEP_BASED_SEEDS) or seeds
    out = [PeersConfig(tasks=tasks, methods=traj, seeds=seeds, cases=cases)] if traj else []
    if steps:
        out.append(PeersConfig(tasks=tasks, methods=steps, seeds=sb3_seeds, cases=cases))
    for task, extra in EXTRA.items():
        if task in tasks and (more := tuple(m for m in extra if m in STEP_BASED_METHODS and m not in methods)):
            out.append(PeersConfig(tasks=(task,), methods=more, seeds=sb3_seeds, cases=("extrapolation",)))
    if not out:
        raise InputError("methods: expected at least one")
    return out


def main(argv: list[str] | None = None) -> int:
    """Run (or merge) the comparison; print one line per run and the summary."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", type=_names, default=TASK_NAMES, metavar="T,..",
                    help=f"comma-separated tasks (default: all: {','.join(TASK_NAMES)})")
    ap.add_argument("--methods", type=_names, default=METHODS, metavar="M,..",
                    help=f"comma-separated methods (default: {','.join(METHODS)}, and {EXTRA} there)")
    ap.add_argument("--seeds", type=_seeds, default=REPORT_SEEDS, metavar="S,..",
                    help="comma-separated seeds (default: the report seeds "
                         f"{REPORT_SEEDS[0]}-{REPORT_SEEDS[-1]}; SB3 on {STEP_BASED_SEEDS[0]}-{STEP_BASED_SEEDS[-1]})")
    ap.add_argument("--cases", type=_names, default=CASES, metavar="C,..",
                    help=f"comma-separated cases (default: both: {','.join(CASES)})")
    ap.add_argument("--part", type=_part, default=None, metavar="K/N",
                    help="only the K-th of N shares of the tasks (dealt out in turn), for N processes side by side")
    ap.add_argument("--out", default=str(OUT), metavar="FILE",
                    help="write the result here after every run, its figure beside it at the end "
                         "(default benchmarks/results/peers.json)")
    ap.add_argument("--resume", action="store_true", help="keep the runs already in --out, run the rest")
    ap.add_argument("--merge", nargs="+", default=None, metavar="JSON",
                    help="run nothing; merge these parts (made at one commit) into --out")
    args = ap.parse_args(argv)
    if args.merge:
        try:
            parts = [json.loads(Path(p).read_text()) for p in args.merge]
        except (OSError, ValueError) as exc:
            ap.error(f"--merge: {exc}")
        commits = {(p.get("provenance") or {}).get("commit") for p in parts}
        if len(commits) != 1:
            ap.error(f"--merge: the parts were made at different commits ({sorted(map(str, commits))}); "
                     "a result of record is made at one")
        result = merge_results(parts, {"provenance": provenance()})
        return save_result(result, args.out, plot_peers, ("wall_time_s",))
    torch.set_num_threads(1)
    tasks = args.tasks if args.part is None else args.tasks[args.part[0] - 1::args.part[1]]
    try:
        plans = configs(tasks, args.methods, args.seeds, args.cases)
    except InputError as exc:
        ap.error(str(exc))
    meta = provenance()
    commit = f"{meta['commit']}{'-dirty' if meta.get('dirty') else ''}"
    results = []
    for i, config in enumerate(plans):
        out = args.out if i == 0 else f"{args.out}.part{i}"
        try:
            results.append(run_peers(config, out=out, resume=args.resume, header={"provenance": meta},
                                     on_run=lambda r: print(run_line(r), flush=True), commit=commit))
        except InputError as exc:
            ap.error(str(exc))
    result = results[0] if len(results) == 1 else merge_results(results, {"provenance": meta})
    for i in range(1, len(plans)):
        Path(f"{args.out}.part{i}").unlink(missing_ok=True)
    return save_result(result, args.out, plot_peers, ("wall_time_s",))


if __name__ == "__main__":
    sys.exit(main())
