"""The study behind the default adaptation (issue 64): candidate ACNMP variants, each measured on the
tasks of the peers comparison, with the same seeds, test conditions and budget as the comparison.

A candidate is a model (the CNMP alone, or with the demonstrations' linear path) and adaptation
settings. Every candidate runs through the comparison's own code (``acnmp_core.experiments.peers``),
so its numbers are comparable with peers.json run for run.

Usage:
  python benchmarks/studies/method/study.py                                  # both candidates, every task
  python benchmarks/studies/method/study.py --candidates linear --tasks e2-push,pusher --cases extrapolation
  python benchmarks/studies/method/study.py --list        # the candidates and what each changes
Runs already in --out are kept (the study resumes).
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.adaptation.config import AdaptConfig  # noqa: E402
from acnmp_core.experiments.peers import PeersConfig, TASK_NAMES, peer_task, run_line, summarise  # noqa: E402
from acnmp_core.experiments.peers.config import PeerRun  # noqa: E402
from acnmp_core.experiments.peers.methods import Variant, acnmp_run  # noqa: E402
from benchmarks._results import development_seeds, provenance, study_results  # noqa: E402

#: candidate -> (the model's linear path, whether the network's conditions are clipped, AdaptConfig
#: fields over the paper's method, what it is). The two ends of the ladder need no run of their own:
#: the paper's method and the default are ``acnmp_paper`` and ``acnmp`` of the comparison of record.
CANDIDATES = {
    "linear": ("linear", False, {}, "the paper's method on the CNMP with the demonstrations' linear path"),
    "linear_clip": ("linear", True, {}, "as linear, the network's conditions clipped to the demonstrations' ranges"),
}


def variant(name: str) -> Variant:
    prior, clip, fields, _ = CANDIDATES[name]
    return Variant(prior, lambda budget: AdaptConfig.paper(**{**fields, "max_rollouts": budget}), clip)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--candidates", default=",".join(CANDIDATES), help="comma-separated candidates (default: all; --list)")
    ap.add_argument("--tasks", default=",".join(TASK_NAMES), help="comma-separated tasks")
    ap.add_argument("--cases", default="extrapolation,interpolation", help="comma-separated cases (default: both)")
    ap.add_argument("--seeds", type=development_seeds, default=(0, 1, 2, 3, 4),
                    help="comma-separated development seeds (default 0,1,2,3,4; the report seeds are refused)")
    ap.add_argument("--budget", type=int, default=1000, help="episodes per run (default 1000, the comparison's)")
    ap.add_argument("--out", default=str(study_results("method") / "method_study.json"),
                    help="the result (default benchmarks/studies/method/results/method_study.json); its runs are kept")
    ap.add_argument("--list", action="store_true", help="print the candidates and exit")
    args = ap.parse_args(argv)
    if args.list:
        for name, (prior, clip, fields, what) in CANDIDATES.items():
            print(f"{name:<26} prior={prior} clip={clip} {fields}: {what}")
        return 0
    torch.set_num_threads(1)
    names = [c for c in args.candidates.split(",") if c]
    unknown = [c for c in names if c not in CANDIDATES]
    if unknown:
        ap.error(f"--candidates: unknown {unknown}; --list names them")
    variants = {name: variant(name) for name in names}
    seeds = args.seeds
    config = PeersConfig(tasks=tuple(args.tasks.split(",")), methods=("acnmp",), seeds=seeds,
                         cases=tuple(args.cases.split(",")), budget=args.budget)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    old = json.loads(out.read_text()) if out.exists() else {}
    runs = [PeerRun.from_json(r) for r in old.get("runs", [])]
    done = {r.key for r in runs}
    meta = provenance()
    for kind in config.tasks:
        task = peer_task(kind)
        state: dict = {}
        try:
            for seed in seeds:
                for case in [c for c in config.cases if c in task.cases]:
                    for name in names:
                        if (kind, name, seed, case) in done:
                            continue
                        r = acnmp_run(task, config, seed, case, name, state, variants)
                        runs.append(r)
                        print(run_line(r), flush=True)
                        out.write_text(json.dumps({"provenance": meta, "candidates": {
                            n: {"prior": CANDIDATES[n][0], "clip": CANDIDATES[n][1], "adapt": CANDIDATES[n][2],
                                "what": CANDIDATES[n][3]} for n in CANDIDATES},
                            "budget": args.budget, "runs": [x.to_json() for x in runs],
                            "summary": summarise(runs)}, indent=1) + "\n")
        finally:
            task.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
