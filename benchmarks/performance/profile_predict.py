"""Where a predict's time goes in the model service, with 1 and with 16 concurrent clients.

The setup of benchmarks/performance/bench_predict.py (one model service process, batching on, the E1-size
model, 200-step predicts; the clients are threads of this process with their own sessions, on the
same 2 cores): for each client count, py-spy samples the service process (all threads, only
while running on a CPU) during the throughput measurement, and each sample is put in the stage of
the innermost frame that names one (:data:`STAGES`). py-spy samples only threads that run Python
(the rpc workers, zenoh's callback threads); a stage's milliseconds per predict are its samples
divided by the sampling rate and the predicts served. The service's CPU per predict (psutil,
all threads) minus those is ``native``: zenoh's own runtime threads (links, routing, tx/rx),
where py-spy sees no Python frame. py-spy is in the ``profile`` extra (``pip install -e .[profile]``).

Caveat: py-spy counts a thread as busy while it runs *or waits for a core* (runnable), so on a
loaded machine a stage's milliseconds include scheduling delay and may exceed its CPU (``native``
then goes negative). So the forward pass is also timed in this process with CPU time
(``time.process_time``), per item, for batches of 1, 2, 6 and 16 predicts (``forward_cpu_ms_per_item``):
batching saves the pass's fixed costs, not the per-point work.

    python benchmarks/performance/profile_predict.py --json benchmarks/results/predict_profile.json
"""
from __future__ import annotations

import argparse
import collections
import multiprocessing as mp
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks._results import save_result, start_run  # noqa: E402
from benchmarks.performance import bench_predict as B  # noqa: E402

#: (stage, file suffix, function) markers, matched from the innermost frame outwards: a sample
#: belongs to the first marker found. Order matters only where one marker calls another.
STAGES = (
    ("reply: msgpack encode of the reply", "services/transport/wire.py", "encode"),
    ("reply: zenoh query.reply and the query's drop", "services/transport/rpc.py", "RpcQueryable._answer"),
    ("request: query tensors (normalise, time grid)", "acnmp_core/model/cnmp.py", "CNMP.make_query"),
    ("forward: encoder + decoder (torch)", "acnmp_core/model/cnmp.py", "CNMP.predict_queries"),
    ("request: msgpack decode", "services/transport/wire.py", "decode"),
    ("request: validation and limits", "services/model/handlers.py", "prepare_predict"),
    ("batching: collecting, futures", "services/model/batching.py", "PredictBatcher._take"),
    ("batching: collecting, futures", "services/model/batching.py", "PredictBatcher._run_pass"),
    ("zenoh callback: queueing the query", "services/transport/rpc.py", "RpcQueryable._serve_inline"),
)
_FRAME = re.compile(r"^(?P<func>.+?) \((?P<file>[^:)]+)(?::\d+)?\)$")


def stage_of(frames: list[str]) -> str:
    """The stage of one sampled stack (outermost frame first), or ``other``."""
    for frame in reversed(frames):
        m = _FRAME.match(frame)
        if m is None:
            continue
        for stage, suffix, func in STAGES:
            if m["func"] == func and m["file"].endswith(suffix):
                return stage
    return "other"


def shares(raw_file: Path) -> tuple[dict[str, float], int]:
    """({stage: share of the samples}, samples) from a py-spy ``--format raw`` file."""
    counts: collections.Counter = collections.Counter()
    for line in raw_file.read_text().splitlines():
        stack, _, n = line.rpartition(" ")
        if stack and n.isdigit():
            counts[stage_of(stack.split(";")[1:])] += int(n)  # the first entry names the thread
    total = sum(counts.values())
    return {k: v / total for k, v in counts.most_common()}, total


def forward_cpu_per_item(model, batches=(1, 2, 6, 16), reps: int = 100) -> dict[str, float]:
    """CPU milliseconds (median of ``reps``) per predict of the service's two steps, in this
    process: ``make_query`` (one 200-step query) and ``predict_queries`` of a batch of b such
    queries divided by b (``batch_<b>``)."""
    import time

    import numpy as np

    def cpu_ms(f) -> float:
        times = []
        for _ in range(reps):
            t0 = time.process_time()
            f()
            times.append(time.process_time() - t0)
        return 1e3 * float(np.median(times))

    q = model.make_query(B.OBS_T, B.OBS_V, n_steps=B.STEPS)
    out = {"make_query": cpu_ms(lambda: model.make_query(B.OBS_T, B.OBS_V, n_steps=B.STEPS))}
    for b in batches:
        out[f"batch_{b}"] = cpu_ms(lambda: model.predict_queries([q] * b)) / b
    return out


