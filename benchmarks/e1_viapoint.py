"""E1 over several seeds: LfD-only, RL-only and ACNMP on the extrapolated via-point.

Writes benchmarks/results/e1_viapoint.json with per-seed results and medians. Usage:
    .venv/bin/python benchmarks/e1_viapoint.py [--seeds 10] [--json FILE]
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import torch

from acnmp_core.experiments.viapoint import METHODS, run_viapoint


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--budget", type=int, default=100)
    ap.add_argument("--variant", default="2d", choices=("2d", "1d"))
    ap.add_argument("--json", default=str(Path(__file__).parent / "results" / "e1_viapoint.json"))
    ap.add_argument("--adapt", action="append", default=[], metavar="KEY=VALUE",
                    help="override an AdaptConfig field, e.g. --adapt explore_scale=0.5")
    args = ap.parse_args(argv)
    overrides = {k: json.loads(v) for k, v in (a.split("=", 1) for a in args.adapt)}
    torch.set_num_threads(1)
    t0 = time.perf_counter()
    runs = []
    for seed in range(args.seeds):
        s = run_viapoint(seed, args.variant, budget=args.budget, progress=False, adapt_overrides=overrides).summary
        runs.append(s)
        print(seed, {m: (r["rollouts"], r["success"], round(r["shape_error"], 4)) for m, r in s["methods"].items()},
              f"{s['wall_time_s']:.1f}s", flush=True)
    agg = {}
    for m in METHODS:
        rs = [r["methods"][m] for r in runs]
        ok = [r["rollouts"] for r in rs if r["success"]]
        agg[m] = {
            "success_rate": float(np.mean([r["success"] for r in rs])),
            "rollouts_median_successful": float(np.median(ok)) if ok else None,
            "rollouts_median": float(np.median([r["rollouts"] for r in rs])),
            "within_35_rate": float(np.mean([r["success"] and r["rollouts"] <= 35 for r in rs])),
            "error_median": float(np.median([r["error"] for r in rs])),
            "shape_error_median": float(np.median([r["shape_error"] for r in rs])),
        }
    out = {
        "experiment": "viapoint", "variant": args.variant, "seeds": args.seeds, "budget": args.budget,
        "adapt_overrides": overrides,
        "wall_time_s": round(time.perf_counter() - t0, 1),
        "wall_time_per_run_s_median": float(np.median([r["wall_time_s"] for r in runs])),
        "methods": agg,
        "shape_error_ratio_rl_only_over_acnmp": agg["rl_only"]["shape_error_median"] / agg["acnmp"]["shape_error_median"],
        "runs": runs,
    }
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(out, indent=2))
    print(json.dumps({k: v for k, v in out.items() if k != "runs"}, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
