"""What an oversized request costs the model service before it is refused (issue 12, bounded work).

Each case runs in a fresh child process (so its peak RSS is its own) on the code under ``--root``
(default: this checkout; pass another checkout to measure the code before a change), in process,
through the same decode and handler a query goes through:

- ``batch``: a batched predict of ``--items`` requests, each N=4096 observations and T=20 000 query
  steps with S=100 samples (S*T*D = 4 M per item), against a CNMP of the default size;
- ``weights``: a weights message whose config says ``encoder_widths [16000, 16000]`` (~0.26 G
  parameters) but whose state is that of a small model.

Reported per case: the error code (or "ok"), wall and CPU seconds of the handler, peak RSS of the
child before and after it. Numbers from one run on a shared machine.

    python benchmarks/performance/bench_bounded.py [--root DIR] [--items 64] [--out benchmarks/results/bench_bounded.json]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks._results import provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402

CHILD = r"""
import json, resource, sys, time
import numpy as np, torch
torch.set_num_threads(1)
from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.tasks.viapoint.task import obstacle_demos
from services.transport import WireError, decode, encode
case, items = sys.argv[1], int(sys.argv[2])
demos = obstacle_demos()
if case == "batch":
    from services.model.handlers import ModelRegistry, SkillModel, handle_predict
    model = CNMP(CNMPConfig(n_outputs=2), seed=0)
    model.fit_normalization(demos)
    reg = ModelRegistry()
    reg.offer(SkillModel("e1", 0, model.eval()))
    one = {"obs_times": np.linspace(0, 1, 4096), "obs_values": np.zeros((4096, 2)), "n_steps": 20000,
           "n_samples": 100, "seed": 0}
    payload = encode({"batch": [one] * items})
    run = lambda: handle_predict(reg, "e1", decode(payload))
else:
    from acnmp_core.model.checkpoint import model_to_arrays
    from services.model.weights import decode_weights
    small = CNMP(CNMPConfig(n_outputs=2, encoder_widths=(8,), decoder_widths=(8,)), seed=0)
    small.fit_normalization(demos)
    config, state = model_to_arrays(small)
    config["encoder_widths"] = [16000, 16000]
    payload = encode({"skill": "e1", "version": 1, "config": config, "state": state})
    run = lambda: decode_weights(payload)
rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
w0, c0 = time.perf_counter(), time.process_time()
try:
    out = run()
    code = "ok"
    if case == "batch":
        encode(out)  # the service encodes the reply next
except WireError as exc:
    code = exc.code
wall, cpu = time.perf_counter() - w0, time.process_time() - c0
rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"case": case, "items": items if case == "batch" else None, "payload_bytes": len(payload),
                  "code": code, "wall_s": round(wall, 3), "cpu_s": round(cpu, 3),
                  "peak_rss_mb_before": round(rss0 / 1024, 1), "peak_rss_mb_after": round(rss1 / 1024, 1)}))
"""


def measure(root: Path, case: str, items: int) -> dict:
    """Run one case in a child on the code under ``root``; its JSON line as a dict."""
    env = dict(os.environ, PYTHONPATH=str(root), OMP_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", CHILD, case, str(items)], cwd=root, env=env,
                         capture_output=True, text=True, timeout=1800)
    if out.returncode != 0:
        raise RuntimeError(out.stderr[-2000:])
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--root", default=str(Path(__file__).resolve().parents[2]), help="checkout whose code runs")
    p.add_argument("--items", type=int, default=64, help="requests in the batched predict (default: %(default)s)")
    p.add_argument("--cases", default="batch,weights", help="comma-separated cases (default: %(default)s)")
    add_run_arguments(p, out="benchmarks/results/bench_bounded.json")
    args = p.parse_args(argv)
    root_commit = subprocess.run(["git", "-C", args.root, "rev-parse", "HEAD"], capture_output=True,
                                 text=True).stdout.strip() or None
    result = {"benchmark": "bounded", "provenance": provenance(sys.argv), "root": args.root,
              "root_commit": root_commit,  # the code measured (provenance names the benchmark's own checkout)
              "results": [measure(Path(args.root), case, args.items) for case in args.cases.split(",")]}
    for row in result["results"]:
        print(row)
    return save_result(result, args.out)


if __name__ == "__main__":
    sys.exit(main())
