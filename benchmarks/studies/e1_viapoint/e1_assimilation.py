"""E1 assimilation check: how many continued-training steps keep what the adaptation learnt?

For each seed: the E1 LfD model (3000 steps), ACNMP's adaptation to the extrapolated via-point
(E1's settings, budget 100), then the solution assimilated from the same adapted network with each
candidate :class:`~acnmp_core.adaptation.assimilation.AssimilationConfig`. Per candidate and seed: the
conditioned skill's task error and success with no RL (issue 10: within tolerance in every seed),
the old demonstrations' reproduction RMSE over the LfD model's (<= 1.2), and the solution's own
reproduction RMSE (m). Seeds run in ``--jobs`` processes (each seed's numbers do not depend on it).
Writes ``benchmarks/studies/e1_viapoint/results/e1_assimilation.json``. Usage:
``python benchmarks/studies/e1_viapoint/e1_assimilation.py [--seeds 0-9] [--jobs 2] [--out FILE]``.
"""
from __future__ import annotations

import argparse
import copy
import sys
import time
from multiprocessing import get_context
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.adaptation.loop import adapt  # noqa: E402
from acnmp_core.adaptation.assimilation import AssimilationConfig, assimilate  # noqa: E402
from acnmp_core.data.demos import Demonstration  # noqa: E402
from acnmp_core.experiments import viapoint as V  # noqa: E402
from acnmp_core.model.training import reproduction_error  # noqa: E402
from benchmarks._results import provenance, save_result, study_results  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402

#: Candidates: the library's default (1000 steps), E1's setting (3000), and the anchor's weight.
CANDIDATES = {"steps_1000": {"steps": 1000}, "steps_3000": {"steps": 3000},
              "anchor_5": {"steps": 1000, "anchor_weight": 5.0}}
BUDGET, TRAIN_STEPS = 100, 3000


def seed_range(text: str) -> list[int]:
    """"0-9" or "3,5,8" -> the seeds (argparse type: a malformed value is a one-line usage error)."""
    try:
        if "-" in text:
            a, b = text.split("-")
            seeds = list(range(int(a), int(b) + 1))
        else:
            seeds = [int(s) for s in text.split(",")]
    except ValueError:
        seeds = []
    if not seeds or min(seeds) < 0:
        raise argparse.ArgumentTypeError(f'expected "0-9" or "3,5,8" (seeds >= 0), got {text!r}')
    return seeds


def run_seed(seed: int) -> dict:
    """One seed: the adaptation once, then every candidate's assimilation from a copy of its network."""
    torch.set_num_threads(1)
    setup = V.make_setup("2d")
    model = V.train_lfd(setup.demos, seed, TRAIN_STEPS)
    before = reproduction_error(model, setup.demos)
    res = adapt(model, setup.demos, setup.target, setup.task, V.adapt_config("acnmp", BUDGET), seed=seed)
    row = {"seed": seed, "adapted": bool(res.success), "rollouts": int(res.rollouts), "candidates": {}}
    if not res.success:
        return row
    for name, kw in CANDIDATES.items():
        m = copy.deepcopy(model)
        # seed + 1: the sampling seed E1's own assimilation uses
        new, _ = assimilate(m, setup.demos, Demonstration(res.times, res.trajectory), AssimilationConfig(**kw),
                            conditions=setup.target, seed=seed + 1)
        after = V.trajectory_metrics(setup, m.predict(setup.target.obs_times, setup.target.obs_values, None,
                                                      res.times).mean)
        row["candidates"][name] = {"error_after": after["error"], "success_after": bool(after["success"]),
                                   "old_demos_rmse_ratio": reproduction_error(m, setup.demos) / before,
                                   "solution_reproduction_rmse": reproduction_error(m, new.subset([len(setup.demos)]))}
    print(seed, {k: (v["success_after"], round(v["old_demos_rmse_ratio"], 2)) for k, v in row["candidates"].items()},
          flush=True)
    return row


def summarise(rows: list[dict]) -> dict:
    """Per candidate: seeds within tolerance after assimilation, and the worst old-demos ratio."""
    out = {}
    for name in CANDIDATES:
        got = [r["candidates"][name] for r in rows if name in r["candidates"]]
        out[name] = {"seeds": len(got), "success_after": sum(g["success_after"] for g in got),
                     "old_demos_rmse_ratio_max": max(g["old_demos_rmse_ratio"] for g in got),
                     "solution_reproduction_rmse_max": max(g["solution_reproduction_rmse"] for g in got)}
    return out


def main(argv: list[str] | None = None) -> int:
    """Run the candidates over the seeds; write the JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=seed_range, default="0-9", help='the seeds: "0-9" or "3,5,8" (default 0-9)')
    ap.add_argument("--jobs", type=int, default=2, help="seeds run in processes at once (default 2)")
    add_run_arguments(ap, out=str(study_results("e1_viapoint") / "e1_assimilation.json"))
    args = ap.parse_args(argv)
    meta, t0 = provenance(), time.perf_counter()
    seeds = args.seeds
    with get_context("spawn").Pool(max(1, args.jobs)) as pool:
        rows = pool.map(run_seed, seeds)
    result = {"provenance": meta, "benchmark": "e1_assimilation", "seeds": seeds,
              "candidates": CANDIDATES, "summary": summarise(rows), "runs": rows,
              "wall_time_s": round(time.perf_counter() - t0, 1)}
    return save_result(result, args.out, None, ("summary", "wall_time_s"))


if __name__ == "__main__":
    sys.exit(main())
