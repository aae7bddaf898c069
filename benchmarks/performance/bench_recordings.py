"""Recordings as data and live: how fast a recording is read back as tables, and how soon a live
viewer gets a roll-out.

1. Export speed: a recording of ``--rollouts`` roll-outs of E3's shape (101 steps x 2 dims, E1's
   via-point task scoring them, ``--jobs`` jobs each with its job event) is written with the
   recorder's writer, then read back with :func:`services.recording.tables.read_recording` and
   written as Parquet. Roll-outs per second of each step, and the file sizes.
2. Live latency: a local deployment with a recorder serving its stream (``viewer=True``) and the
   ``rerun`` command connected to it, saving what it receives. ``--events`` roll-out events are
   published one at a time through the deployment's event publisher; the time from a publication
   to the moment the client's file grows (polled every millisecond; the client writes what it
   receives at once) is the latency: median and p99. The client's file growing is what a viewer
   would draw from, so this is an upper bound of the arrival itself.

Writes ``benchmarks/results/bench_recordings.json``. Usage::

    python benchmarks/performance/bench_recordings.py [--rollouts 10000] [--jobs 20] [--events 200]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks._results import provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402


def bench_export(n_rollouts: int, n_jobs: int, tmp: Path) -> dict:
    """Write a recording of ``n_rollouts`` roll-outs over ``n_jobs`` jobs, read it back, write Parquet."""
    from acnmp_core.experiments.viapoint import make_setup
    from services.recording.events import batch_rollout_events, job_event
    from services.recording.rrd_writer import RrdWriter
    from services.recording.tables import read_recording

    setup = make_setup()
    times = setup.target.query_times
    rng = np.random.default_rng(0)
    path = tmp / "export.rrd"
    per_job = n_rollouts // n_jobs
    t0 = time.perf_counter()
    with RrdWriter(path) as writer:
        for j in range(n_jobs):
            job = f"bench-{j:04d}"
            writer.log_event(job_event(job, method="acnmp", robot="point2d", task="viapoint", seed=j,
                                       task_config=setup.task_config))
            for first in range(0, per_job, 50):
                trajs = rng.normal(scale=0.3, size=(min(50, per_job - first), len(times), 2))
                batch = setup.task.evaluate(trajs, times, None)
                for ev in batch_rollout_events(job, first, trajs, times, batch, skill="e1", iteration=first // 50):
                    writer.log_event(ev)
    written = time.perf_counter() - t0
    t0 = time.perf_counter()
    tables = read_recording(path)
    read = time.perf_counter() - t0
    t0 = time.perf_counter()
    paths = tables.write_parquet(tmp / "tables")
    parquet = time.perf_counter() - t0
    n = tables.rollouts.num_rows
    return {"rollouts": n, "steps": len(times), "dims": 2, "jobs": n_jobs,
            "rrd_mb": round(path.stat().st_size / 2**20, 2),
            "parquet_mb": round(sum(p.stat().st_size for p in paths.values()) / 2**20, 2),
            "write_rollouts_per_s": round(n / written, 1), "read_rollouts_per_s": round(n / read, 1),
            "parquet_rollouts_per_s": round(n / parquet, 1), "read_s": round(read, 3), "parquet_s": round(parquet, 3)}


def bench_live(n_events: int, tmp: Path) -> dict:
    """Publication-to-client latency of roll-out events through a live recorder."""
    from acnmp_core.experiments.viapoint import make_setup
    from services.launcher import LocalDeployment
    from services.recording.events import rollout_event
    from services.recording.live_client import saving_client

    setup = make_setup()
    times = setup.target.query_times
    saved = tmp / "client.rrd"
    latencies = []
    with LocalDeployment("benchlive", workers=0, model=False, learner=False, record=tmp / "live.rrd",
                         viewer=True, state_dir=tmp / "state") as dep:
        with saving_client(dep.viewer_url, saved):
            grown = threading.Event()
            size = [0]

            def watch() -> None:  # the moment the client's file grows
                while not stopped.is_set():
                    now = saved.stat().st_size if saved.exists() else 0
                    if now != size[0]:
                        size[0] = now
                        grown.set()
                    time.sleep(0.001)

            stopped = threading.Event()
            watcher = threading.Thread(target=watch, daemon=True)
            watcher.start()
            warm = rollout_event("warm-up", 0, np.zeros((len(times), 2)), times, np.zeros(len(times)))
            dep.events.publish(warm)
            if not grown.wait(30):
                raise RuntimeError("the rerun client received nothing in 30 s")
            time.sleep(1.0)  # the recording's first messages (blueprint, properties) settle
            for i in range(n_events):
                grown.clear()
                ev = rollout_event("bench", i, np.full((len(times), 2), i * 1e-3), times, np.zeros(len(times)))
                t0 = time.perf_counter()
                dep.events.publish(ev)
                if grown.wait(10):
                    latencies.append(time.perf_counter() - t0)
                time.sleep(0.05)  # one at a time: each publication's own arrival
            stopped.set()
            watcher.join()
    ms = np.asarray(latencies) * 1e3
    return {"events": n_events, "received": len(latencies), "latency_ms_p50": round(float(np.median(ms)), 2),
            "latency_ms_p99": round(float(np.percentile(ms, 99)), 2), "latency_ms_max": round(float(ms.max()), 2),
            "measured_to": "the rerun client's saved file growing (polled every 1 ms)"}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rollouts", type=int, default=10_000, help="roll-outs in the exported recording (default 10000)")
    ap.add_argument("--jobs", type=int, default=20, help="jobs the recording's roll-outs belong to (default 20)")
    ap.add_argument("--events", type=int, default=200, help="roll-out events timed live (default 200)")
    add_run_arguments(ap, out=str(ROOT / "benchmarks" / "results" / "bench_recordings.json"))
    args = ap.parse_args(argv)
    if min(args.rollouts, args.jobs, args.events) < 1 or args.rollouts < args.jobs:
        ap.error("--rollouts, --jobs, --events: integers >= 1, at least one roll-out per job")
    meta = provenance()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        export = bench_export(args.rollouts, args.jobs, Path(tmp))
        print("export", export, flush=True)
        live = bench_live(args.events, Path(tmp))
        print("live", live, flush=True)
    result = {"experiment": "bench_recordings", "provenance": meta,
              "config": {"rollouts": args.rollouts, "jobs": args.jobs, "events": args.events},
              "export": export, "live": live, "wall_time_s": round(time.perf_counter() - t0, 1)}
    return save_result(result, args.out, headline=("export", "live"))


if __name__ == "__main__":
    sys.exit(main())
