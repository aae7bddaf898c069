"""What spreading the deployment over hosts costs: predict latency and throughput, and E1's time.

Two layouts of the same secured deployment (services/launcher/multihost.py: TLS, a password per
role, the ACL; router, recorder, learner, model service, two point-mass workers), one after the
other in one run:

* ``hosts``: every process on a network namespace of its own, joined to the router's by veth links
  (the client on a seventh); every message crosses two links (client -> router -> model);
* ``loopback``: the same processes, configs and certificates, all in the router's namespace: the
  same path through the router, over that namespace's loopback.

In each: E1 run from the client host (``acnmp experiment viapoint --distributed --namespace
--config``, ``--train-steps`` and ``--budget``), its own ``wall_time_s`` and the command's time;
then, on the skill E1 trained, ``--n`` predicts one at a time (p50, p99 in ms) and the predicts per
second of 1, 4 and 16 concurrent clients (threads of one process, a session each, ``--duration`` s
each) from the client host. The layouts alternate ``--reps`` times each (the machine is shared:
one run of each is noise); reported: every run, the medians per layout, the ratio of the medians
hosts / loopback and the ratio per repetition.

    python benchmarks/performance/bench_hosts.py [--n 300] [--out benchmarks/results/bench_hosts.json]

Needs root (network namespaces). ``--probe`` is the client-side part, run inside the client host.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks._results import provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402
from benchmarks.performance.bench_predict import run_clients  # noqa: E402

SKILL = "e1"


def probe(args) -> dict:
    """The client's measurements (run inside the client host): latency of ``args.n`` predicts one
    at a time after ``args.warmup``, then throughput per number of clients."""
    from acnmp_core.experiments.viapoint import make_setup
    from clients.client import ACNMPClient

    target = make_setup().target
    obs_t, obs_v, query = target.obs_times, target.obs_values, target.query_times

    def predict(client):
        client.predict(SKILL, obs_t, obs_v, None, query)

    with ACNMPClient(args.namespace, config_file=args.config, role="client", timeout=30) as client:
        for _ in range(args.warmup):
            predict(client)
        times = []
        for _ in range(args.n):
            t0 = time.perf_counter()
            predict(client)
            times.append(time.perf_counter() - t0)
    ms = np.array(times) * 1e3
    out = {"latency": {"p50_ms": float(np.percentile(ms, 50)), "p99_ms": float(np.percentile(ms, 99)), "n": args.n},
           "throughput": []}
    for n_clients in args.clients:
        ran = run_clients(n_clients, args.duration,
                          lambda: ACNMPClient(args.namespace, config_file=args.config, role="client", timeout=30), predict)
        out["throughput"].append({"clients": n_clients, "predicts": ran["ops"], "errors": ran["errors"],
                                  "predicts_per_s": ran["ops"] / ran["seconds"]})
    return out


def measure_layout(layout: str, args, work: Path) -> dict:
    """E1 and the probe on one layout (``hosts`` or ``loopback``); returns their numbers."""
    from services.launcher.multihost import MultiHostDeployment

    with MultiHostDeployment(f"bench-{layout}", workers=2, one_host=layout == "loopback",
                             work_dir=work / layout) as dep:
        e1_json = work / f"{layout}_e1.json"
        t0 = time.perf_counter()
        e1 = dep.acnmp("experiment", "viapoint", "--seeds", f"{args.seed}-{args.seed}", "--budget", str(args.budget),
                       "--train-steps", str(args.train_steps), "--quiet", "--distributed", "--json", str(e1_json),
                       timeout=3600)
        command_s = time.perf_counter() - t0
        if e1.returncode != 0:
            raise RuntimeError(f"E1 on {layout}: {e1.stderr or e1.stdout}")
        summary = json.loads(e1_json.read_text())
        probe_argv = [sys.executable, str(Path(__file__).resolve()), "--probe", "--namespace", dep.namespace,
                      "--config", str(dep.config("client")), "--n", str(args.n), "--warmup", str(args.warmup),
                      "--duration", str(args.duration), "--clients", ",".join(map(str, args.clients))]
        p = dep.popen(probe_argv, stdout=__import__("subprocess").PIPE, text=True)
        out, _ = p.communicate(timeout=3600)
        if p.returncode != 0:
            raise RuntimeError(f"the probe on {layout} exited {p.returncode}")
        measured = json.loads(out.strip().splitlines()[-1])
    return {"e1": {"wall_time_s": summary["wall_time_s"], "command_s": command_s,
                   "rollouts": {m: r["rollouts"] for m, r in summary["methods"].items()},
                   "success": {m: r["success"] for m, r in summary["methods"].items()}},
            **measured}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=300, help="predicts one at a time (default %(default)s)")
    parser.add_argument("--warmup", type=int, default=20, help="predicts sent and not timed first (default 20)")
    parser.add_argument("--duration", type=float, default=3.0, help="seconds per throughput point")
    parser.add_argument("--clients", type=lambda s: [int(x) for x in s.split(",")], default=[1, 4, 16], metavar="N,..",
                        help="comma-separated counts of concurrent clients, one measurement each (default 1,4,16)")
    parser.add_argument("--reps", type=int, default=3, help="runs of each layout, alternating (default %(default)s)")
    parser.add_argument("--seed", type=int, default=0, help="E1's seed")
    parser.add_argument("--train-steps", type=int, default=3000, help="E1's training steps (default 3000)")
    parser.add_argument("--budget", type=int, default=100, help="E1's roll-out budget per method (default 100)")
    add_run_arguments(parser, out="benchmarks/results/bench_hosts.json")
    parser.add_argument("--probe", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--namespace", help=argparse.SUPPRESS)
    parser.add_argument("--config", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.probe:
        print(json.dumps(probe(args)), flush=True)
        return 0
    import tempfile

    from services.launcher.netns import unavailable_reason

    why = unavailable_reason()
    if why is not None:
        print(f"bench_hosts: {why}", file=sys.stderr)
        return 1
    result = {"provenance": provenance(sys.argv), "config": {k: v for k, v in vars(args).items()
                                                             if k not in ("probe", "namespace", "config")}}
    runs: dict[str, list[dict]] = {"loopback": [], "hosts": []}
    with tempfile.TemporaryDirectory(prefix="bench-hosts-") as tmp:
        for rep in range(args.reps):  # alternating, so both layouts meet the machine's moods alike
            for layout in (("loopback", "hosts") if rep % 2 == 0 else ("hosts", "loopback")):
                runs[layout].append(measure_layout(layout, args, Path(tmp) / f"rep{rep}"))
                print(rep, layout, json.dumps(runs[layout][-1]), flush=True)

    def median(layout: str, get) -> float:
        return float(np.median([get(r) for r in runs[layout]]))

    metrics = {"predict_p50_ms": lambda r: r["latency"]["p50_ms"], "predict_p99_ms": lambda r: r["latency"]["p99_ms"],
               **{f"predicts_per_s_{n}_clients": (lambda r, i=i: r["throughput"][i]["predicts_per_s"])
                  for i, n in enumerate(args.clients)},
               "e1_wall_time_s": lambda r: r["e1"]["wall_time_s"], "e1_command_s": lambda r: r["e1"]["command_s"]}
    for layout in runs:
        result[layout] = {"runs": runs[layout], "median": {k: median(layout, f) for k, f in metrics.items()}}
    lo, hi = result["loopback"]["median"], result["hosts"]["median"]
    result["ratios_hosts_over_loopback"] = {k: hi[k] / lo[k] for k in metrics}
    result["ratios_per_rep"] = {k: [f(h) / f(l) for h, l in zip(runs["hosts"], runs["loopback"])] for k, f in metrics.items()}
    result["e1_same_counts"] = all(r["e1"]["rollouts"] == runs["loopback"][0]["e1"]["rollouts"]
                                   and r["e1"]["success"] == runs["loopback"][0]["e1"]["success"]
                                   for layout in runs for r in runs[layout])
    return save_result(result, args.out, headline=("ratios_hosts_over_loopback", "e1_same_counts"))


if __name__ == "__main__":
    sys.exit(main())
