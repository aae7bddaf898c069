"""The default that selects itself: which model each task's demonstrations choose, and how the
candidate searches do where the first trajectory misses, on the development seeds only.

Two parts:

* ``--part errors`` (the demonstrations alone): for every task of the comparison, the held-out
  error at the edges of the demonstrations' conditions (acnmp_core/model/selection.py) of the
  linear path alone, the linear path with the network's residual (the previous default), the
  network with the linear trend beyond its range and the network alone, and what the default
  chooses (between the last two). It is the measured reason a task is or is not linear in its conditions.
  Writes ``results/selection_errors.json``.
* ``--part runs`` (development seeds 0-4): the default model (``auto``) with each candidate search
  after a first trajectory that missed, at the comparison's test conditions and budget:

  - ``auto``: the default adaptation (RL with simultaneous SL on the network, the mean first);
  - ``auto_demos``: the same, exploring along the demonstrations' deviations (``noise="demos"``);
  - ``auto_cma``: CMA-ES (the ``cma`` package) over basis weights added to the model's mean, in
    the coordinates whitened by the demonstrations' weight covariance (step 1: one standard
    deviation of the demonstrations), the search's mean executed first in every generation.

  Writes ``results/selection_runs.json`` (every candidate's runs, kept or dropped).

Usage:
  python benchmarks/studies/method/selection_study.py --part errors
  python benchmarks/studies/method/selection_study.py --part runs --tasks e2-push,pusher --cases extrapolation
"""
from __future__ import annotations

import argparse
import copy
import json
import sys
import time
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.adaptation.config import AdaptConfig  # noqa: E402
from acnmp_core.experiments.peers import PeerRun, PeersConfig, peer_task, run_line, summarise  # noqa: E402
from acnmp_core.experiments.peers.config import TASK_NAMES  # noqa: E402
from acnmp_core.experiments.peers.methods import Variant, _model, acnmp_run  # noqa: E402
from acnmp_core.model.selection import CANDIDATES as MODELS, held_out_errors  # noqa: E402
from acnmp_core.model.training import TrainConfig, fold_trainer  # noqa: E402
from benchmarks._results import development_seeds, provenance, study_results  # noqa: E402

CANDIDATES = {
    "auto": "the default model; the default adaptation (the network's RL with SL, the mean first)",
    "auto_demos": "the default model; the default adaptation exploring along the demonstrations' deviations",
    "auto_cma": "the default model; CMA-ES over basis weights added to its mean, whitened by the demonstrations' "
                "weight covariance",
}
VARIANTS = {"auto": Variant("auto", lambda b: AdaptConfig(max_rollouts=b)),
            "auto_demos": Variant("auto", lambda b: AdaptConfig(max_rollouts=b, noise="demos"))}


def errors_part(tasks: list[str], steps: int, out: Path) -> None:
    """Every task's held-out errors at the edges (the module docstring's first part)."""
    rows = {}
    for kind in tasks:
        task = peer_task(kind)
        try:
            a = task.arrays
            demos = a.to_demo_set()
            from acnmp_core.model.cnmp import CNMPConfig

            cfg = CNMPConfig(n_outputs=a.values.shape[2], n_task_params=a.task_params.shape[1])
            t0 = time.perf_counter()
            errors, folds = held_out_errors(demos, cfg, fold_trainer(TrainConfig(steps=steps), 0), seed=0,
                                            candidates=("path", "linear", "trend", "none"))
            chosen = min(MODELS, key=lambda c: (round(errors[c], 9), MODELS.index(c)))
            rows[kind] = {"errors": errors, "folds": [list(f) for f in folds], "chosen": chosen,
                          "n_demos": len(demos), "time_s": round(time.perf_counter() - t0, 1)}
            print(kind, {k: round(v, 4) for k, v in errors.items()}, "->", chosen, flush=True)
        finally:
            task.close()
        out.write_text(json.dumps({"provenance": provenance(), "train_steps": steps, "tasks": rows}, indent=1) + "\n")


