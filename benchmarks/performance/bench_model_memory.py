"""The model service's memory under predicts at their key's bound, and the refusal of one over it (issue 66).

An authenticated ``acnmp up`` deployment in its own process (``--workers 0``, skill e1 trained for
20 steps). Measured:

1. **flood**: ``--senders`` (default 4) processes holding the client role's password each send
   ``--predicts`` / senders (default 100 in all) predicts whose payload is just under the predict
   key's bound (services/transport/payload_limits.py: a valid predict with a padding field the
   service ignores), one after another; the model service's resident set before (idle, after a
   few light predicts), at peak (sampled every 20 ms) and once idle again (the lowest of the
   samples over ``--settle`` s after the last answer). Target: idle again within 1.5x of idle.
2. **refusals**: a predict one byte over the bound sent by the client (``ACNMPClient``: refused
   before it is sent), the same payload sent by a raw zenoh get (dropped by zenoh's filter: the
   get ends with no reply) and a 500 MB one by the client; the seconds each took. Target: < 1 s.

    python benchmarks/performance/bench_model_memory.py [--senders 4] [--predicts 100] [--settle 10]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks._results import RESULTS, main_provenance, save_result  # noqa: E402
from benchmarks.performance.bench_hostile import RssSampler  # noqa: E402
from benchmarks.performance.up_process import rss, up_process  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

#: One sender: ``n`` predicts of ``size`` bytes each on the key, one after another; prints one
#: line per answer ("ok" or the error code).
_SENDER = r"""
import sys, numpy as np
from services.transport import call, encode, open_session
from services.transport.wire import WireError
cfg, key, n, size = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
base = {"v": 1, "obs_times": np.array([0.0, 1.0]), "obs_values": np.array([[0.0, 0.0], [1.0, 0.0]]), "n_steps": 20}
pad = size - len(encode({**base, "pad": b""}))
body = encode({**base, "pad": bytes(pad - 4)})  # bin32's header: 4 bytes more than bin8's
assert len(body) <= size, (len(body), size)
with open_session(None, config_file=cfg) as s:
    for _ in range(n):
        try:
            call(s, key, body, timeout=120)
            print("ok", flush=True)
        except WireError as exc:
            print(exc.code, flush=True)
"""


def _idle_rss(pid: int, seconds: float, period: float = 0.1) -> tuple[float, list[float]]:
    """The lowest resident set (MiB) of ``pid`` over ``seconds`` (sampled every ``period``), and
    the samples: memory freed is given back within a moment, not at once."""
    samples = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        samples.append(rss(pid) / 2**20)
        time.sleep(period)
    return min(samples), samples


def measure(senders: int, predicts: int, settle: float) -> dict:
    """Both parts (see the module docstring) on one ``acnmp up`` deployment."""
    from clients.client import ACNMPClient, ClientError
    from services.transport.keys import Keyspace
    from services.transport.payload_limits import request_limit

    env = dict(os.environ, PYTHONPATH=str(ROOT), RERUN_ANALYTICS="0")
    with up_process("benchmem") as run:
        ns = run.namespace
        keys = Keyspace(ns)
        key = keys.predict("e1")
        bound = request_limit(key)
        model = next(p.pid for p in run.processes if p.name == "model")
        out: dict = {"senders": senders, "predicts": predicts, "payload_bytes": bound, "settle_s": settle}
        with ACNMPClient(ns, role="client", timeout=30) as client:
            for _ in range(20):  # warm: the first predicts build what every later one reuses
                client.predict("e1", [0.0, 1.0], [[0.0, 0.0], [1.0, 0.0]], n_steps=20)
            out["idle_mib"], _ = _idle_rss(model, 2.0)
            sampler = RssSampler(model)
            t0 = time.perf_counter()
            each = [predicts // senders + (i < predicts % senders) for i in range(senders)]
            procs = [subprocess.Popen([sys.executable, "-c", _SENDER, run.credentials, key, str(n), str(bound)],
                                      cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                     for n in each]
            answers: dict[str, int] = {}
            for p in procs:
                stdout, stderr = p.communicate(timeout=900)
                for word in stdout.split():
                    answers[word] = answers.get(word, 0) + 1
                if p.returncode:
                    answers[f"sender exit {p.returncode}: {stderr.strip().splitlines()[-1:]}"] = 1
            out["flood_s"] = round(time.perf_counter() - t0, 2)
            out["peak_mib"] = sampler.stop() / 2**20
            out["answers"] = answers
            out["after_mib"], samples = _idle_rss(model, settle)
            out["after_samples_mib"] = [round(s, 1) for s in samples[:: max(1, len(samples) // 20)]]
            out["after_over_idle"] = out["after_mib"] / out["idle_mib"]
            client.info("e1")  # still answering

            over = bytes(bound + 1)
            refusals = {}
            for name, body in (("over_bound_client", over), ("500mb_client", None)):
                body = body if body is not None else bytes(500 * 2**20)
                t = time.perf_counter()
                try:
                    client.request(key, body)
                    code = "ok"
                except ClientError as exc:
                    code = exc.code
                refusals[name] = {"bytes": len(body), "answer": code, "seconds": round(time.perf_counter() - t, 4)}
                del body
            t = time.perf_counter()
            replies = list(client.session.get(key, payload=over, timeout=60))
            refusals["over_bound_raw_get"] = {"bytes": len(over), "answer": f"{len(replies)} replies",
                                              "seconds": round(time.perf_counter() - t, 4)}
            out["refusals"] = refusals
        return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--senders", type=int, default=4, help="sender processes (default: %(default)s)")
    p.add_argument("--predicts", type=int, default=100, help="predicts at the bound in all (default: %(default)s)")
    p.add_argument("--settle", type=float, default=10.0,
                   help="seconds of samples once idle again; the lowest is reported (default: %(default)s)")
    p.add_argument("--out", default=str(RESULTS / "bench_model_memory.json"), help="the JSON written (default: %(default)s)")
    args = p.parse_args(argv)
    prov = main_provenance(__file__, argv)
    t0 = time.perf_counter()
    measured = measure(args.senders, args.predicts, args.settle)
    result = {"benchmark": "model_memory", "provenance": prov, "wall_time_s": round(time.perf_counter() - t0, 1),
              "targets": {"after_over_idle": 1.5, "refusal_s": 1.0}, **measured}
    return save_result(result, args.out, headline=("idle_mib", "peak_mib", "after_mib", "after_over_idle", "refusals"))


if __name__ == "__main__":
    sys.exit(main())
