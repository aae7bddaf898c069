"""E3's first training under three process settings that are not landed: the default (one torch
thread, IEEE denormals), denormals flushed to zero (``torch.set_flush_denormal(True)``) and two
torch threads. Each runs in its own child process (both settings are process-wide).

Per setting: CPU ms per step in blocks of 500 steps, the count of denormal Adam first moments at
the end, and a digest of the weights, so the JSON says whether the setting changes the result
and what it saves. Writes ``benchmarks/results/bench_step_arith.json``. Usage::

    python benchmarks/performance/bench_step_arith.py [--steps 3000] [--steps-2-threads 500]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks._results import provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402

BLOCK = 500


def child(threads: int, flush: bool, steps: int) -> dict:
    """Train E3's CNMP ``steps`` steps (batch 32 x 10, the library's loop) and time each step."""
    import hashlib
    import time

    import torch

    torch.set_num_threads(threads)
    if flush:
        torch.set_flush_denormal(True)
    from acnmp_core.experiments.wall import make_wall_cnmp, make_setup
    from acnmp_core.model.optim_step import Stepper
    from acnmp_core.model.training import TrainConfig, make_sampler, nll_loss

    setup = make_setup(1, 0)
    model = make_wall_cnmp(0)
    model.fit_normalization(setup.initial)
    sampler = make_sampler(model, setup.initial, TrainConfig())
    gen = torch.Generator().manual_seed(0)
    opt = torch.optim.Adam(model.parameters(), lr=1e-3, fused=True)
    step = Stepper(opt)
    cpu = []
    for _ in range(steps):
        t = time.process_time()
        loss = nll_loss(model, sampler.sample(32, gen), 0.5)
        step.zero_grad()
        loss.backward()
        step.step()
        loss.item()
        cpu.append(time.process_time() - t)
    tiny = torch.finfo(torch.float32).tiny
    denormal = sum(int(((s["exp_avg"] != 0) & (s["exp_avg"].abs() < tiny)).sum()) for s in opt.state.values())
    h = hashlib.sha256()
    for v in model.state_dict().values():
        h.update(v.numpy().tobytes())
    blocks = [round(1000 * sum(cpu[i:i + BLOCK]) / len(cpu[i:i + BLOCK]), 3) for i in range(0, steps, BLOCK)]
    return {"threads": threads, "flush_denormal": flush, "steps": steps, "cpu_ms_per_step_by_500": blocks,
            "cpu_ms_per_step": round(1000 * sum(cpu) / steps, 3), "denormal_exp_avg_at_end": denormal,
            "weights_digest": h.hexdigest()[:16]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=3000, help="training steps of the one-thread settings (default 3000)")
    ap.add_argument("--steps-2-threads", type=int, default=500, help="training steps with two threads (default 500)")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    add_run_arguments(ap, out=str(ROOT / "benchmarks" / "results" / "bench_step_arith.json"))
    args = ap.parse_args(argv)
    if args.child:
        threads, flush, steps = json.loads(args.child)
        print(json.dumps(child(threads, flush, steps)))
        return 0
    meta = provenance()
    load0 = os.getloadavg()[0]
    runs = []
    for threads, flush, steps in ((1, False, args.steps), (1, True, args.steps), (1, False, args.steps_2_threads),
                                  (2, False, args.steps_2_threads)):
        out = subprocess.run([sys.executable, __file__, "--child", json.dumps([threads, flush, steps])],
                             capture_output=True, text=True, check=True, cwd=ROOT)
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    base, flushed, short, two = runs
    result = {"benchmark": "bench_step_arith", "provenance": meta, "load_average_start_end": [round(load0, 2),
              round(os.getloadavg()[0], 2)], "runs": runs,
              "flush_denormal_same_weights": base["weights_digest"] == flushed["weights_digest"],
              "flush_denormal_cpu_ratio": round(base["cpu_ms_per_step"] / flushed["cpu_ms_per_step"], 3),
              "two_threads_same_weights": short["weights_digest"] == two["weights_digest"],
              "two_threads_cpu_ratio": round(two["cpu_ms_per_step"] / short["cpu_ms_per_step"], 3),
              "note": "cpu = process CPU time (all threads); one setting at a time, in this order"}
    return save_result(result, args.out, headline=("flush_denormal_same_weights", "flush_denormal_cpu_ratio",
                                            "two_threads_same_weights", "two_threads_cpu_ratio"))


if __name__ == "__main__":
    sys.exit(main())
