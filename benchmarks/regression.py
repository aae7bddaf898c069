"""The pinned regression runs: small, exact versions of E1, E2 and E3 that guard the defaults.

``benchmarks/results/regression.json`` holds, for E1 seed 0 (all three methods), E2 seed 0 (both
cases, both methods) and E3 with 20 new environments and 200 test environments (both methods),
the exact roll-out counts and successes. ``tests/unit/test_published_numbers.py`` re-runs them and fails on any
difference, so a change of a default, of the algorithm or of a task cannot silently change the
published numbers: whoever changes them re-runs the full benchmarks and this pin in the same commit.

Usage::

    python benchmarks/regression.py           # measure and compare with the pin (exit 1 on a difference)
    python benchmarks/regression.py --write   # measure and write the pin
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
PIN = ROOT / "benchmarks" / "results" / "regression.json"
#: E3's pinned size: new environments, test environments.
E3_ENVS, E3_TEST = 20, 200


def measure_e1() -> dict:
    """E1 seed 0: per method, roll-outs and success."""
    from acnmp_core.experiments.viapoint import run_viapoint

    s = run_viapoint(0, progress=False, assimilation_steps=0).summary
    return {m: {"rollouts": r["rollouts"], "success": r["success"]} for m, r in s["methods"].items()}


def measure_e2() -> dict:
    """E2 seed 0: per method and case, roll-outs and success."""
    from acnmp_core.experiments.push import run_push

    r = run_push([0])
    return {run["method"] + "/" + run["case"]: {"rollouts": run["rollouts"], "success": run["success"]}
            for run in r["runs"]}


def measure_e3() -> dict:
    """E3 with E3_ENVS new and E3_TEST test environments: per method, roll-outs per environment,
    whether each adaptation succeeded, and the final test success rate."""
    from acnmp_core.experiments.wall import run_wall

    r = run_wall(E3_ENVS, 0, n_test=E3_TEST, eval_every=E3_ENVS)
    return {m: {"rollouts_per_env": r["rollouts_per_env"][m], "test_success_rate": s["test_success_rate"],
                "adaptations_failed": s["adaptations_failed"]} for m, s in r["methods"].items()}


def measure() -> dict:
    """All pinned quantities (single-threaded torch, as the benchmarks run)."""
    torch.set_num_threads(1)
    return {"e1_seed0": measure_e1(), "e2_seed0": measure_e2(), "e3_envs20": measure_e3()}


def differences(pinned: dict, measured: dict, path: str = "") -> list[str]:
    """'path: pinned -> measured' for every leaf that differs."""
    if isinstance(pinned, dict) and isinstance(measured, dict):
        out = []
        for k in sorted(set(pinned) | set(measured)):
            out += differences(pinned.get(k), measured.get(k), f"{path}/{k}" if path else k)
        return out
    return [] if pinned == measured else [f"{path}: {pinned!r} -> {measured!r}"]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="write the pin instead of comparing with it")
    args = ap.parse_args(argv)
    from clients.provenance import provenance

    meta = provenance()
    measured = measure()
    if args.write:
        PIN.write_text(json.dumps({"provenance": meta, **measured}, indent=2) + "\n")
        print(f"wrote {PIN}")
        return 0
    pinned = {k: v for k, v in json.loads(PIN.read_text()).items() if k != "provenance"}
    diff = differences(pinned, measured)
    for line in diff:
        print(line)
    print("regression: identical" if not diff else f"regression: {len(diff)} difference(s)")
    return 1 if diff else 0


if __name__ == "__main__":
    sys.exit(main())
