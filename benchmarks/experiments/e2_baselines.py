"""E2 baselines benchmark: ACNMP against ProMP + REPS after Stark et al. 2019 (from scratch, from the
skill with the most similar effect, from a similarity-weighted mixture) and the tuned ProMP variant,
in each task setting (paper, authors), one run per setting.

Writes benchmarks/studies/e2_push/results/e2_baselines.json with its provenance:
``{settings: {paper|authors: {methods: {acnmp|promp_scratch|promp_similar|promp_mixture|promp_tuned:
{extrapolation: {rollouts_median, success_rate, final_error_median, ...}, interpolation: {...}}}, ...}}}``.
Usage: ``python benchmarks/experiments/e2_baselines.py [--seeds N] [--setting paper authors] [--jobs 2]``; with
``--jobs 2`` the two settings run side by side in two processes (spawned, single-threaded torch).
After every seed each setting's result so far goes to ``<out>.<setting>.partial.json``; if a run
must be stopped, ``--from-partials`` writes the JSON from those files (with the seeds they hold).
"""
from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.push_baselines import BUDGET, run_push_baselines  # noqa: E402
from acnmp_core.tasks.push.settings import SETTING_NAMES, push_setting  # noqa: E402
from benchmarks._results import provenance, save_result, study_results  # noqa: E402


def partial_path(out: str, setting: str) -> Path:
    """Where a setting's result so far is kept during a run."""
    return Path(out).with_suffix(f".{setting}.partial.json")


def _run_setting(args: tuple[str, int, int, str, dict]) -> dict:
    """One setting's run in a worker process: (setting name, seeds, budget, out, provenance) -> its
    result; after every seed the result so far (with the run's provenance) goes to :func:`partial_path`."""
    import torch

    torch.set_num_threads(1)
    name, seeds, budget, out, meta = args

    def keep(res: dict) -> None:
        partial_path(out, name).write_text(json.dumps({"provenance": meta, **res}) + "\n")

    return run_push_baselines(seeds, setting=push_setting(name), budget=budget,
                              log=lambda s: print(s, flush=True), on_seed=keep)


def headline(result: dict) -> dict:
    """Per setting and method: extrapolation's median roll-outs, success rate and median error."""
    return {s: {m: {k: v["extrapolation"][k] for k in ("rollouts_median", "success_rate", "final_error_median")}
                for m, v in r["methods"].items()} for s, r in result["settings"].items()}


def main(argv: list[str] | None = None) -> int:
    """Run the settings asked for and write the JSON; returns the exit code."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10, help="seeds 0..N-1 of every setting (default 10)")
    ap.add_argument("--setting", nargs="+", choices=SETTING_NAMES, default=list(SETTING_NAMES),
                    help=f"the task settings to run (default: all, {' '.join(SETTING_NAMES)})")
    ap.add_argument("--budget", type=int, default=BUDGET, help=f"roll-outs per target, every method (default {BUDGET})")
    ap.add_argument("--jobs", type=int, default=2, help="settings run side by side (default 2)")
    ap.add_argument("--out", default=str(study_results("e2_push") / "e2_baselines.json"),
                    help="write the result here (default benchmarks/studies/e2_push/results/e2_baselines.json)")
    ap.add_argument("--from-partials", action="store_true",
                    help="run nothing; write --out from the partial files of a stopped run")
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.budget < 3 or args.jobs < 1:
        print("e2_baselines: --seeds and --jobs must be positive, --budget at least 3", file=sys.stderr)
        return 2
    if args.from_partials:
        parts = [json.loads(partial_path(args.out, s).read_text()) for s in args.setting
                 if partial_path(args.out, s).exists()]
        if not parts:
            print(f"e2_baselines: no partial files beside {args.out}", file=sys.stderr)
            return 2
        meta = parts[0].pop("provenance")
        for p in parts[1:]:
            p.pop("provenance")
        results = parts
        wall = max(p["wall_time_s"] for p in parts)
    else:
        meta = provenance()
        t0 = time.perf_counter()
        work = [(s, args.seeds, args.budget, args.out, meta) for s in args.setting]
        if args.jobs > 1 and len(work) > 1:
            with mp.get_context("spawn").Pool(min(args.jobs, len(work))) as pool:
                results = pool.map(_run_setting, work)
        else:
            results = [_run_setting(w) for w in work]
        wall = round(time.perf_counter() - t0, 2)
    result = {"provenance": meta, "wall_time_s": wall,
              "seeds": {r["setting"]: r["seeds"] for r in results}, "budget": results[0]["budget"],
              "settings": {r["setting"]: r for r in results}}
    result["headline"] = headline(result)
    return save_result(result, args.out, None, ("headline", "wall_time_s"))


if __name__ == "__main__":
    sys.exit(main())
