"""E4: how far apart the rewards of roll-outs that never touch the cube are (PyBullet's jitter).

For a few RL seeds of the transfer condition with E4's settings before ``signal_tolerance`` (exact
equality), record every iteration's largest difference between a roll-out's credited rewards and
the mean roll-out's (the quantity ``acnmp_core.adaptation.credit.per_step_advantages`` tests), and summarise: the
differences below :data:`~acnmp_core.experiments.transfer.BLIND_TOLERANCE` (the cube untouched by
every roll-out; it still moves by micrometres) against those above it (a touch). Writes
benchmarks/studies/e4_transfer/results/e4_jitter.json. Usage: ``python benchmarks/studies/e4_transfer/e4_jitter.py [--seeds 30 35 39]
[--cache DIR]`` (``--cache``: the sweep's trained pairs).
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.transfer import (BLIND_TOLERANCE, TransferExperimentConfig, make_setup,  # noqa: E402
                                             run_condition)
from acnmp_core.tasks.transfer.scene import CubeGapTask  # noqa: E402
from benchmarks._results import save_result, start_run, study_results  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402
from benchmarks.studies.e4_transfer.e4_sweep import _memo_trainer  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    """Run the seeds, write the per-iteration differences and their summary."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[30, 35, 39], metavar="S",
                    help="RL seeds whose runs are replayed (default 30 35 39)")
    ap.add_argument("--cache", default=None, metavar="DIR",
                    help="directory for trained pairs, shared with e4_sweep.py (default: in memory only)")
    add_run_arguments(ap, out=str(study_results("e4_transfer") / "e4_jitter.json"))
    args, meta = start_run(ap, argv)
    base = TransferExperimentConfig()
    cfg = replace(base, adapt=replace(base.adapt, signal_tolerance=1e-12))
    setup, trainer = make_setup(), _memo_trainer(None if args.cache is None else Path(args.cache))
    task = CubeGapTask(4)
    runs = []
    try:
        for seed in args.seeds:
            diffs: list[float] = []

            def record(log, trajs, batch, diffs=diffs):
                r = np.cumsum(batch.rewards[:, ::-1], axis=1)[:, ::-1]  # the task's "future" credit
                if len(r) > 1:
                    diffs.append(float(np.abs(r[1:] - r[0]).max()))

            res = run_condition(trainer(setup, cfg, seed % cfg.pair_seeds), setup, "transfer", task, cfg, seed, record)
            runs.append({"seed": seed, "iterations": res["iterations"], "max_reward_diff": diffs})
    finally:
        task.close()
    every = np.array([x for r in runs for x in r["max_reward_diff"]])
    low, high = every[every <= BLIND_TOLERANCE], every[every > BLIND_TOLERANCE]
    result = {"provenance": meta, "experiment": "transfer_jitter", "tolerance": BLIND_TOLERANCE,
              "config": cfg.to_dict(), "runs": runs,
              "untouched": {"iterations": int(len(low)), "max": float(low.max()) if len(low) else None,
                            "median": float(np.median(low)) if len(low) else None},
              "touched": {"iterations": int(len(high)), "min": float(high.min()) if len(high) else None,
                          "median": float(np.median(high)) if len(high) else None}}
    return save_result(result, args.out, None, ("untouched", "touched"))


if __name__ == "__main__":
    sys.exit(main())
