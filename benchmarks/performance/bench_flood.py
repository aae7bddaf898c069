"""A flood of abandoned heavy predicts against one model service (issue 12, deadlines).

A model service process (``python -m services.model``, the code under ``--root``) serves an E1-sized
CNMP from a checkpoint. ``--clients`` threads, each with its own zenoh session, send heavy predicts
(N=4096 observations, T=20 000 steps) with a ``--heavy-timeout`` of 0.5 s, back to back, for
``--seconds``. Meanwhile one light predict (N=2, T=100, timeout 30 s) is sent every 0.5 s; after the
flood, light predicts continue until one is answered in under 50 ms (the service is idle again).

Reported: light-predict latencies during the flood (max, p50), how long after the flood the service
was idle, the heavy predicts sent and their outcomes by code. Numbers from one run on a shared
machine (2 cores; other benchmarks may run).

    python benchmarks/performance/bench_flood.py [--root DIR] [--clients 16] [--seconds 10] [--out FILE]
"""
from __future__ import annotations

import argparse
import collections
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks._results import provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402

NS = "flood"


def _checkpoint(path: Path) -> Path:
    from acnmp_core.model.checkpoint import save_checkpoint
    from acnmp_core.model.cnmp import CNMP, CNMPConfig
    from acnmp_core.tasks.viapoint.task import obstacle_demos

    model = CNMP(CNMPConfig(n_outputs=2), seed=0)
    model.fit_normalization(obstacle_demos())
    return save_checkpoint(model.eval(), path, meta={"version": 0})


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--root", default=str(Path(__file__).resolve().parents[2]), help="checkout whose model service runs")
    p.add_argument("--clients", type=int, default=16, help="threads sending heavy predicts (default 16)")
    p.add_argument("--seconds", type=float, default=10.0, help="how long the flood lasts (default 10)")
    p.add_argument("--heavy-timeout", type=float, default=0.5,
                   help="the timeout of each heavy predict, seconds (default 0.5)")
    add_run_arguments(p, out="benchmarks/results/bench_flood.json")
    args = p.parse_args(argv)

    from clients.client import ACNMPClient
    from services.transport import WireError, free_port, loopback_endpoint

    prov = provenance(sys.argv)
    root_commit = subprocess.run(["git", "-C", args.root, "rev-parse", "HEAD"], capture_output=True,
                                 text=True).stdout.strip() or None
    with tempfile.TemporaryDirectory(prefix="bench-flood-") as tmp:
        ckpt = _checkpoint(Path(tmp) / "e1.pt")
        ep = loopback_endpoint(free_port())
        env = dict(os.environ, PYTHONPATH=args.root, OMP_NUM_THREADS="1")
        service = subprocess.Popen([sys.executable, "-m", "services.model", "--namespace", NS, "--listen", ep,
                                    "--checkpoint", f"e1={ckpt}"], cwd=args.root, env=env,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            light = {"obs_times": [0.0, 1.0], "obs_values": [[0.0, 0.0], [1.0, 0.0]], "n_steps": 100}
            heavy = {"obs_times": np.linspace(0, 1, 4096), "obs_values": np.zeros((4096, 2)), "n_steps": 20_000}
            with ACNMPClient(NS, connect=[ep], timeout=30) as probe:
                deadline = time.monotonic() + 60
                while True:
                    try:
                        probe.request(probe.keys.predict("e1"), {"v": 1, **light})
                        break
                    except WireError:
                        if time.monotonic() > deadline:
                            raise
                        time.sleep(0.1)
                t0 = time.perf_counter()
                probe.request(probe.keys.predict("e1"), {"v": 1, **heavy}, timeout=60)
                heavy_alone_s = time.perf_counter() - t0

                stop = threading.Event()
                outcomes: collections.Counter = collections.Counter()
                lock = threading.Lock()

                def flood() -> None:
                    with ACNMPClient(NS, connect=[ep], timeout=args.heavy_timeout) as c:
                        while not stop.is_set():
                            try:
                                c.request(c.keys.predict("e1"), {"v": 1, **heavy})
                                code = "ok"
                            except WireError as exc:
                                code = exc.code
                            with lock:
                                outcomes[code] += 1

                threads = [threading.Thread(target=flood) for _ in range(args.clients)]
                for t in threads:
                    t.start()
                def timed_light() -> float:
                    """Seconds a light predict took; its timeout (30 s) when it got no answer."""
                    t1 = time.perf_counter()
                    try:
                        probe.request(probe.keys.predict("e1"), {"v": 1, **light})
                    except WireError as exc:
                        light_failures[exc.code] += 1
                    return time.perf_counter() - t1

                light_failures: collections.Counter = collections.Counter()
                during = []
                start = time.perf_counter()
                while time.perf_counter() - start < args.seconds:
                    t1 = time.perf_counter()
                    during.append(timed_light())
                    time.sleep(max(0.0, 0.5 - (time.perf_counter() - t1)))
                stop.set()
                flood_end = time.perf_counter()
                for t in threads:
                    t.join(timeout=60)
                after = []
                while True:
                    after.append(timed_light())
                    if after[-1] < 0.05 or time.perf_counter() - flood_end > 120:
                        break
                idle_after_s = time.perf_counter() - flood_end
        finally:
            service.terminate()
            service.wait(timeout=30)
    result = {
        "benchmark": "flood", "provenance": prov, "root": args.root, "root_commit": root_commit,
        "clients": args.clients, "seconds": args.seconds, "heavy_timeout_s": args.heavy_timeout,
        "heavy_alone_s": round(heavy_alone_s, 3),
        "light_during_flood_s": {"n": len(during), "max": round(max(during), 3),
                                 "p50": round(float(np.median(during)), 3)},
        "idle_after_flood_s": round(idle_after_s, 3), "light_after_flood_s": [round(x, 3) for x in after],
        "heavy_outcomes": dict(outcomes), "light_failures": dict(light_failures),
    }
    return save_result(result, args.out, headline=("heavy_alone_s", "light_during_flood_s", "idle_after_flood_s",
                                            "heavy_outcomes", "light_failures"))


if __name__ == "__main__":
    sys.exit(main())