def cma_search(model, demos, target, evaluator, budget: int, seed: int) -> dict:
    """``auto_cma``: the model's mean once, then CMA-ES over basis weights added to it (the module
    docstring). Returns episodes, success and the error curve."""
    import cma

    from acnmp_core.model.prior import LinearPrior

    q = target.query(model)
    mean = model.predict_query(q).mean
    times = np.asarray(target.query_times, dtype=np.float64)
    params = None if target.task_params is None else np.asarray(target.task_params, dtype=np.float64)
    first = evaluator.evaluate(mean[None], times, params)
    curve = [[1, float(first.errors[0]) if first.errors is not None else None]]
    if first.success[0]:
        return {"episodes": 1, "success": True, "curve": curve}
    prior = model.prior
    if prior is None:  # the network alone: the demonstrations' weights fitted for the search's covariance
        packed = model.pack(demos)
        prior = LinearPrior(model.config.n_outputs, model.config.n_task_params, 10).fit(
            packed.times[..., 0].numpy(), packed.values.numpy(), packed.task_params.numpy(), packed.lengths.numpy())
    m = prior.n_outputs * prior.n_basis
    chol = np.linalg.cholesky(prior.cov.numpy()[:m, :m] + 1e-6 * np.eye(m))
    phi = prior.basis(q.tgt_x[0, :, 0].numpy().astype(np.float64))  # (T, K)
    scale = model.value_norm.scale.numpy()

    def trajectories(zs: np.ndarray) -> np.ndarray:
        w = (np.atleast_2d(zs) @ chol.T).reshape(-1, prior.n_outputs, prior.n_basis)
        return mean[None] + np.einsum("tk,bdk->btd", phi, w) * scale

    es = cma.CMAEvolutionStrategy(np.zeros(m), 1.0, {"seed": int(seed) + 1, "verbose": -9})
    used, success = 1, False
    while used < budget:
        r = evaluator.evaluate(trajectories(es.mean), times, params)
        used += 1
        curve.append([used, float(r.errors[0]) if r.errors is not None else None])
        if r.success[0]:
            success = True
            break
        xs = es.ask()[:budget - used]
        if not xs:
            break
        batch = evaluator.evaluate(trajectories(np.array(xs)), times, params)
        used += len(xs)
        if len(xs) == es.popsize:
            es.tell(xs, [-float(x) for x in batch.returns])
    return {"episodes": used, "success": success, "curve": curve}


def runs_part(tasks: list[str], cases: list[str], seeds: tuple[int, ...], names: list[str], budget: int,
              out: Path) -> None:
    """The candidates' runs (the module docstring's second part), kept in ``out`` and resumed."""
    config = PeersConfig(tasks=tuple(tasks), methods=("acnmp",), seeds=seeds, cases=tuple(cases), budget=budget)
    old = json.loads(out.read_text()) if out.exists() else {}
    runs = [PeerRun.from_json(r) for r in old.get("runs", [])]
    done = {r.key for r in runs}
    meta = provenance()
    for kind in tasks:
        task = peer_task(kind)
        state: dict = {}
        try:
            for seed in seeds:
                for case in [c for c in cases if c in task.cases]:
                    for name in names:
                        if (kind, name, seed, case) in done:
                            continue
                        t0 = time.perf_counter()
                        if name in VARIANTS:
                            r = acnmp_run(task, config, seed, case, name, state, VARIANTS)
                        else:
                            model, train_s = _model(task, config, seed, VARIANTS["auto"], state)
                            t1 = time.perf_counter()
                            res = cma_search(copy.deepcopy(model), task.arrays.to_demo_set(), task.target(seed, case),
                                             task.evaluator(name), budget, seed)
                            r = PeerRun(kind, name, seed, case, task.params(seed, case).tolist(), res["episodes"],
                                        res["success"], budget, round(time.perf_counter() - t1, 2),
                                        {"curve": res["curve"], "train_s": train_s, "prior": model.config.prior})
                        r.wall_s = round(time.perf_counter() - t0, 2)
                        runs.append(r)
                        print(run_line(r), flush=True)
                        out.write_text(json.dumps({"provenance": meta, "candidates": CANDIDATES, "budget": budget,
                                                   "runs": [x.to_json() for x in runs], "summary": summarise(runs)},
                                                  indent=1) + "\n")
        finally:
            task.close()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", choices=("errors", "runs"), required=True, help="errors: the demonstrations alone; runs: the candidates")
    ap.add_argument("--candidates", default=",".join(CANDIDATES), help=f"comma-separated, among {', '.join(CANDIDATES)}")
    ap.add_argument("--tasks", default=",".join(TASK_NAMES), help="comma-separated tasks (default: all)")
    ap.add_argument("--cases", default="extrapolation,interpolation", help="comma-separated cases (default: both)")
    ap.add_argument("--seeds", type=development_seeds, default=(0, 1, 2, 3, 4),
                    help="comma-separated development seeds (default 0,1,2,3,4; the report seeds are refused)")
    ap.add_argument("--budget", type=int, default=1000, help="episodes per run (default 1000, the comparison's)")
    ap.add_argument("--train-steps", type=int, default=3000, help="--part errors: the skills' training steps (default 3000; the runs train the comparison's)")
    ap.add_argument("--out", default=None, help="the result (default: results/selection_<part>.json; runs are kept)")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    tasks = [t for t in args.tasks.split(",") if t]
    bad = [t for t in tasks if t not in TASK_NAMES]
    names = [c for c in args.candidates.split(",") if c]
    if bad or [c for c in names if c not in CANDIDATES]:
        ap.error(f"unknown tasks or candidates: {bad + [c for c in names if c not in CANDIDATES]}")
    out = Path(args.out or study_results("method") / f"selection_{args.part}.json")
    out.parent.mkdir(parents=True, exist_ok=True)
    if args.part == "errors":
        errors_part(tasks, args.train_steps, out)
    else:
        runs_part(tasks, [c for c in args.cases.split(",") if c], args.seeds, names, args.budget, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
