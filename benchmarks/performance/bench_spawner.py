"""A local deployment's start with and without the spawner (services/launcher/spawner.py).

Starts ``LocalDeployment`` (recorder, learner, model, 2 point2d workers) ``--reps`` times with the
spawner (the default) and as many times with every child a fresh interpreter
(``fork_server=False``), alternately, so both settings see the machine's same minutes. Per start:
the wall time until every child is live (``start()``), and the CPU seconds (user + system) every
process of the deployment has used by then (the spawner's own included; a forked child counts from
its fork). Reported per setting: median, min and max; and the median of the rounds' paired ratios
spawner / fresh interpreters.

    python benchmarks/performance/bench_spawner.py [--reps 5] [--out benchmarks/results/bench_spawner.json]
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import psutil

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks._results import benchmark_args, provenance, save_result  # noqa: E402
from services.launcher import LocalDeployment  # noqa: E402

SETTINGS = {"spawner": True, "fresh": False}


def _cpu(pid: int) -> float:
    t = psutil.Process(pid).cpu_times()
    return t.user + t.system


def start_once(fork_server: bool, workers: int) -> dict:
    """One deployment started and stopped: {"ready_s", "cpu_s", "cpu_by_process"}."""
    with tempfile.TemporaryDirectory(prefix="acnmp-bench-spawner-") as tmp:
        dep = LocalDeployment("benchspawn", workers=workers, record=Path(tmp) / "run.rrd", state_dir=Path(tmp) / "state",
                              fork_server=fork_server)
        t0 = time.perf_counter()
        dep.start()
        try:
            ready = time.perf_counter() - t0
            cpu = {name: _cpu(child.pid) for name, child in dep.children.items()}
            if dep.spawner_pid is not None:
                cpu["spawner"] = _cpu(dep.spawner_pid)
        finally:
            dep.stop()
    return {"ready_s": ready, "cpu_s": sum(cpu.values()), "cpu_by_process": cpu}


def _spread(values) -> dict:
    return {"median": float(np.median(values)), "min": float(np.min(values)), "max": float(np.max(values))}


def main() -> int:
    args = benchmark_args(__doc__, "bench_spawner", None, reps=(5, "deployments started per setting"),
                          workers=(2, "point2d workers per deployment"))
    prov, t0 = provenance(), time.perf_counter()
    runs: dict[str, list[dict]] = {name: [] for name in SETTINGS}
    for _ in range(args.reps):
        for name, fork in SETTINGS.items():
            runs[name].append(start_once(fork, args.workers))
    summary = {name: {"ready_s": _spread([r["ready_s"] for r in rs]), "cpu_s": _spread([r["cpu_s"] for r in rs])}
               for name, rs in runs.items()}
    ratios = {key: _spread([a[key] / b[key] for a, b in zip(runs["spawner"], runs["fresh"])])
              for key in ("ready_s", "cpu_s")}
    result = {"provenance": prov, "config": {"reps": args.reps, "workers": args.workers,
                                             "processes": ["recorder", "learner", "model", f"{args.workers} workers"]},
              "summary": summary, "ratio_spawner_to_fresh": ratios, "runs": runs,
              "wall_time_s": round(time.perf_counter() - t0, 1),
              "headline": (f"a deployment's start: {summary['spawner']['cpu_s']['median']:.1f} CPU s with the spawner, "
                           f"{summary['fresh']['cpu_s']['median']:.1f} without (x{ratios['cpu_s']['median']:.2f}); "
                           f"up in {summary['spawner']['ready_s']['median']:.1f} s against "
                           f"{summary['fresh']['ready_s']['median']:.1f} s")}
    save_result(result, args.out)
    print(result["headline"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