def main(argv: list[str] | None = None) -> int:
    """Profile; print the split; write JSON with --json FILE. Exit code 0."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clients", default="1,16", help="client counts (default: %(default)s)")
    ap.add_argument("--duration", type=float, default=15.0, help="seconds per client count")
    ap.add_argument("--rate", type=int, default=200, help="py-spy samples per second")
    ap.add_argument("--json", metavar="FILE", help="also write the profile here as JSON (default: print only)")
    args, prov = start_run(ap, argv, __file__)
    import psutil

    from clients.client import ACNMPClient
    from services.model.batching import DEFAULT_BATCH_MAX, DEFAULT_BATCH_WINDOW
    from services.transport import free_port, loopback_endpoint

    spy = Path(sys.executable).with_name("py-spy")
    if not spy.is_file():
        ap.error("py-spy is not installed: pip install -e .[profile]")
    ctx = mp.get_context("spawn")
    rows = {}
    with tempfile.TemporaryDirectory(prefix="profile-predict-") as tmp:
        ckpt = Path(tmp) / "reach.pt"
        forward = forward_cpu_per_item(B._train_checkpoint(ckpt, 300))  # before the service runs
        endpoint = loopback_endpoint(free_port())
        stop, ready = ctx.Event(), ctx.Event()
        child = ctx.Process(target=B._serve, args=(str(ckpt), endpoint, 2, DEFAULT_BATCH_MAX, DEFAULT_BATCH_WINDOW, 1,
                                                   ready, stop), daemon=True)
        child.start()
        try:
            if not ready.wait(60):
                raise RuntimeError("model service did not start")
            with ACNMPClient(B.NS, connect=[endpoint], timeout=10.0) as c:
                B._wait_served(c)
            for k in (int(x) for x in args.clients.split(",")):
                raw = Path(tmp) / f"spy-{k}.txt"
                rec = subprocess.Popen([str(spy), "record", "-p", str(child.pid), "-d", str(int(args.duration)),
                                        "-r", str(args.rate), "--format", "raw", "-o", str(raw), "--nonblocking"],
                                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                r = B.measure_throughput(endpoint, k, args.duration, psutil.Process(child.pid))
                rec.wait(120)
                split, samples = shares(raw)
                n = max(r["predicts"], 1)
                by_stage = {s: 1e3 * v * samples / args.rate / n for s, v in split.items()}
                by_stage["native (zenoh runtime threads, not sampled)"] = \
                    r["service_cpu_ms_per_predict"] - sum(by_stage.values())
                rows[str(k)] = {**r, "samples": samples, "share_of_python_samples": split,
                                "service_ms_per_predict_by_stage": by_stage}
        finally:
            stop.set()
            child.join(15)
            if child.is_alive():
                child.terminate()
    result = {"benchmark": "predict_profile", "provenance": prov, "steps": B.STEPS,
              "model": "CNMP default (3x128 encoder/decoder), D=2", "batching": "on (service default)",
              "duration_s": args.duration, "py_spy_rate_hz": args.rate, "by_clients": rows,
              "forward_cpu_ms_per_item": forward,
              "machine": {"note": "shared 2-core machine (other jobs running); clients are threads of the "
                                  "benchmark process, on the same cores as the service; py-spy samples add load"}}
    print("in-process CPU ms per predict: " + ", ".join(f"{k}: {v:.3f}" for k, v in forward.items()))
    for k, row in rows.items():
        print(f"{k} client(s): {row['predicts_per_s']:.0f} predicts/s, service {row['service_cpu_ms_per_predict']:.2f} "
              f"+ clients {row['client_cpu_ms_per_predict']:.2f} CPU ms per predict")
        for stage, v in row["service_ms_per_predict_by_stage"].items():
            print(f"   {v:6.3f} ms  {stage}")
    if args.json:
        save_result(result, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
