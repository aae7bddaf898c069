"""E3 time by torch thread count: the same ACNMP run with 1 and with more intra-op threads.

The CNMP is small, but its supervised steps (the assimilations, the first training, the steps
interleaved in each adaptation) are most of E3's time, and their matrix products still split over
threads. Runs ``run_wall`` (ACNMP only) once per thread count, one after the other in this process,
checks that every run gives the same numbers bit for bit (test curve, summary, roll-outs per
environment), and records each run's time and its ratio to the one-thread run. Writes
``benchmarks/studies/e3_wall/results/bench_e3_threads.json``. Usage::

    python benchmarks/performance/bench_e3_threads.py [--envs 150] [--threads 1 2] [--out FILE]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.wall import run_wall  # noqa: E402
from acnmp_core.threads import set_training_threads  # noqa: E402
from benchmarks._results import provenance, save_result, study_results  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402


def _numbers(result: dict) -> tuple:
    """Everything a run reports except its times."""
    s = result["methods"]["acnmp"]
    return ({k: v for k, v in s.items() if k != "time_s"}, result["curves"]["acnmp"],
            result["rollouts_per_env"]["acnmp"])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", type=int, default=150, help="new environments in each run (default 150)")
    ap.add_argument("--seed", type=int, default=0, help="the runs' seed (default 0)")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2], metavar="N",
                    help="the torch thread counts, one run each, the first the reference (default 1 2)")
    add_run_arguments(ap, out=str(study_results("e3_wall") / "bench_e3_threads.json"))
    args = ap.parse_args(argv)
    if args.envs < 1 or any(t < 1 for t in args.threads) or args.threads[0] != 1:
        ap.error("--envs and --threads: expected integers >= 1, the first thread count 1 (the baseline)")
    meta = provenance()
    runs, first = [], None
    t0 = time.perf_counter()
    for threads in args.threads:
        set_training_threads(threads)
        r = run_wall(args.envs, args.seed, eval_every=50, methods=("acnmp",))
        numbers = _numbers(r)
        first = first or numbers
        s = r["methods"]["acnmp"]
        runs.append({"threads": threads, "acnmp_time_s": s["time_s"], "identical_to_one_thread": numbers == first,
                     "test_success_rate": s["test_success_rate"], "trajectories_total": s["trajectories_total"],
                     "adaptations": s["adaptations"]})
        print(runs[-1], flush=True)
    base = runs[0]["acnmp_time_s"]
    for run in runs:
        run["speedup_over_one_thread"] = round(base / run["acnmp_time_s"], 3)
    result = {"experiment": "bench_e3_threads", "provenance": meta,
              "config": {"envs": args.envs, "seed": args.seed, "threads": args.threads, "eval_every": 50},
              "runs": runs, "wall_time_s": round(time.perf_counter() - t0, 1)}
    save_result(result, args.out, headline=("runs",))
    return 0 if all(run["identical_to_one_thread"] for run in runs) else 1


if __name__ == "__main__":
    sys.exit(main())
