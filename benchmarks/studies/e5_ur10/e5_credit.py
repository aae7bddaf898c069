"""E5 credit check: does the UR10 task want per-step or "future" credit in adapt()?

The pick-and-place reward comes at two steps (grasp, crossing). The LfD model of ``acnmp experiment
ur10`` mostly solves the test cases at once, which says nothing about the credit, so this check
adapts a deliberately under-trained model (``--train-steps``, default 400) whose LfD trajectory
misses, once with each credit, same seeds, same budget (60), and records the error of the mean
roll-out (m, grasp + avoidance distance) against roll-outs. Writes
benchmarks/studies/e5_ur10/results/e5_credit.json with its provenance. Usage:
``python benchmarks/studies/e5_ur10/e5_credit.py [--seeds N] [--train-steps N] [--out FILE]``.
"""
from __future__ import annotations

import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.ur10 import run_ur10  # noqa: E402
from acnmp_core.tasks.ur10_pick_place.task import UR10PickPlaceTask  # noqa: E402
from benchmarks._results import benchmark_args, provenance, save_result, study_results  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    """Run E5's adaptation with "step" and with "future" credit; print one line per run."""
    args = benchmark_args(__doc__, "e5_credit", argv, results=study_results("e5_ur10"), seeds=1,
                          train_steps=(400, "CNMP training steps"))
    torch.set_num_threads(1)
    result = {"provenance": provenance(), "benchmark": "e5_credit", "train_steps": args.train_steps, "credits": {}}
    for credit in ("step", "future"):
        with UR10PickPlaceTask() as task:
            task.credit = credit  # the instance's credit is what adapt() reads
            r = run_ur10(args.seeds, train_steps=args.train_steps, evaluator_factory=lambda case: task,
                         log=lambda s, c=credit: print(f"[{c}] {s}", flush=True))
        result["credits"][credit] = {
            "cases": {c: {m: {k: v for k, v in s.items() if k in ("success_rate", "rollouts_median", "error_m_median")}
                          for m, s in ms.items()} for c, ms in r["cases"].items()},
            "runs": [{"seed": x["seed"], "case": x["case"], "lfd_error_m": x["lfd"]["error_m"],
                      "final_error_m": x["acnmp"]["error_m"], "success": x["acnmp"]["success"],
                      "rollouts": x["acnmp"]["rollouts"], "curve": x["acnmp"]["curve"]} for x in r["runs"]],
        }
    return save_result(result, args.out, None, ("credits",))


if __name__ == "__main__":
    sys.exit(main())
