"""What is adapted stays learnt: a solution assimilated beyond the demonstrations' range, answered
there afterwards, and the demonstrations at the edge kept.

One task parameter: seven demonstrations, an amplitude ``0.5 + c`` times one shape for c in
[0, 0.6]; a solution at c = 0.9 that is not the family's linear extrapolation (a bump more, as an
adaptation finds). Per model kind (the default's choice, the network with the demonstrations'
trend beyond its range, the network alone, and the previous default: the linear path beside the
network) and training seed: the error of the skill's prediction at c = 0.9 against the
solution and at the edge demonstration (c = 0.6) against it, before and after ``assimilate`` with
the library's defaults (1000 steps, the anchor on the adaptation's conditions).

Usage: python benchmarks/studies/method/assimilation_beyond.py [--seeds 0,1]
Writes benchmarks/studies/method/results/assimilation_beyond.json.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.adaptation.assimilation import assimilate  # noqa: E402
from acnmp_core.adaptation.config import AdaptTarget, AssimilationConfig  # noqa: E402
from acnmp_core.data.demos import DemoSet, Demonstration  # noqa: E402
from acnmp_core.model.cnmp import CNMP, CNMPConfig  # noqa: E402
from acnmp_core.model.training import TrainConfig, train  # noqa: E402
from benchmarks._results import save_result, start_run, study_results  # noqa: E402

T = np.linspace(0.0, 1.0, 60)
CS = np.linspace(0.0, 0.6, 7)
C_SOLUTION = 0.9


def shape(t: np.ndarray) -> np.ndarray:
    return np.exp(-((t - 0.3) ** 2) / 0.02) - 0.5 * np.exp(-((t - 0.7) ** 2) / 0.01)


def family() -> tuple[DemoSet, np.ndarray]:
    """The demonstrations and the solution at c = 0.9 (T, 1)."""
    demos = DemoSet.from_arrays(T, np.stack([(0.5 + c) * shape(T)[:, None] for c in CS]), CS[:, None])
    solution = (1.4 * shape(T) + 0.15 * np.exp(-((T - 0.5) ** 2) / 0.005))[:, None]
    return demos, solution


def rms(model: CNMP, c: float, truth: np.ndarray) -> float:
    """RMS of the model's prediction at condition ``c`` (from ``truth``'s start) against ``truth``."""
    return float(np.sqrt(np.mean((model.predict([0.0], truth[:1], [c], T).mean - truth) ** 2)))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0,1", help="comma-separated training seeds (default 0,1)")
    ap.add_argument("--out", default=str(study_results("method") / "assimilation_beyond.json"),
                    help="the result JSON (default: the study's results/assimilation_beyond.json)")
    args, made = start_run(ap, argv, __file__)
    demos, solution = family()
    edge = demos[-1].values
    rows = []
    for prior in ("auto", "trend", "none", "linear"):
        for seed in (int(s) for s in args.seeds.split(",")):
            model = CNMP(CNMPConfig(n_outputs=1, n_task_params=1, prior=prior), seed=seed)
            train(model, demos, TrainConfig(steps=3000), seed=seed, progress=False)
            before = {"solution": rms(model, C_SOLUTION, solution), "edge": rms(model, 0.6, edge)}
            target = AdaptTarget(np.array([0.0]), solution[:1], np.array([C_SOLUTION]), T)
            assimilate(model, demos, Demonstration(T, solution, np.array([C_SOLUTION])), AssimilationConfig(),
                       conditions=target, seed=seed)
            after = {"solution": rms(model, C_SOLUTION, solution), "edge": rms(model, 0.6, edge)}
            rows.append({"prior": prior, "chosen": model.config.prior, "seed": seed, "before": before, "after": after})
            print(rows[-1], flush=True)
    return save_result({"provenance": made, "c_solution": C_SOLUTION, "rows": rows}, args.out)


if __name__ == "__main__":
    sys.exit(main())
