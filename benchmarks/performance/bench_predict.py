"""Predict latency and throughput of the model service over zenoh, against its two lower bounds,
with dynamic batching on and off side by side.

One model service process per configuration (``--modes``: ``off`` = ``batch_max=1``, each predict
alone; ``on`` = the service default, batching what is waiting; ``window`` = batching with a
``--window`` collection window; ``threads2`` = batching on two batcher threads), all started at once, spawned, peer mode on loopback, one hop. In
one run, interleaved so that they share the machine's conditions:

- ``predict_zenoh``: a 200-step predict (2 observations, the E1 model, default architecture) sent by
  :class:`clients.client.ACNMPClient` to the service of each configuration (``modes``;
  ``predict_zenoh`` itself is the default configuration, ``on``);
- ``in_process``: the same ``CNMP.predict`` called directly in this process;
- ``empty_query``: a zenoh query with no payload to a queryable in a service process that
  replies an empty payload at once (the transport's floor).

Target: p50(predict_zenoh) <= 1.5 x (p50(in_process) + p50(empty_query)). Then throughput
(predicts/s) with 1, 4 and 16 concurrent clients, each a thread of this process with its own zenoh
session, ``--reps`` times, cycling through the configurations within each repetition; the target
is throughput(16) >= 3 x throughput(1) of the same configuration (medians over the repetitions).
The clients share the machine (2 cores here) with the service. For each configuration it also
records the cores kept busy (service and clients, CPU seconds per second) and the CPU ceiling of the
scaling: cores / (CPU ms per predict at 16 clients) / throughput(1), what 16 clients could reach
with every core busy at the CPU cost per predict they were measured at.

    python benchmarks/performance/bench_predict.py --json benchmarks/results/bench_predict.json
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

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

NS = "bench"
EMPTY_KEY = f"acnmp/{NS}/bench/empty"
OBS_T = np.array([0.0, 1.0])
OBS_V = np.array([[0.0, 0.0], [1.0, 0.0]])
STEPS = 200


def _serve(checkpoint: str, endpoint: str, workers: int, batch_max: int, window: float, threads: int, ready,
           stop, routed: bool = False, computed=None) -> None:
    """Child process: a model service serving ``checkpoint`` as skill 'reach' plus the empty queryable,
    as a peer listening on ``endpoint``; ``routed``: as a client of the router there, without the
    empty queryable. At exit, ``computed`` (a shared integer) gets the predicts it computed."""
    import torch

    torch.set_num_threads(1)
    from services.model.service import ModelService
    from services.transport import open_session

    with open_session("client" if routed else "peer", None if routed else [endpoint],
                      [endpoint] if routed else None) as session:
        def empty(query):
            with query:
                query.reply(query.key_expr, b"")

        q = None if routed else session.declare_queryable(EMPTY_KEY, empty, complete=True)
        with ModelService(session, NS, workers=workers, fetch_latest=False, batch_max=batch_max,
                          batch_window=window, batch_threads=threads) as service:
            service.load_checkpoint(checkpoint, "reach")
            ready.set()
            while not stop.wait(0.2):
                pass
            b = service.batcher
            if computed is not None and b is not None:
                computed.value = b.computed
            if b is not None:
                print(f"batcher (max {b.max_items}, window {b.window}, threads {b.threads}): {b.computed} predicts "
                      f"in {b.passes} passes, "
                      f"largest {b.largest}", file=sys.stderr, flush=True)
        if q is not None:
            q.undeclare()


def _route(endpoint: str, ready, stop) -> None:
    """Child process: a zenoh router listening on ``endpoint``."""
    from services.transport import open_session

    with open_session("router", [endpoint]):
        ready.set()
        stop.wait()


def _train_checkpoint(path: Path, steps: int):
    from acnmp_core.model.checkpoint import save_checkpoint
    from acnmp_core.model.cnmp import CNMP, CNMPConfig
    from acnmp_core.model.training import TrainConfig, train
    from acnmp_core.tasks.viapoint.task import obstacle_demos

    demos = obstacle_demos()
    model = CNMP(CNMPConfig(n_outputs=2), seed=0)
    train(model, demos, TrainConfig(steps=steps), seed=0, progress=False)
    save_checkpoint(model.eval(), path, meta={"version": 1, "n_demos": len(demos)})
    return model


def _stats(samples_s: list[float]) -> dict:
    a = np.array(samples_s) * 1e3
    return {"p50_ms": float(np.percentile(a, 50)), "p99_ms": float(np.percentile(a, 99)),
            "mean_ms": float(a.mean()), "n": int(a.size)}


def measure_latency(clients: dict, model, n: int, warmup: int) -> dict:
    """Interleave a predict to each configuration's service (``clients``: mode -> connected client),
    the in-process predict and the empty query ``n`` times (after ``warmup`` rounds); return stats
    keyed ``predict_<mode>``, ``in_process``, ``empty_query``."""
    first = next(iter(clients.values()))

    def predict_zenoh(client):
        return lambda: client.predict("reach", OBS_T, OBS_V, n_steps=STEPS)

    def in_process():
        model.predict(OBS_T, OBS_V, n_steps=STEPS)

    def empty_query():
        for reply in first.session.get(EMPTY_KEY, timeout=5.0):
            assert reply.ok is not None

    ops = {f"predict_{mode}": predict_zenoh(c) for mode, c in clients.items()}
    ops.update(in_process=in_process, empty_query=empty_query)
    times = {name: [] for name in ops}
    for i in range(warmup + n):
        for name, op in ops.items():
            t0 = time.perf_counter()
            op()
            dt = time.perf_counter() - t0
            if i >= warmup:
                times[name].append(dt)
    return {name: _stats(v) for name, v in times.items()}


def _cpu_seconds(proc) -> float:
    """User + system CPU seconds of a psutil process (or a list of them, summed) so far."""
    if isinstance(proc, list):
        return sum(_cpu_seconds(p) for p in proc)
    t = proc.cpu_times()
    return t.user + t.system


def run_clients(n_clients: int, duration: float, connect, op, on_start=None) -> dict:
    """``n_clients`` threads, each with its own client ``connect()`` (a context manager), call
    ``op(client)`` once to warm up, then as often as they can for ``duration`` s, all at once.
    ``on_start()`` runs when they start (e.g. to read CPU counters). Returns the ops done, the
    errors and the seconds measured."""
    counts, errors = [0] * n_clients, [0] * n_clients
    start = threading.Barrier(n_clients + 1)
    stop = threading.Event()

    def worker(i: int) -> None:
        with connect() as c:
            op(c)  # connected and warm
            start.wait()
            while not stop.is_set():
                try:
                    op(c)
                    counts[i] += 1
                except Exception:
                    errors[i] += 1

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(n_clients)]
    for t in threads:
        t.start()
    start.wait()
    if on_start is not None:
        on_start()
    t0 = time.perf_counter()
    time.sleep(duration)  # the measuring window
    stop.set()
    for t in threads:
        t.join()
    return {"ops": sum(counts), "errors": sum(errors), "seconds": time.perf_counter() - t0}


def measure_throughput(endpoint: str, n_clients: int, duration: float, service=None, empty: bool = False,
                       skill_key: bool = False) -> dict:
    """Predicts per second with ``n_clients`` threads, each with its own session, for ``duration`` s;
    with ``service`` (a psutil process) also the CPU milliseconds per predict of the service and
    of this (the clients') process. ``empty``: empty queries instead of predicts (the transport's
    floor), counted the same way."""
    import psutil

    from clients.client import ACNMPClient, predict_request

    request = predict_request(OBS_T, OBS_V, n_steps=STEPS)

    def op(c):
        if empty:
            if not [r for r in c.session.get(EMPTY_KEY, timeout=30.0) if r.ok is not None]:
                raise RuntimeError("no empty reply")
        elif skill_key:  # on the skill's key, as clients did before they shared predicts between processes
            c.request(c.keys.predict("reach"), request)
        else:
            c.predict("reach", OBS_T, OBS_V, n_steps=STEPS)

    me, cpu0 = psutil.Process(), []

    def on_start():
        cpu0.extend([_cpu_seconds(service) if service is not None else 0.0, _cpu_seconds(me)])

    ran = run_clients(n_clients, duration, lambda: ACNMPClient(NS, connect=[endpoint], timeout=30.0), op, on_start)
    cpu1 = (_cpu_seconds(service) if service is not None else 0.0, _cpu_seconds(me))
    n = max(ran["ops"], 1)
    return {"clients": n_clients, "predicts": ran["ops"], "errors": ran["errors"],
            "seconds": ran["seconds"], "predicts_per_s": ran["ops"] / ran["seconds"],
            "service_cpu_ms_per_predict": 1e3 * (cpu1[0] - cpu0[0]) / n if service is not None else None,
            "client_cpu_ms_per_predict": 1e3 * (cpu1[1] - cpu0[1]) / n}


#: The configurations: ``off``, ``on``, ``window``, ``threads2`` (services), ``routed1`` / ``routed2``
#: (one or two ``on`` services as clients of a zenoh router; with two, each client sends each predict
#: to one of them in turn), ``routed2key`` (two, the clients' predicts on the skill's key: every
#: process computes each), ``empty`` (empty queries to the ``on`` service: the transport's floor,
#: throughput only).
MODES = ("off", "on", "window", "threads2", "routed1", "routed2", "routed2key", "empty")


def _wait_served(client) -> None:
    deadline = time.monotonic() + 10
    while True:  # the queryables need a moment to reach this session
        try:
            client.predict("reach", OBS_T, OBS_V, n_steps=STEPS)
            return
        except Exception:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.05)


def _median(values: list[float]) -> float:
    return float(np.median(values))


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; print a summary; write JSON with --json FILE. Exit code 0."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=300, help="latency samples per measurement (default: %(default)s)")
    parser.add_argument("--warmup", type=int, default=30, help="predicts sent and not timed first (default 30)")
    parser.add_argument("--duration", type=float, default=3.0, help="seconds per throughput point")
    parser.add_argument("--clients", default="1,4,16", help="concurrent clients per throughput point")
    parser.add_argument("--reps", type=int, default=3, help="repetitions of the throughput points (default: %(default)s)")
    parser.add_argument("--modes", default="off,on,window,threads2,empty", help="configurations (default: %(default)s)")
    parser.add_argument("--window", type=float, default=0.001, help="collection window of mode 'window', seconds")
    parser.add_argument("--workers", type=int, default=2, help="model service predict threads")
    parser.add_argument("--train-steps", type=int, default=300, help="training steps of the benchmarked model")
    parser.add_argument("--json", metavar="FILE", help="write the results here")
    from benchmarks._results import save_result, start_run

    args, prov = start_run(parser, argv, __file__)
    import psutil
    import torch

    from clients.client import ACNMPClient
    from services.model.batching import DEFAULT_BATCH_MAX, DEFAULT_BATCH_WINDOW
    from services.transport import free_port, loopback_endpoint

    modes = [m for m in args.modes.split(",") if m]
    if "on" not in modes or any(m not in MODES for m in modes):
        parser.error(f"--modes: a comma-separated subset of {', '.join(MODES)} that includes 'on'")
    settings = {"off": (1, 0.0, 1), "on": (DEFAULT_BATCH_MAX, DEFAULT_BATCH_WINDOW, 1),
                "window": (DEFAULT_BATCH_MAX, args.window, 1), "threads2": (DEFAULT_BATCH_MAX, DEFAULT_BATCH_WINDOW, 2),
                "routed1": (DEFAULT_BATCH_MAX, DEFAULT_BATCH_WINDOW, 1), "routed2": (DEFAULT_BATCH_MAX, DEFAULT_BATCH_WINDOW, 1),
                "routed2key": (DEFAULT_BATCH_MAX, DEFAULT_BATCH_WINDOW, 1),
                "empty": (None, None, None)}
    n_clients = [int(k) for k in args.clients.split(",")]
    ctx = mp.get_context("spawn")  # zenoh sessions do not survive fork
    with tempfile.TemporaryDirectory(prefix="bench-predict-") as tmp:
        ckpt = Path(tmp) / "reach.pt"
        model = _train_checkpoint(ckpt, args.train_steps)
        served = [m for m in modes if m != "empty"]
        endpoints = {m: loopback_endpoint(free_port()) for m in served}
        stop = ctx.Event()
        children, readies, computed = {}, {}, {}
        for m in served:
            if m.startswith("routed"):  # a router, and that many service processes as its clients
                readies[m] = ctx.Event()
                children[m] = ctx.Process(target=_route, args=(endpoints[m], readies[m], stop), daemon=True)
                children[m].start()
                readies[m].wait(60)
                for i in range(int(m.removeprefix("routed").removesuffix("key"))):
                    readies[f"{m}+{i}"] = ctx.Event()
                    computed[f"{m}+{i}"] = ctx.Value("q", 0)
                    children[f"{m}+{i}"] = ctx.Process(target=_serve, args=(
                        str(ckpt), endpoints[m], args.workers, *settings[m], readies[f"{m}+{i}"], stop, True,
                        computed[f"{m}+{i}"]), daemon=True)
                    children[f"{m}+{i}"].start()
                continue
            readies[m] = ctx.Event()
            children[m] = ctx.Process(target=_serve, args=(str(ckpt), endpoints[m], args.workers, *settings[m],
                                                           readies[m], stop), daemon=True)
            children[m].start()
        try:
            for m in readies:
                if not readies[m].wait(60):
                    raise RuntimeError(f"model service ({m}) did not start")
            clients = {m: ACNMPClient(NS, connect=[endpoints[m]], timeout=10.0) for m in served}
            try:
                for c in clients.values():
                    _wait_served(c)
                latency = measure_latency(clients, model, args.n, args.warmup)
            finally:
                for c in clients.values():
                    c.close()
            runs = []  # one row per (repetition, clients, mode), the modes' order rotating per repetition
            for rep in range(args.reps):
                order = modes[rep % len(modes):] + modes[:rep % len(modes)]
                for k in n_clients:
                    for m in order:
                        on = "on" if m == "empty" else m
                        runs.append({"rep": rep, "mode": m, **measure_throughput(
                            endpoints[on], k, args.duration, [psutil.Process(c.pid) for n, c in children.items()
                                                             if n == on or n.startswith(on + "+")], empty=m == "empty",
                            skill_key=m == "routed2key")})
        finally:
            stop.set()
            for child in children.values():
                child.join(15)
                if child.is_alive():
                    child.terminate()

    latency["predict_zenoh"] = latency["predict_on"]
    floor = latency["in_process"]["p50_ms"] + latency["empty_query"]["p50_ms"]
    ratio = latency["predict_zenoh"]["p50_ms"] / floor
    by_mode = {}
    for m in modes:
        rate = {k: _median([r["predicts_per_s"] for r in runs if r["mode"] == m and r["clients"] == k])
                for k in n_clients}
        per_rep = {k: [r["predicts_per_s"] for r in runs if r["mode"] == m and r["clients"] == k] for k in n_clients}
        lat = latency["empty_query" if m == "empty" else f"predict_{m}"]
        by_mode[m] = {
            "batch_max": settings[m][0], "batch_window_s": settings[m][1], "batch_threads": settings[m][2],
            "p50_ms": lat["p50_ms"], "p50_ratio": lat["p50_ms"] / floor,
            "predicts_per_s_median": {str(k): rate[k] for k in n_clients},
            "scaling_vs_1": {str(k): rate[k] / rate[n_clients[0]] for k in n_clients},
            "scaling_vs_1_per_rep": {str(k): [a / b for a, b in zip(per_rep[k], per_rep[n_clients[0]])]
                                     for k in n_clients},
            "errors": sum(r["errors"] for r in runs if r["mode"] == m),
            "service_cpu_ms_per_predict_median": {
                str(k): _median([r["service_cpu_ms_per_predict"] for r in runs if r["mode"] == m and r["clients"] == k])
                for k in n_clients},
            "client_cpu_ms_per_predict_median": {
                str(k): _median([r["client_cpu_ms_per_predict"] for r in runs if r["mode"] == m and r["clients"] == k])
                for k in n_clients},
            # cores kept busy by the service and the clients together (CPU seconds per second)
            "cores_busy_median": {
                str(k): _median([r["predicts_per_s"] * (r["service_cpu_ms_per_predict"] + r["client_cpu_ms_per_predict"])
                                 / 1e3 for r in runs if r["mode"] == m and r["clients"] == k]) for k in n_clients},
        }
        # The CPU ceiling: with every core busy at the CPU per predict measured at the top client
        # count, throughput could be at most cores / that; relative to one client's rate it is
        # (cores / cores busy with one client) x (CPU per predict with one client / at the top).
        row = by_mode[m]
        cpu = {k: row["service_cpu_ms_per_predict_median"][k] + row["client_cpu_ms_per_predict_median"][k]
               for k in row["service_cpu_ms_per_predict_median"]}
        first, last = str(n_clients[0]), str(n_clients[-1])
        row["cpu_ms_per_predict_median"] = cpu
        row["scaling_ceiling"] = (os.cpu_count() * 1e3 / cpu[last]) / rate[n_clients[0]]
        if m.startswith("routed"):
            # predicts the service processes computed, against those the clients counted (which leave
            # out a few warm-up and latency predicts, so ~1.0 means each predict was computed once)
            done = [computed[k].value for k in sorted(computed) if k.startswith(m + "+")]
            row["service_processes"] = len(done)
            row["computed_per_process"] = done
            row["computed_per_counted_predict"] = sum(done) / max(1, sum(r["predicts"] for r in runs if r["mode"] == m))
    top = str(n_clients[-1])
    result = {
        "benchmark": "predict", "provenance": prov, "steps": STEPS,
        "model": "CNMP default (3x128 encoder/decoder), D=2",
        "latency": latency, "p50_floor_ms": floor, "p50_ratio": ratio, "target_ratio": 1.5,
        "target_met": bool(ratio <= 1.5),
        "p99_ratio": latency["predict_zenoh"]["p99_ms"] / (latency["in_process"]["p99_ms"] + latency["empty_query"]["p99_ms"]),
        "modes": by_mode,
        "throughput_target": f"throughput({top} clients) >= 3 x throughput({n_clients[0]} client), same mode",
        "throughput_scaling_vs_1": by_mode["on"]["scaling_vs_1"],
        "throughput_target_met": bool(by_mode["on"]["scaling_vs_1"][top] >= 3.0),
        "throughput": runs, "reps": args.reps, "duration_s": args.duration,
        "service_workers": args.workers,
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "torch": torch.__version__,
                    "note": "shared machine (other jobs running); clients are threads of the benchmark "
                            "process, on the same cores as the service"},
    }
    for name, s in latency.items():
        print(f"{name:14s} p50 {s['p50_ms']:7.3f} ms   p99 {s['p99_ms']:7.3f} ms   (n={s['n']})")
    print(f"p50 ratio predict/(in-process + empty) = {ratio:.2f} (target <= 1.5: {'met' if ratio <= 1.5 else 'NOT met'})")
    for m, row in by_mode.items():
        rates = ", ".join(f"{k}: {v:.0f}/s" for k, v in row["predicts_per_s_median"].items())
        cpu = ", ".join(f"{k}: {row['service_cpu_ms_per_predict_median'][k]:.2f}+"
                        f"{row['client_cpu_ms_per_predict_median'][k]:.2f}" for k in row["predicts_per_s_median"])
        print(f"{m:7s} p50 ratio {row['p50_ratio']:.2f}; {rates}; x{row['scaling_vs_1'][top]:.2f} at {top} "
              f"({row['errors']} errors); CPU ms per predict service+clients {cpu}; cores busy "
              f"{', '.join(f'{k}: {v:.2f}' for k, v in row['cores_busy_median'].items())}; CPU ceiling at {top}: "
              f"x{row['scaling_ceiling']:.2f}"
              + (f"; {row['service_processes']} service processes computed {row['computed_per_process']}: "
                 f"{row['computed_per_counted_predict']:.2f} computations per predict" if "service_processes" in row else ""))
    if args.json:
        save_result(result, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
