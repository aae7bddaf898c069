"""Predict latency and throughput of the model service over zenoh, against its two lower bounds.

In one run, interleaved so that they share the machine's conditions:

- ``predict_zenoh``: a 200-step predict (2 observations, the E1 model, default architecture) sent by
  :class:`clients.client.ACNMPClient` to a model service in another process (spawned, peer mode on
  loopback, one hop);
- ``in_process``: the same ``CNMP.predict`` called directly in this process;
- ``empty_query``: a zenoh query with no payload to a queryable in the service process that
  replies an empty payload at once (the transport's floor).

Target: p50(predict_zenoh) <= 1.5 x (p50(in_process) + p50(empty_query)). Then throughput
(predicts/s) with 1, 4 and 16 concurrent clients, each a thread with its own zenoh session.

    python benchmarks/bench_predict.py --json benchmarks/results/bench_predict.json
"""
from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import platform
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

NS = "bench"
EMPTY_KEY = f"acnmp/{NS}/bench/empty"
OBS_T = np.array([0.0, 1.0])
OBS_V = np.array([[0.0, 0.0], [1.0, 0.0]])
STEPS = 200


def _serve(checkpoint: str, endpoint: str, workers: int, ready, stop) -> None:
    """Child process: a model service serving ``checkpoint`` as skill 'reach' plus the empty queryable."""
    import torch

    torch.set_num_threads(1)
    from services.model import ModelService
    from services.transport import open_session

    with open_session("peer", [endpoint]) as session:
        def empty(query):
            with query:
                query.reply(query.key_expr, b"")

        q = session.declare_queryable(EMPTY_KEY, empty, complete=True)
        with ModelService(session, NS, workers=workers, fetch_latest=False) as service:
            service.load_checkpoint(checkpoint, "reach")
            ready.set()
            while not stop.wait(0.2):
                pass
        q.undeclare()


def _train_checkpoint(path: Path, steps: int):
    from acnmp_core.checkpoint import save_checkpoint
    from acnmp_core.cnmp import CNMP, CNMPConfig
    from acnmp_core.tasks.viapoint import obstacle_demos
    from acnmp_core.training import TrainConfig, train

    demos = obstacle_demos()
    model = CNMP(CNMPConfig(n_outputs=2), seed=0)
    train(model, demos, TrainConfig(steps=steps), seed=0, progress=False)
    save_checkpoint(model.eval(), path, meta={"version": 1, "n_demos": len(demos)})
    return model


def _stats(samples_s: list[float]) -> dict:
    a = np.array(samples_s) * 1e3
    return {"p50_ms": float(np.percentile(a, 50)), "p99_ms": float(np.percentile(a, 99)),
            "mean_ms": float(a.mean()), "n": int(a.size)}


def measure_latency(client, model, n: int, warmup: int) -> dict:
    """Interleave the three measurements ``n`` times (after ``warmup`` rounds); return stats."""
    times = {"predict_zenoh": [], "in_process": [], "empty_query": []}

    def predict_zenoh():
        client.predict("reach", OBS_T, OBS_V, n_steps=STEPS)

    def in_process():
        model.predict(OBS_T, OBS_V, n_steps=STEPS)

    def empty_query():
        for reply in client.session.get(EMPTY_KEY, timeout=5.0):
            assert reply.ok is not None

    ops = {"predict_zenoh": predict_zenoh, "in_process": in_process, "empty_query": empty_query}
    for i in range(warmup + n):
        for name, op in ops.items():
            t0 = time.perf_counter()
            op()
            dt = time.perf_counter() - t0
            if i >= warmup:
                times[name].append(dt)
    return {name: _stats(v) for name, v in times.items()}


