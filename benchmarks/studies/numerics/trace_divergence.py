"""Where do two CPUs' E1 runs first differ? Traces every torch op of E1 seed 0's first training steps.

Each op's outputs are hashed (exact bytes) under a ``TorchDispatchMode``; the trace is run natively
and under ``qemu-x86_64 -cpu MODEL`` (another CPU model's instruction set and CPUID, so MKL and
numpy pick that CPU's kernels), and the first op whose hash differs is reported: its index, the
training step, the op and its input shapes. Written to ``--out`` (JSON) for benchmarks/studies/numerics/README.md.

    python benchmarks/studies/numerics/trace_divergence.py --emulate Haswell-v4 [--steps 2] [--out benchmarks/studies/numerics/results/trace_divergence.json]
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))


#: Ops whose output bytes are allocator state, not a computed value.
MEMORY_OPS = ("aten.set_", "aten.empty", "aten.new_empty", "aten.resize_", "aten.lift_fresh")


def trace(steps: int) -> list[dict]:
    """Every op (model construction included, step 0) of ``steps`` training steps of E1's CNMP (seed 0,
    one thread; step k is one ``train`` call of one step, seed k-1): [{"i", "step", "op", "shapes", "sha"}]."""
    import torch
    from torch.utils._python_dispatch import TorchDispatchMode

    from acnmp_core.model.cnmp import CNMP, CNMPConfig
    from acnmp_core.model.training import TrainConfig, train
    from acnmp_core.tasks.viapoint.task import obstacle_demos

    torch.set_num_threads(1)
    ops: list[dict] = []
    step = [0]  # 0: building the model and its normalisation

    class Hash(TorchDispatchMode):
        def __torch_dispatch__(self, func, types, args=(), kwargs=None):
            out = func(*args, **(kwargs or {}))
            flat = out if isinstance(out, (tuple, list)) else (out,)
            h = hashlib.sha256()
            for t in flat:
                if isinstance(t, torch.Tensor):
                    h.update(t.detach().contiguous().cpu().numpy().tobytes())
            shapes = [list(a.shape) for a in args if isinstance(a, torch.Tensor)]
            ops.append({"i": len(ops), "step": step[0], "op": str(func), "shapes": shapes, "sha": h.hexdigest()[:16]})
            return out

    model = CNMP(CNMPConfig(n_outputs=2, prior="none"), seed=0)
    demos = obstacle_demos()

    with Hash():
        for k in range(steps):  # one train() call per step, so each op knows its step
            step[0] = k + 1
            train(model, demos, TrainConfig(steps=1), seed=k, progress=False)
    return ops


def main(argv: list[str] | None = None) -> int:
    from clients.experiments.common import add_run_arguments

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1, help="training steps traced (one train() call each)")
    ap.add_argument("--emulate", default="Haswell-v4", help="qemu CPU model to compare with")
    ap.add_argument("--trace-only", action="store_true", help=argparse.SUPPRESS)  # the child's mode
    add_run_arguments(ap, out=str((Path(__file__).resolve().parent / "results") / "trace_divergence.json"))
    args = ap.parse_args(argv)
    if args.trace_only:
        print(json.dumps(trace(args.steps)))
        return 0
    from benchmarks._results import save_result
    from clients.provenance import provenance

    runs = {}
    for name, prefix in (("native", []), ("native again", []), (f"qemu {args.emulate}", ["qemu-x86_64", "-cpu", args.emulate])):
        t0 = time.perf_counter()
        out = subprocess.run([*prefix, sys.executable, __file__, "--trace-only", "--steps", str(args.steps)],
                             cwd=ROOT, env=dict(os.environ), capture_output=True, text=True, check=True)
        runs[name] = {"ops": json.loads(out.stdout.strip().splitlines()[-1]), "seconds": time.perf_counter() - t0}
    a, again, b = (r["ops"] for r in runs.values())
    # an op whose output differs between two native runs hashes memory it did not compute
    # (aten.empty, set_ on a fresh storage): not a numerical difference, left out
    unstable = {x["i"] for x, y in zip(a, again) if x["sha"] != y["sha"]}
    # ops that only allocate or rebind storage (their "output" is whatever memory held) compute nothing
    unstable |= {x["i"] for x in a if any(m in x["op"] for m in MEMORY_OPS)}
    first = next((x for x, y in zip(a, b) if x["i"] not in unstable and (x["sha"] != y["sha"] or x["op"] != y["op"])),
                 None)
    result = {"provenance": provenance(), "steps": args.steps, "ops": len(a),
              "seconds": {k: v["seconds"] for k, v in runs.items()}, "first_difference": first,
              "ops_before_it": [x for x in a[:first["i"]] if x["i"] not in unstable][-3:] if first else None,
              "left_out": {"ops": len(unstable), "why": "output differs between two native runs, or op in MEMORY_OPS",
                           "memory_ops": list(MEMORY_OPS)},
              "differing_ops": sum(x["sha"] != y["sha"] for x, y in zip(a, b) if x["i"] not in unstable)}
    return save_result(result, args.out, headline=("ops", "first_difference", "differing_ops"))


if __name__ == "__main__":
    sys.exit(main())
