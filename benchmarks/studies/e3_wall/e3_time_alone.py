"""E3's time per seed with each seed alone on the machine, at the default settings.

The ten-seed table (``e3_wall.json`` for seed 0, ``e3_seeds.json`` for seeds 1-9) ran seeds 1-9 two
at a time, sharing the two cores. This combines ``benchmarks/experiments/e3_wall.py --seed S`` runs
made one after another, each alone on the machine with the defaults (training, adaptation and
assimilation at one torch thread, acnmp_core/threads.py), as ``acnmp experiment wall`` runs for a
user, and compares every number but the times with the ten-seed table's.

    for s in 0 1 2 3 4 5 6 7 8 9; do python benchmarks/experiments/e3_wall.py --seed $s --out runs/s$s.json; done
    python benchmarks/studies/e3_wall/e3_time_alone.py runs/s*.json --out benchmarks/results/e3_time_alone.json
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from benchmarks._results import provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402
from benchmarks.blocks.e3 import e3_seed_runs  # noqa: E402

#: the summary entries that are times, not results
TIME_KEYS = ("time_s",)


def same_results(a: dict, b: dict) -> bool:
    """True when two summaries agree in every entry but the times."""
    keys = (set(a) | set(b)) - set(TIME_KEYS)
    return all(a.get(k) == b.get(k) for k in keys)


def combine(paths: list[Path]) -> dict:
    """One record per seed run (e3_wall.py JSON files) with the ten-seed table's time beside it."""
    _, _, reference = e3_seed_runs()
    seeds, parts, wall = {}, [], 0.0
    for path in paths:
        run = json.loads(path.read_text())
        seed = str(run["seed"])
        if seed in seeds:
            raise SystemExit(f"{path}: seed {seed} given twice")
        if seed not in reference:
            raise SystemExit(f"{path}: seed {seed} is not in the ten-seed table")
        parts.append(run["provenance"])
        wall += run["wall_time_s"]
        ref = reference[seed]
        seeds[seed] = {
            "acnmp_time_s": run["methods"]["acnmp"]["time_s"],
            "promp_rl_time_s": run["methods"]["promp_rl"]["time_s"],
            "acnmp_time_s_ten_seed_table": ref["acnmp"]["time_s"],
            "adaptations": run["methods"]["acnmp"]["adaptations"],
            "adaptations_failed": run["methods"]["acnmp"]["adaptations_failed"],
            "test_success_rate": run["methods"]["acnmp"]["test_success_rate"],
            "same_results_as_ten_seed_table": all(same_results(run["methods"][m], ref[m]) for m in run["methods"]),
        }
    times = [s["acnmp_time_s"] for s in seeds.values()]
    return {"experiment": "e3_time_alone", "seeds": dict(sorted(seeds.items(), key=lambda kv: int(kv[0]))),
            "acnmp_time_s_median": statistics.median(times),
            "acnmp_time_s_max": max(times),
            "seeds_within_120_s": sum(t <= 120 for t in times),
            "wall_time_s": wall, "combined_from": parts}


def main(argv: list[str] | None = None) -> int:
    """Combine e3_wall.py runs into one JSON (``--out``) and print the times per seed."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path, help="e3_wall.py JSON files, one per seed")
    add_run_arguments(ap, out=str(ROOT / "benchmarks" / "results" / "e3_time_alone.json"))
    args = ap.parse_args(argv)
    result = {"provenance": provenance(), **combine(args.runs)}
    for seed, s in result["seeds"].items():
        print(f"seed {seed}: ACNMP {s['acnmp_time_s']:.0f} s alone, "
              f"{s['acnmp_time_s_ten_seed_table']:.0f} s in the ten-seed table; {s['adaptations']} adaptations "
              f"({s['adaptations_failed']} failed); same results: {s['same_results_as_ten_seed_table']}")
    return save_result(result, args.out, None, ("acnmp_time_s_median", "acnmp_time_s_max", "seeds_within_120_s"))


if __name__ == "__main__":
    sys.exit(main())
