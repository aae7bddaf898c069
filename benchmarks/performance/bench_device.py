"""A training step, an E3 assimilation and a batched predict on every device this machine has.

For each device of :func:`acnmp_core.model.device.available_devices` (the CPU; each CUDA device where
there is one), on one thread (as the services run):

* ``train_step_ms``: one of E1's training steps (its CNMP, batch 32): the time of ``train`` with
  20 + ``--steps`` steps less that with 20, over ``--steps``, the median of three (each step
  includes sampling on the CPU and the move of the batch);
* ``e3_assimilation_s``: one E3 assimilation (E3's CNMP on 20 of its demonstrations, one solution
  added, its default 150 steps, anchor and rate schedule), the median of ``--reps``;
* ``predict_batch_ms``: ``--batch`` single predicts (E1's skill, 3 observations, 200 query times)
  in one forward pass (``CNMP.predict_queries``, what the model service's batcher runs), median of
  ``--reps``; ``predict_single_ms``: one of them alone.

Reported per device and, with more than one, each device's time over the CPU's.

    python benchmarks/performance/bench_device.py [--out benchmarks/results/bench_device.json]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks._results import provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402


def _sync(device) -> None:
    import torch

    if device.type == "cuda":
        torch.cuda.synchronize(device)


def measure(device, args) -> dict:
    """The three timings on ``device`` (a torch.device)."""
    import torch

    from acnmp_core.adaptation.assimilation import AssimilationConfig, assimilate
    from acnmp_core.data.demos import DemoSet, Demonstration
    from acnmp_core.experiments.wall import TRAIN_DEFAULTS, make_wall_cnmp
    from acnmp_core.model.cnmp import CNMP, CNMPConfig
    from acnmp_core.model.training import TrainConfig, train
    from acnmp_core.tasks.viapoint.task import obstacle_demos
    from acnmp_core.tasks.wall.task import make_demo_set

    torch.set_num_threads(1)
    demos = obstacle_demos()
    # a training step: two train() calls of 20 and 20 + --steps steps (no validation but the first);
    # the difference over --steps is one step, the call's set-up and first steps cancelled out
    def train_time(steps: int) -> float:
        m = CNMP(CNMPConfig(n_outputs=2), seed=0).to_device(device)
        _sync(device)
        t0 = time.perf_counter()
        train(m, demos, TrainConfig(steps=steps, val_every=10 ** 6), seed=0, progress=False)
        _sync(device)
        return time.perf_counter() - t0

    step_ms = [(train_time(20 + args.steps) - train_time(20)) / args.steps * 1e3 for _ in range(3)]
    model = CNMP(CNMPConfig(n_outputs=2), seed=0).to_device(device)
    train(model, demos, TrainConfig(steps=200), seed=0, progress=False)

    # an E3 assimilation
    times, values, params = make_demo_set(20, np.random.default_rng(0))
    wall = DemoSet([Demonstration(times[i], values[i], params[i]) for i in range(len(values))])
    solution = wall[0]
    from acnmp_core.adaptation.config import AdaptTarget

    # conditioned as E3 conditions: on the start and the goal
    target = AdaptTarget(solution.times[[0, -1]], solution.values[[0, -1]], solution.task_params, solution.times)
    e3_times = []
    for rep in range(args.reps):
        m = make_wall_cnmp(0).to_device(device)
        train(m, wall, TrainConfig(steps=50), seed=0, progress=False)
        acfg = AssimilationConfig(steps=TRAIN_DEFAULTS["assimilate_steps"], lr=TRAIN_DEFAULTS["assimilate_lr"],
                                  batch_size=TRAIN_DEFAULTS["assimilate_batch_size"],
                                  n_targets=TRAIN_DEFAULTS["assimilate_targets"],
                                  anchor_weight=TRAIN_DEFAULTS["assimilate_anchor_weight"],
                                  lr_final=TRAIN_DEFAULTS["assimilate_lr_final"])
        _sync(device)
        t0 = time.perf_counter()
        assimilate(m, wall, solution, acfg, conditions=target, seed=rep)
        _sync(device)
        e3_times.append(time.perf_counter() - t0)

    # batched predicts
    d = demos[0]
    query = model.make_query(d.times[:3], d.values[:3], None, np.linspace(d.times[0], d.times[-1], 200))
    queries = [query] * args.batch
    model.predict_queries(queries)
    batch_ms, single_ms = [], []
    for _ in range(args.reps):
        t0 = time.perf_counter()
        model.predict_queries(queries)
        batch_ms.append((time.perf_counter() - t0) * 1e3)
        t0 = time.perf_counter()
        model.predict_query(query)
        single_ms.append((time.perf_counter() - t0) * 1e3)
    name = torch.cuda.get_device_name(device) if device.type == "cuda" else "cpu (1 thread)"
    return {"device": str(device), "name": name, "train_step_ms": float(np.median(step_ms)),
            "e3_assimilation_s": float(np.median(e3_times)), "predict_batch_ms": float(np.median(batch_ms)),
            "predict_single_ms": float(np.median(single_ms)), "batch": args.batch}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300, help="timed training steps (default %(default)s)")
    parser.add_argument("--reps", type=int, default=5, help="repetitions of the other timings (default %(default)s)")
    parser.add_argument("--batch", type=int, default=64, help="predicts in one batch (default %(default)s)")
    add_run_arguments(parser, out="benchmarks/results/bench_device.json")
    args = parser.parse_args()
    from acnmp_core.model.device import available_devices

    result = {"provenance": provenance(sys.argv), "config": vars(args), "devices": []}
    for device in available_devices():
        row = measure(device, args)
        result["devices"].append(row)
        print(row, flush=True)
    cpu = result["devices"][0]
    result["over_cpu"] = {row["device"]: {k: row[k] / cpu[k] for k in ("train_step_ms", "e3_assimilation_s",
                                                                        "predict_batch_ms", "predict_single_ms")}
                          for row in result["devices"][1:]}
    if not result["over_cpu"]:
        result["note"] = "only the CPU here: the CUDA rows appear on a machine with a CUDA device"
    return save_result(result, args.out, headline=("devices", "over_cpu"))


if __name__ == "__main__":
    sys.exit(main())
