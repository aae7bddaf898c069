"""E5: exploring in the demonstrations' directions, with and without task-parameter jitter in the
LfD model's training, against every E5 target.

Why: ACNMP's reward at E5 is the paper's (the TCP's distances to the grasp and the
obstacle-avoidance points at two steps). It says nothing about the tool's pitch nor about wrist 3,
so per-step noise on each joint (the default, ``noise="rbf"``) can succeed with joints far from the
expert's; and the LfD model drifts, when extrapolated, on joints the demonstrations never vary
(shoulder pan, wrist 2, wrist 3), which no reward on the TCP corrects. The variants:

* ``default``: E5 as published (no jitter, per-step noise);
* ``demo_noise``: ``AdaptConfig(noise="demos")`` (:class:`~acnmp_core.adaptation.exploration.DemoNoise`,
  episode credit);
* ``jitter_X_demo_noise``: the LfD model trained with ``TrainConfig(task_param_jitter=X)``, then
  demonstration-shaped noise;
* ``jitter_0.3_rbf``: that model with the default noise (which of the two does the work);
* ``mixup``: the LfD model trained on blends of demonstration pairs (``TrainConfig(mixup=1)``),
  the default noise.

Each variant runs the whole E5 (the three cases, LfD only and ACNMP, budget 60) on every seed; the
counts are issue 37's: LfD's and ACNMP's physics successes and ACNMP's successes with every joint
within 2 deg. (variant, seed) pairs run in ``--jobs`` processes (one seed's numbers do not depend
on it).

Writes ``benchmarks/studies/e5_ur10/results/e5_exploration.json``.
Usage: ``python benchmarks/studies/e5_ur10/e5_exploration.py [--seeds N|A-B] [--only NAME,...] [--jobs 2]``
(about 25 min for the five variants on seeds 0-9 with two processes).
"""
from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.adaptation.config import AdaptConfig  # noqa: E402
from acnmp_core.experiments.ur10 import BUDGET, run_ur10  # noqa: E402
from acnmp_core.threads import set_training_threads  # noqa: E402
from benchmarks._results import provenance, save_result, study_results  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402
from benchmarks.studies.e5_ur10.e5_training import print_variant, variants_and_seeds  # noqa: E402
from clients.experiments.targets import E5_JOINT_DEG, e5_within_bound  # noqa: E402

#: name -> (task-parameter jitter of the LfD model's training, its mixup probability, exploration noise)
VARIANTS = {
    "default": (0.0, 0.0, "rbf"),
    "demo_noise": (0.0, 0.0, "demos"),
    "jitter_0.1_demo_noise": (0.1, 0.0, "demos"),
    "jitter_0.3_demo_noise": (0.3, 0.0, "demos"),
    "jitter_0.3_rbf": (0.3, 0.0, "rbf"),
    "mixup": (0.0, 1.0, "rbf"),
}


def run_one(name: str, seed: int) -> dict:
    """One seed of one variant: run_ur10's result (its runs carry the seed)."""
    set_training_threads(1)
    jitter, mixup, noise = VARIANTS[name]
    return run_ur10([seed], train_task_param_jitter=jitter, train_mixup=mixup,
                    adapt_config=AdaptConfig.paper(max_rollouts=BUDGET, noise=noise))


def counts(runs: list[dict], case: str) -> dict:
    """At ``case``: seeds, LfD's and ACNMP's successes, ACNMP's successes within E5_JOINT_DEG, and
    per seed ACNMP's roll-outs and both methods' largest joint error (deg)."""
    rs = [r for r in runs if r["case"] == case]
    return {
        "seeds": len(rs),
        "lfd_success": sum(r["lfd"]["success"] for r in rs),
        "acnmp_success": sum(r["acnmp"]["success"] for r in rs),
        "acnmp_within_deg": e5_within_bound(rs, case),
        "acnmp_rollouts": [r["acnmp"]["rollouts"] for r in rs],
        "lfd_max_joint_error_deg": [round(max(r["lfd"]["joint_error_deg"]), 3) for r in rs],
        "acnmp_max_joint_error_deg": [round(max(r["acnmp"]["joint_error_deg"]), 3) for r in rs],
        "lfd_joint_error_deg": [[round(v, 3) for v in r["lfd"]["joint_error_deg"]] for r in rs],
        "acnmp_joint_error_deg": [[round(v, 3) for v in r["acnmp"]["joint_error_deg"]] for r in rs],
    }


def main(argv: list[str] | None = None) -> int:
    """Run the variants; print one line per variant and case."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="10", help="a count N (seeds 0..N-1) or a range A-B (default 10)")
    ap.add_argument("--only", default=None, help=f"comma-separated subset of {','.join(VARIANTS)}")
    ap.add_argument("--jobs", type=int, default=2, help="processes (default 2)")
    add_run_arguments(ap, out=str(study_results("e5_ur10") / "e5_exploration.json"))
    args = ap.parse_args(argv)
    names, seeds = variants_and_seeds(ap, args, VARIANTS)
    if args.jobs < 1:
        ap.error(f"--jobs: expected >= 1, got {args.jobs}")
    prov = provenance()  # the code the run starts from
    t0 = time.perf_counter()
    with ProcessPoolExecutor(args.jobs, mp_context=get_context("spawn")) as pool:
        futures = {(n, s): pool.submit(run_one, n, s) for n in names for s in seeds}
        results = {key: f.result() for key, f in futures.items()}
    out = {"provenance": prov, "benchmark": "e5_exploration", "seeds": len(seeds), "seed_list": seeds,
           "joint_bound_deg": E5_JOINT_DEG, "jobs": args.jobs, "variants": {}}
    for name in names:
        jitter, mixup, noise = VARIANTS[name]
        runs = [run for s in seeds for run in results[(name, s)]["runs"]]
        cases = results[(name, seeds[0])]["cases"]
        out["variants"][name] = {"train_task_param_jitter": jitter, "train_mixup": mixup, "noise": noise,
                                 "cases": {c: counts(runs, c) for c in cases}}
        print_variant(name, out["variants"][name]["cases"])
    out["wall_time_s"] = round(time.perf_counter() - t0, 2)
    return save_result(out, args.out)


if __name__ == "__main__":
    sys.exit(main())
