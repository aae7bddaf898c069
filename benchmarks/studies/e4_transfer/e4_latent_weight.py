"""E4's alignment weight: what the latent alignment weight does to a transfer pair, on the authors'
arrays and on our proxy skills.

For each weight (default 0, 1e3 and the authors' 5e6) one pair of E4's settings
(:class:`~acnmp_core.experiments.transfer.TransferExperimentConfig`, seed 0) is trained on (1) the
authors' proxy arrays, giving the RMSE (rad) of their transferred button press against the 4-DoF
ground truth, and (2) our proxy skills, giving the transferred first trajectory's RMSE (rad) to what
the scripted expert shows on robot B and the cube's final distance (m) to the goal. Each also records
the last 100 steps' mean NLL of both decoders and the latent MSE. Writes
benchmarks/studies/e4_transfer/results/e4_latent_weight.json. Usage: ``python benchmarks/studies/e4_transfer/e4_latent_weight.py [--weights W ...]``.
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.transfer import (AUTHORS_DATA, TransferExperimentConfig, authors_data_check,  # noqa: E402
                                             make_setup, paired_latent_distance, task_config)
from acnmp_core.tasks.transfer.scene import CubeGapTask  # noqa: E402
from acnmp_core.transfer.pair import TransferPair, spread_observations, train_pair  # noqa: E402
from benchmarks._results import save_result, start_run, study_results  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    """Train one pair per weight and data set; print and save the measurements."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--weights", type=float, nargs="+", default=[0.0, 1e3, 5e6], metavar="W",
                    help="latent alignment weights, one pair each (default 0 1e3 5e6)")
    add_run_arguments(ap, out=str(study_results("e4_transfer") / "e4_latent_weight.json"))
    args, meta = start_run(ap, argv)
    base = TransferExperimentConfig()
    setup = make_setup()
    rows = []
    with CubeGapTask(**task_config()) as task:
        for w in args.weights:
            cfg = replace(base.pair, latent_weight=w)
            authors = authors_data_check(cfg, 0, AUTHORS_DATA, base.n_obs)
            pair = TransferPair(3, 4, cfg, seed=0)
            hist = train_pair(pair, setup.demos_a, setup.demos_b, cfg, seed=0)
            pred = pair.transfer(*spread_observations(setup.times, setup.new_a, base.n_obs), setup.times)
            cube = float(task.evaluate(pred.mean[None], setup.times).errors[0])
            row = {"latent_weight": w, "authors_data": authors,
                   "ours": {"rmse_to_expert": float(np.sqrt(np.mean((pred.mean - setup.expert_b) ** 2))),
                            "cube_error": cube, "paired_latent_distance": paired_latent_distance(pair, setup),
                            "nll_a": float(np.mean(hist.nll_a[-100:])), "nll_b": float(np.mean(hist.nll_b[-100:])),
                            "latent_mse": float(np.mean(hist.align[-100:]))}}
            rows.append(row)
            print(row, flush=True)
    result = {"provenance": meta, "experiment": "transfer_latent_weight", "config": base.pair.to_dict(),
              "weights": rows}
    return save_result(result, args.out, None, ("weights",))


if __name__ == "__main__":
    sys.exit(main())
