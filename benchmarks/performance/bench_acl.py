"""The access table and the message bounds under attack (issue 31), three measurements:

1. **generated cases**: ``--cases`` (default 10,000) generated (role, message, key expression,
   payload) cases against an authenticated in-process deployment (benchmarks/performance/hostile_acl.py):
   refusals, state changes outside the table (target 0), crashes (target 0).
2. **flood**: an ``acnmp up`` deployment in its own process (the router is the launcher); an
   attacker process holding the client role's password puts a ``--flood-mb`` (default 500) MB
   payload and sends a query carrying one. Reported: the router's and the model service's
   resident set before, at peak (psutil, every 20 ms) and after (target: peak < 1 GiB each,
   after within 20 % of before).
3. **57 MB list-encoded predict**: the attacker sends one (client role, the concrete predict key)
   while a second client sends light predicts back to back; reported: the light predicts' latency
   during the hostile request (target: every one within 1 s) and the hostile request's answer.

    python benchmarks/performance/bench_acl.py [--cases 10000] [--flood-mb 500] [--out benchmarks/results/bench_acl.json]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks._results import main_provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402
from benchmarks.performance.bench_hostile import RssSampler  # noqa: E402
from benchmarks.performance.up_process import rss, up_process  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

_ATTACKER = r"""
import sys, numpy as np, msgpack
from services.transport import open_session
cfg, key, what, mb = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
with open_session(None, config_file=cfg) as s:
    if what == "put":
        s.put(key, bytes(mb * 2**20))
    elif what == "query":
        for _ in s.get(key, payload=bytes(mb * 2**20), timeout=20):
            pass
    else:  # a list-encoded predict of about mb MB (msgpack floats, 9 bytes each)
        n = mb * 2**20 // 27
        body = msgpack.packb({"v": 1, "obs_times": np.linspace(0, 1, n).tolist(),
                              "obs_values": np.zeros((n, 2)).tolist(), "n_steps": 20})
        print(len(body), flush=True)
        for r in s.get(key, payload=body, timeout=60):
            print("ok" if r.ok is not None else r.err.payload.to_bytes()[:200], flush=True)
"""


def _attack(cfg: str, key: str, what: str, mb: int) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-c", _ATTACKER, cfg, key, what, str(mb)], env=env, cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


def generated(cases: int) -> dict:
    """Part 1 (see the module docstring)."""
    from benchmarks.performance.hostile_acl import acl_deployment, run_cases

    with tempfile.TemporaryDirectory(prefix="bench-acl-") as tmp, acl_deployment(Path(tmp) / "d") as dep:
        t0 = time.perf_counter()
        result = run_cases(dep, cases)
        result["seconds"] = round(time.perf_counter() - t0, 1)
    return result


def flood_and_list_predict(flood_mb: int, repeats: int = 3, env_extra: dict | None = None) -> dict:
    """Parts 2 and 3 (see the module docstring), on one ``acnmp up`` deployment."""
    from clients.client import ACNMPClient
    from services.transport.keys import Keyspace

    with up_process("benchacl", env_extra) as run:
        ns = run.namespace
        keys = Keyspace(ns)
        pids = {"router": run.pid, "model": next(p.pid for p in run.processes if p.name == "model")}
        out: dict = {"flood_mb": flood_mb, "repeats": repeats}
        with ACNMPClient(ns, role="client", timeout=30) as client:
            client.info("e1")
            start = {n: rss(p) for n, p in pids.items()}
            out["start_mib"] = {n: v / 2**20 for n, v in start.items()}
            for i, what in enumerate(("put", "query") * repeats):
                before = {n: rss(p) for n, p in pids.items()}
                samplers = {n: RssSampler(p) for n, p in pids.items()}
                attack = _attack(run.credentials, keys.predict("e1"), what, flood_mb)
                client.info("e1")  # still answering
                peak = {n: s.stop() for n, s in samplers.items()}
                after = {n: rss(p) for n, p in pids.items()}
                out.setdefault("floods", []).append({
                    "what": what, "attacker_exit": attack.returncode, "attacker_stderr": attack.stderr[-300:],
                    **{f"{n}_mib": {"before": before[n] / 2**20, "peak": peak[n] / 2**20,
                                    "after": after[n] / 2**20} for n in pids}})
            end = {n: rss(p) for n, p in pids.items()}
            out["peak_mib"] = {n: max(f[f"{n}_mib"]["peak"] for f in out["floods"]) for n in pids}
            out["end_over_start"] = {n: end[n] / start[n] for n in pids}
            # part 3: a 57 MB list-encoded predict while light predicts run back to back
            latencies: list[float] = []
            stop = threading.Event()

            def light() -> None:
                with ACNMPClient(ns, role="client", timeout=30) as c2:
                    while not stop.is_set():
                        t = time.perf_counter()
                        c2.predict("e1", [0.0, 1.0], [[0.0, 0.0], [1.0, 0.0]], n_steps=20)
                        latencies.append(time.perf_counter() - t)

            th = threading.Thread(target=light, daemon=True)
            th.start()
            while not latencies:
                time.sleep(0.01)
            n_before = len(latencies)
            attack = _attack(run.credentials, keys.predict("e1"), "list", 57)
            n_during = len(latencies)
            stop.set()
            th.join(timeout=30)
            during = latencies[n_before:n_during + 1]
            out["list_predict_57mb"] = {"hostile_bytes": attack.stdout.splitlines()[:1],
                                        "hostile_answer": attack.stdout.splitlines()[1:2],
                                        "light_predicts_during": len(during),
                                        "light_max_s": max(during) if during else None,
                                        "light_p50_s": sorted(during)[len(during) // 2] if during else None}
        return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", type=int, default=10_000, help="generated cases (default: %(default)s)")
    p.add_argument("--flood-mb", type=int, default=500, help="size of the flood payloads, MB (default: %(default)s)")
    add_run_arguments(p, out="benchmarks/results/bench_acl.json")
    args = p.parse_args(argv)
    if args.cases < 1 or args.flood_mb < 1:
        p.error("--cases and --flood-mb: at least 1")
    prov = main_provenance(__file__, argv)
    gen = generated(args.cases)
    flood = flood_and_list_predict(args.flood_mb)
    result = {"benchmark": "acl", "provenance": prov, "generated": gen, **flood,
              "cases": gen["cases"], "state_changes": gen["state_changes"], "crashes": gen["crashes"]}
    return save_result(result, args.out, headline=("cases", "state_changes", "crashes", "put", "query", "list_predict_57mb"))


if __name__ == "__main__":
    raise SystemExit(main())
