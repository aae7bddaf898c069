"""How much a first trajectory's success at once owes to its basis count: the demonstrations' linear
conditioning with every candidate basis count, executed once at each test condition of a task of the
comparison, in the default model's own basis (the linear path alone) and in ProMP + CMA-ES's
(``mp_pytorch``'s ProMP conditioned as the peer conditions it).

It measures what the method study's table cannot show: on a task whose success turns on a contact
(Meta-World's push), whether a start succeeds at once changes from one basis count to the next with
no order, so a method's median of 1 episode there says how its count fell, not how well it
extrapolates.

Usage:
  python benchmarks/studies/method/start_sensitivity.py --tasks metaworld-push --cases extrapolation
Writes benchmarks/studies/method/results/start_sensitivity.json.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.peers import peer_task  # noqa: E402
from acnmp_core.model.cnmp import CNMP, CNMPConfig  # noqa: E402
from acnmp_core.model.prior import BASIS_CANDIDATES  # noqa: E402
from acnmp_core.peers.black_box import DemoProMP  # noqa: E402
from benchmarks._results import development_seeds, provenance, study_results  # noqa: E402


def path_only(task, n_basis: int) -> CNMP:
    """The default model's linear path alone (its network's output zeroed) with ``n_basis`` bases."""
    a = task.arrays
    model = CNMP(CNMPConfig(n_outputs=a.values.shape[2], n_task_params=a.task_params.shape[1], prior_basis=n_basis),
                 seed=0)
    model.fit_normalization(a.to_demo_set())
    with torch.no_grad():
        for p in model.decoder.parameters():
            p.zero_()
    return model


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", default="metaworld-push", help="comma-separated tasks (default metaworld-push)")
    ap.add_argument("--cases", default="extrapolation", help="comma-separated cases (default extrapolation)")
    ap.add_argument("--seeds", type=development_seeds, default=(0, 1, 2, 3, 4),
                    help="comma-separated development seeds (default 0,1,2,3,4; the report seeds are refused)")
    ap.add_argument("--out", default=str(study_results("method") / "start_sensitivity.json"),
                    help="the result (default benchmarks/studies/method/results/start_sensitivity.json)")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    meta, rows = provenance(), []
    for name in args.tasks.split(","):
        task = peer_task(name)
        try:
            a, ev = task.arrays, task.evaluator("acnmp")
            ours = {k: path_only(task, k) for k in BASIS_CANDIDATES}
            peers = {k: DemoProMP(task.times, a.values, a.task_params, k) for k in BASIS_CANDIDATES}
            for case in args.cases.split(","):
                for seed in args.seeds:
                    target = task.target(seed, case)
                    p = np.asarray(target.task_params)
                    trajs = [m.predict_query(target.query(m)).mean for m in ours.values()]
                    trajs += [pm.trajectories_at(pm.conditioned_mean(p, target.obs_times, target.obs_values),
                                                 target.query_times)[0] for pm in peers.values()]
                    batch = ev.evaluate(np.stack(trajs), target.query_times, p)
                    k = len(BASIS_CANDIDATES)
                    row = {"task": name, "case": case, "seed": seed, "bases": list(BASIS_CANDIDATES),
                           "linear_path": {"success": batch.success[:k].tolist(), "error": batch.errors[:k].tolist()},
                           "promp_cma_start": {"success": batch.success[k:].tolist(), "error": batch.errors[k:].tolist()}}
                    rows.append(row)
                    print(name, case, seed, "linear path", "".join("x" if s else "." for s in row["linear_path"]["success"]),
                          "ProMP", "".join("x" if s else "." for s in row["promp_cma_start"]["success"]), flush=True)
        finally:
            task.close()
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"provenance": meta, "experiment": "start_sensitivity", "rows": rows}, indent=1) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
