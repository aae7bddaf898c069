"""E5: how long the LfD model trains, and whether its rate decays, against every E5 target.

For each variant (training steps, the rate the cosine decay ends at), the whole E5 runs (5 seeds,
the three cases, LfD only and ACNMP with the default budget) and the issue-37 counts are taken
per case: LfD's physics successes, ACNMP's, and ACNMP's successes with every joint within 2 deg
of the expert. The variants are those before (3000 steps at a constant 1e-3) and after the change
of default (10000 steps decaying to 1e-5), the decay alone, and twice the steps.

The variants were compared on E5's reported seeds 0-4; ``--seeds 5-9`` checks them on seeds that
chose nothing (``benchmarks/studies/e5_ur10/results/e5_training_fresh.json``).

Writes ``benchmarks/studies/e5_ur10/results/e5_training.json``.
Usage: ``python benchmarks/studies/e5_ur10/e5_training.py [--seeds N|A-B] [--only NAME,...] [--out FILE]``
(about 20 min for the four variants on one core).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.ur10 import run_ur10  # noqa: E402
from benchmarks._results import provenance, save_result, study_results  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402
from clients.experiments.targets import E5_JOINT_DEG, e5_within_bound  # noqa: E402

#: name -> (training steps, final rate of the cosine decay or None for a constant 1e-3)
VARIANTS = {
    "steps_3000_constant": (3000, None),
    "steps_3000_cosine": (3000, 1e-5),
    "steps_10000_cosine": (10000, 1e-5),
    "steps_20000_cosine": (20000, 1e-5),
}


def counts(result: dict) -> dict:
    """Per case of an E5 result: seeds, LfD's and ACNMP's successes, ACNMP's successes with every
    joint within :data:`E5_JOINT_DEG`, ACNMP's roll-outs per seed, both methods' median joint errors."""
    out = {}
    for case, summary in result["cases"].items():
        runs = [r for r in result["runs"] if r["case"] == case]
        out[case] = {
            "seeds": len(runs),
            "lfd_success": sum(r["lfd"]["success"] for r in runs),
            "acnmp_success": sum(r["acnmp"]["success"] for r in runs),
            "acnmp_within_deg": e5_within_bound(result["runs"], case),
            "acnmp_rollouts": [r["acnmp"]["rollouts"] for r in runs],
            "lfd_joint_error_deg": summary["lfd_only"]["joint_error_deg"],
            "acnmp_joint_error_deg": summary["acnmp"]["joint_error_deg"],
        }
    return out


def variants_and_seeds(ap: argparse.ArgumentParser, args: argparse.Namespace, variants: dict) -> tuple[list[str], list[int]]:
    """The variant names of ``args.only`` (comma-separated; None: all of ``variants``) and the seeds
    of ``args.seeds`` (a count N: 0..N-1, or a range A-B); ``ap.error`` (exit 2, one line) otherwise."""
    names = list(variants) if args.only is None else [n.strip() for n in args.only.split(",") if n.strip()]
    unknown = [n for n in names if n not in variants]
    if unknown or not names:
        ap.error(f"--only: expected a subset of {','.join(variants)}, got {args.only!r}")
    try:
        first, _, last = args.seeds.partition("-")
        seeds = list(range(int(first), int(last) + 1)) if last else list(range(int(first)))
    except ValueError:
        seeds = []
    if not seeds:
        ap.error(f"--seeds: expected a count N >= 1 or a range A-B, got {args.seeds!r}")
    return names, seeds


def print_variant(name: str, cases: dict) -> None:
    """One line per case of a variant's counts: LfD's and ACNMP's successes, ACNMP's within
    E5_JOINT_DEG, ACNMP's roll-outs per seed."""
    for case, c in cases.items():
        print(f"{name} {case}: LfD {c['lfd_success']}/{c['seeds']}, ACNMP {c['acnmp_success']}/{c['seeds']}, "
              f"within {E5_JOINT_DEG:g} deg {c['acnmp_within_deg']}/{c['seeds']}, roll-outs {c['acnmp_rollouts']}",
              flush=True)


def main(argv: list[str] | None = None) -> int:
    """Run the variants; print one line per variant and case."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="5", help="a count N (seeds 0..N-1) or a range A-B (default 5)")
    ap.add_argument("--only", default=None, help=f"comma-separated subset of {','.join(VARIANTS)}")
    add_run_arguments(ap, out=str(study_results("e5_ur10") / "e5_training.json"))
    args = ap.parse_args(argv)
    names, seeds = variants_and_seeds(ap, args, VARIANTS)
    torch.set_num_threads(1)
    result = {"provenance": provenance(), "benchmark": "e5_training", "seeds": len(seeds), "seed_list": seeds,
              "joint_bound_deg": E5_JOINT_DEG, "variants": {}}
    t0 = time.perf_counter()
    for name in names:
        steps, lr_final = VARIANTS[name]
        r = run_ur10(seeds, train_steps=steps, train_lr_final=lr_final)
        result["variants"][name] = {"train_steps": steps, "train_lr_final": lr_final,
                                    "wall_time_s": r["wall_time_s"], "cases": counts(r)}
        print_variant(name, result["variants"][name]["cases"])
    result["wall_time_s"] = round(time.perf_counter() - t0, 2)
    return save_result(result, args.out)


if __name__ == "__main__":
    sys.exit(main())