def measure_throughput(endpoint: str, n_clients: int, duration: float) -> dict:
    """Predicts per second with ``n_clients`` threads, each with its own session, for ``duration`` s."""
    from clients.client import ACNMPClient

    counts, errors = [0] * n_clients, [0] * n_clients
    start = threading.Barrier(n_clients + 1)
    stop = threading.Event()

    def worker(i: int) -> None:
        with ACNMPClient(NS, connect=[endpoint], timeout=30.0) as c:
            c.predict("reach", OBS_T, OBS_V, n_steps=STEPS)  # connected and warm
            start.wait()
            while not stop.is_set():
                try:
                    c.predict("reach", OBS_T, OBS_V, n_steps=STEPS)
                    counts[i] += 1
                except Exception:
                    errors[i] += 1

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(n_clients)]
    for t in threads:
        t.start()
    start.wait()
    t0 = time.perf_counter()
    time.sleep(duration)
    stop.set()
    for t in threads:
        t.join()
    elapsed = time.perf_counter() - t0
    return {"clients": n_clients, "predicts": sum(counts), "errors": sum(errors),
            "seconds": elapsed, "predicts_per_s": sum(counts) / elapsed}


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; print a summary; write JSON with --json FILE. Exit code 0."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=300, help="latency samples per measurement (default: %(default)s)")
    parser.add_argument("--warmup", type=int, default=30)
    parser.add_argument("--duration", type=float, default=3.0, help="seconds per throughput point")
    parser.add_argument("--clients", default="1,4,16", help="concurrent clients per throughput point")
    parser.add_argument("--workers", type=int, default=2, help="model service predict threads")
    parser.add_argument("--train-steps", type=int, default=300, help="training steps of the benchmarked model")
    parser.add_argument("--json", metavar="FILE", help="write the results here")
    args = parser.parse_args(argv)

    import torch

    torch.set_num_threads(1)
    from clients.client import ACNMPClient
    from clients.experiments.common import write_json
    from services.transport import free_port, loopback_endpoint

    ctx = mp.get_context("spawn")  # zenoh sessions do not survive fork
    with tempfile.TemporaryDirectory(prefix="bench-predict-") as tmp:
        ckpt = Path(tmp) / "reach.pt"
        model = _train_checkpoint(ckpt, args.train_steps)
        endpoint = loopback_endpoint(free_port())
        ready, stop = ctx.Event(), ctx.Event()
        child = ctx.Process(target=_serve, args=(str(ckpt), endpoint, args.workers, ready, stop), daemon=True)
        child.start()
        try:
            if not ready.wait(60):
                raise RuntimeError("model service did not start")
            with ACNMPClient(NS, connect=[endpoint], timeout=10.0) as client:
                deadline = time.monotonic() + 10
                while True:  # the queryables need a moment to reach this session
                    try:
                        client.predict("reach", OBS_T, OBS_V, n_steps=STEPS)
                        break
                    except Exception:
                        if time.monotonic() > deadline:
                            raise
                        time.sleep(0.05)
                latency = measure_latency(client, model, args.n, args.warmup)
            throughput = [measure_throughput(endpoint, int(k), args.duration) for k in args.clients.split(",")]
        finally:
            stop.set()
            child.join(15)
            if child.is_alive():
                child.terminate()

    floor = latency["in_process"]["p50_ms"] + latency["empty_query"]["p50_ms"]
    ratio = latency["predict_zenoh"]["p50_ms"] / floor
    result = {
        "benchmark": "predict", "steps": STEPS, "model": "CNMP default (3x128 encoder/decoder), D=2",
        "latency": latency, "p50_floor_ms": floor, "p50_ratio": ratio, "target_ratio": 1.5,
        "target_met": bool(ratio <= 1.5),
        "p99_ratio": latency["predict_zenoh"]["p99_ms"] / (latency["in_process"]["p99_ms"] + latency["empty_query"]["p99_ms"]),
        "throughput": throughput,
        "throughput_scaling_vs_1": {str(t["clients"]): t["predicts_per_s"] / throughput[0]["predicts_per_s"]
                                    for t in throughput},
        "service_workers": args.workers,
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "torch": torch.__version__,
                    "note": "shared machine; numbers from one run"},
    }
    for name, s in latency.items():
        print(f"{name:14s} p50 {s['p50_ms']:7.3f} ms   p99 {s['p99_ms']:7.3f} ms   (n={s['n']})")
    print(f"p50 ratio predict/(in-process + empty) = {ratio:.2f} (target <= 1.5: {'met' if ratio <= 1.5 else 'NOT met'})")
    for t in throughput:
        print(f"{t['clients']:3d} clients: {t['predicts_per_s']:8.1f} predicts/s ({t['errors']} errors)")
    write_json(result, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
