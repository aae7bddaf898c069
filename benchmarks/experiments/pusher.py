"""The Pusher-v5 worked example (issue 33): LfD only, ACNMP and ProMP + RL at positions beyond the
demonstrations, 10 seeds, in one process.

Writes benchmarks/results/pusher.json (provenance, the result of ``run_pusher``) and pusher.png.
Usage: ``python benchmarks/experiments/pusher.py [--seeds N] [--out FILE]``; the settings are the library's
defaults, the same as ``acnmp experiment pusher``.
"""
from __future__ import annotations

import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.pusher import plot_pusher, run_pusher  # noqa: E402
from benchmarks._results import benchmark_args, provenance, save_result  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    """Run the example with the default settings; print one line per run and the summary."""
    args = benchmark_args(__doc__, "pusher", argv, seeds=10)
    torch.set_num_threads(1)
    meta = provenance()
    result = {"provenance": meta, **run_pusher(args.seeds, log=lambda s: print(s, flush=True))}
    return save_result(result, args.out, plot_pusher, ("methods", "rollout_ratio_promp_over_acnmp", "wall_time_s"))


if __name__ == "__main__":
    sys.exit(main())
