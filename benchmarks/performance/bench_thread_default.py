"""The library's torch thread default, chosen by measurement: one and two threads on E1's training and
a 10-environment E3, each alone and beside a busy process.

Every cell runs in a fresh Python process (``ACNMP_TORCH_THREADS`` set for it), so one cell's
threads or caches never reach another's. "Busy" starts a second process that spins one core in a
Python loop for the whole cell, as another user's job would on a shared machine. Each cell records
its wall and CPU seconds and a digest of what it computed: a thread count must not change the
numbers. The ratio two threads / one thread per workload and condition is what the default is
chosen from; the JSON names the default the library ships (``acnmp_core.threads``). Usage::

    python benchmarks/performance/bench_thread_default.py [--steps 3000] [--envs 10] [--repeat 1] [--out FILE]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks._results import provenance, save_result, study_results  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402

SPIN = "while True:\n    pass\n"


def _cell(workload: str, steps: int, envs: int) -> dict:
    """One workload in this process at ``$ACNMP_TORCH_THREADS`` threads; returns times and a digest."""
    import hashlib

    import torch

    from acnmp_core.threads import training_threads
    h = hashlib.sha256()
    t0, c0 = time.perf_counter(), time.process_time()
    if workload == "e1_train":
        from acnmp_core.model.cnmp import CNMP, CNMPConfig
        from acnmp_core.model.training import TrainConfig, train
        from acnmp_core.tasks.viapoint.task import obstacle_demos
        model = CNMP(CNMPConfig(n_outputs=2), seed=0)
        r = train(model, obstacle_demos(), TrainConfig(steps=steps), seed=0, progress=False)
        for v in model.state_dict().values():
            h.update(v.detach().numpy().tobytes())
        h.update(json.dumps(r.train_loss).encode())
    else:
        from acnmp_core.experiments.wall import run_wall
        r = run_wall(envs, 0, eval_every=envs, methods=("acnmp",))
        s = r["methods"]["acnmp"]
        h.update(json.dumps([{k: v for k, v in s.items() if k != "time_s"}, r["curves"]["acnmp"],
                             r["rollouts_per_env"]["acnmp"]], sort_keys=True, default=str).encode())
    return {"wall_s": round(time.perf_counter() - t0, 2), "cpu_s": round(time.process_time() - c0, 2),
            "threads_in_use": training_threads(), "torch_threads_outside": torch.get_num_threads(),
            "digest": h.hexdigest()[:16]}


def _run_cell(workload: str, threads: int, busy: bool, steps: int, envs: int) -> dict:
    """Run one cell in a child process, with a spinning neighbour when ``busy``."""
    env = dict(os.environ, ACNMP_TORCH_THREADS=str(threads))
    spinner = subprocess.Popen([sys.executable, "-c", SPIN]) if busy else None
    try:
        out = subprocess.run([sys.executable, __file__, "--cell", workload, "--steps", str(steps),
                              "--envs", str(envs)], env=env, capture_output=True, text=True, check=True)
    finally:
        if spinner is not None:
            spinner.kill()
            spinner.wait()
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=3000, help="E1 training steps (default 3000)")
    ap.add_argument("--envs", type=int, default=10, help="E3 new environments (default 10)")
    ap.add_argument("--repeat", type=int, default=1, help="runs of every cell (default 1)")
    ap.add_argument("--cell", choices=("e1_train", "e3_wall"), help=argparse.SUPPRESS)
    add_run_arguments(ap, out=str(study_results("e3_wall") / "bench_thread_default.json"))
    args = ap.parse_args(argv)
    if args.cell:
        print(json.dumps(_cell(args.cell, args.steps, args.envs)))
        return 0
    if min(args.steps, args.envs, args.repeat) < 1:
        ap.error("--steps, --envs and --repeat: expected integers >= 1")
    meta = provenance()
    t0 = time.perf_counter()
    cells = []
    for rep in range(args.repeat):
        for workload in ("e1_train", "e3_wall"):
            for busy in (False, True):
                for threads in (1, 2):
                    c = {"workload": workload, "busy_neighbour": busy, "threads": threads, "repeat": rep,
                         **_run_cell(workload, threads, busy, args.steps, args.envs)}
                    cells.append(c)
                    print(json.dumps(c), flush=True)
    ratios = []
    for workload in ("e1_train", "e3_wall"):
        for busy in (False, True):
            def best(t: int) -> float:
                return min(c["wall_s"] for c in cells
                           if c["workload"] == workload and c["busy_neighbour"] == busy and c["threads"] == t)
            ratios.append({"workload": workload, "busy_neighbour": busy, "one_thread_wall_s": best(1),
                           "two_threads_wall_s": best(2), "two_over_one": round(best(2) / best(1), 3)})
    same = all(len({c["digest"] for c in cells if c["workload"] == w}) == 1 for w in ("e1_train", "e3_wall"))
    from acnmp_core.threads import DEFAULT_TRAINING_THREADS
    worst_two = max(r["two_over_one"] for r in ratios)
    best_two = min(r["two_over_one"] for r in ratios)
    result = {"experiment": "bench_thread_default", "provenance": meta,
              "config": {"steps": args.steps, "envs": args.envs, "repeat": args.repeat,
                         "neighbour": "one Python process spinning one core"},
              "cells": cells, "ratios": ratios, "same_numbers_at_every_thread_count": same,
              "default_threads": DEFAULT_TRAINING_THREADS,
              "why": (f"two threads take {best_two:.2f}x to {worst_two:.2f}x the time of one: the gain "
                      "alone is smaller than the loss beside a busy process, so one thread is the default"
                      if worst_two > 1 / best_two else
                      f"two threads take {best_two:.2f}x to {worst_two:.2f}x the time of one"),
              "wall_time_s": round(time.perf_counter() - t0, 1)}
    save_result(result, args.out, headline=("ratios", "same_numbers_at_every_thread_count", "why"))
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
