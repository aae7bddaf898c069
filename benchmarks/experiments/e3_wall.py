"""E3 benchmark: self-improvement over wall-with-a-hole environments, ACNMP vs ProMP + RL, one run.

Writes benchmarks/results/e3_wall.json (with its provenance) and e3_wall.png (the paper's
Fig. 5 d, e). Usage: ``python benchmarks/experiments/e3_wall.py [--envs N] [--seed S] [--threads N] [--out FILE]``;
the default is 1500 new environments after 30 demonstrated ones, tested on 1000, the generated
paths moved onto their start and goal (``--snap-paths none``: the paper's variant); ``--recipe default`` runs the product's default method instead of the paper's
(acnmp_core/experiments/recipe.py) and writes e3_wall_default.json. The settings
are the library's defaults, the same as ``acnmp experiment wall``: training, adaptation and
assimilation at one torch thread (acnmp_core/threads.py), which ``--threads N`` changes as the CLI's
option does; on the CPU ``bench_e3_threads.py`` measured, the thread count changes the time, not
the numbers.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from acnmp_core.adaptation.assimilation import ASSIMILATE_FROM  # noqa: E402
from acnmp_core.experiments.wall import TRAIN_DEFAULTS, run_wall  # noqa: E402
from acnmp_core.experiments.plots import plot_wall  # noqa: E402
from benchmarks._results import RESULTS, provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments, apply_threads, output_path, recipe_of  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    """Run E3 with the default settings; print the test curve as it goes and the summary."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_run_arguments(ap, seed=0, envs=1500, eval_every=50)
    ap.add_argument("--assimilate-from", choices=ASSIMILATE_FROM, default=TRAIN_DEFAULTS["assimilate_from"],
                    help="the network ACNMP's assimilation continues from (see run_wall)")
    ap.add_argument("--snap-paths", choices=("none", "generated", "all"), default="generated",
                    help="as acnmp experiment wall: 'generated' (default, boundary conditions enforced), 'none' "
                         "(the paper's variant, paths as generated), 'all' (the adaptations' roll-outs too)")
    add_run_arguments(ap, threads=True, recipe=True, out=RESULTS / "e3_wall.json")
    args = ap.parse_args(argv)
    apply_threads(args)
    meta = provenance()
    result = {"provenance": meta, **run_wall(args.envs, args.seed, eval_every=args.eval_every,
                                               assimilate_from=args.assimilate_from,
                                               snap_outputs=args.snap_paths != "none",
                                               snap_rollouts=args.snap_paths == "all", log=lambda s: print(s, flush=True),
                                               recipe=recipe_of(args))}
    return save_result(result, output_path(args), plot_wall, ("methods", "trajectory_ratio_promp_over_acnmp", "wall_time_s"))


if __name__ == "__main__":
    sys.exit(main())
