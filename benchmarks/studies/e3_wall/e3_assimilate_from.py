"""E3, ACNMP only: which network the assimilation continues from, "skill" vs "adapted", one run each.

Both variants run the same environments, seed and settings (the library's defaults otherwise), in
two processes side by side; the result is written to
``benchmarks/studies/e3_wall/results/e3_assimilate_from.json``. Usage:
``python benchmarks/studies/e3_wall/e3_assimilate_from.py [--envs 300] [--seed 0] [--out FILE]``.
"""
from __future__ import annotations

import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.adaptation.assimilation import ASSIMILATE_FROM  # noqa: E402
from acnmp_core.experiments.wall import run_wall  # noqa: E402
from benchmarks._results import benchmark_args, provenance, save_result, study_results  # noqa: E402


def _one(envs: int, seed: int, eval_every: int, assimilate_from: str) -> dict:
    """One ACNMP-only E3 run; returns its summary, curve and config."""
    torch.set_num_threads(1)
    r = run_wall(envs, seed, eval_every=eval_every, methods=("acnmp",), assimilate_from=assimilate_from)
    return {"summary": r["methods"]["acnmp"], "curve": r["curves"]["acnmp"], "config": r["config"],
            "wall_time_s": r["wall_time_s"]}


def main(argv: list[str] | None = None) -> int:
    """Run both variants and write the JSON."""
    args = benchmark_args(__doc__, "e3_assimilate_from", argv, results=study_results("e3_wall"), seed=0, envs=300,
                          eval_every=60)
    meta = provenance()
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=len(ASSIMILATE_FROM)) as pool:
        futures = {v: pool.submit(_one, args.envs, args.seed, args.eval_every, v) for v in ASSIMILATE_FROM}
        variants = {v: f.result() for v, f in futures.items()}
    result = {"provenance": meta, "experiment": "e3_assimilate_from", "envs": args.envs, "seed": args.seed,
              "variants": variants, "wall_time_s": round(time.perf_counter() - t0, 2)}
    for v, r in variants.items():
        s = r["summary"]
        print(f"{v:<8} test success {100 * s['test_success_rate']:.1f} %  error {s['test_error_mean']:.3f}  "
              f"goal error {s['test_goal_error_mean']:.3f}  trajectories {s['trajectories_total']}  "
              f"adaptations {s['adaptations']}  {r['wall_time_s']:.0f} s")
    return save_result(result, args.out)


if __name__ == "__main__":
    sys.exit(main())
