"""The default's prediction on the families that bend with their condition, beside the paper's CNMP.

For each path family of the comparison (acnmp_core/tasks/families: the bump moving in time, the
arc), the default model (``prior="auto"``) and the paper's CNMP (``prior="none"``) are trained on
the family's demonstrations (3000 steps, one training seed at a time) and predict the family's path
at evenly spaced conditions of its interpolation box and of its extrapolation box, conditioned as
the comparison conditions them (the condition and the path's start). Per family, case, model and
seed: the RMS error against the family's own path (its outputs' units), the mean over the
conditions; and what the default chose. Issue 71's bound: the default at most 1.2x the paper's.

Usage: python benchmarks/studies/method/family_errors.py [--seeds 0,1] [--conditions 5]
Writes benchmarks/studies/method/results/family_errors.json.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.data.demos import DemoSet  # noqa: E402
from acnmp_core.model.cnmp import CNMP, CNMPConfig  # noqa: E402
from acnmp_core.model.training import TrainConfig, train  # noqa: E402
from acnmp_core.tasks.families import FAMILIES, PathFamily  # noqa: E402
from benchmarks._results import save_result, start_run, study_results  # noqa: E402

STEPS = 3000


def conditions(box: np.ndarray, n: int) -> np.ndarray:
    """(n, P) conditions evenly spaced along the diagonal of ``box`` (P, 2), ends included."""
    box = np.asarray(box, dtype=np.float64)
    return box[:, 0] + np.linspace(0.0, 1.0, n)[:, None] * (box[:, 1] - box[:, 0])


def error(model: CNMP, fam: PathFamily, c: np.ndarray) -> float:
    """RMS of ``model``'s mean at condition ``c`` (P,), given the path's start, against the family's path."""
    truth = fam.path(fam.times, c)
    pred = model.predict([0.0], truth[:1], c, fam.times).mean
    return float(np.sqrt(np.mean((pred - truth) ** 2)))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0,1", help="comma-separated training seeds (default 0,1)")
    ap.add_argument("--conditions", type=int, default=5, help="conditions per case, evenly spaced (default 5)")
    ap.add_argument("--out", default=str(study_results("method") / "family_errors.json"),
                    help="the result JSON (default: the study's results/family_errors.json)")
    args, made = start_run(ap, argv, __file__)
    rows = []
    for fam in FAMILIES.values():
        times, values, params = fam.demonstrations()
        demos = DemoSet.from_arrays(times[0], values, params)
        for seed in (int(s) for s in args.seeds.split(",")):
            for prior in ("auto", "none"):
                model = CNMP(CNMPConfig(n_outputs=values.shape[-1], n_task_params=params.shape[1], prior=prior),
                             seed=seed)
                train(model, demos, TrainConfig(steps=STEPS), seed=seed, progress=False)
                for case in ("interpolation", "extrapolation"):
                    cs = conditions(getattr(fam, case), args.conditions)
                    rows.append({"family": fam.name, "prior": prior, "chosen": model.config.prior, "seed": seed,
                                 "case": case, "conditions": cs.tolist(),
                                 "rmse": float(np.mean([error(model, fam, c) for c in cs]))})
                    print(rows[-1]["family"], prior, model.config.prior, seed, case, f"{rows[-1]['rmse']:.4g}",
                          flush=True)
    return save_result({"provenance": made, "train_steps": STEPS, "rows": rows}, args.out)


if __name__ == "__main__":
    sys.exit(main())
