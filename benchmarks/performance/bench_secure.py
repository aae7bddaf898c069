"""What authentication and access control cost a query (issue 12, authenticated deployments).

Two deployments side by side in one run, each with a model service serving one small skill:
``mesh`` (``LocalDeployment()``, the unauthenticated peer mesh) and ``secure``
(``LocalDeployment(secure=True)``, what ``acnmp up`` starts: every process a client of the
authenticated router with the ACL). A client of each (a mesh peer; the ``client`` role through the
router) sends ``--n`` info queries and ``--n`` small predicts, one at a time. Reported: p50/p99 in
ms of each and the ratio secure/mesh; then ``empty_query``: an empty query between two sessions of
this process, peer to peer and through a router plain / with user/password / with the ACL too.
Numbers from one run on a shared machine.

    python benchmarks/performance/bench_secure.py [--n 300] [--out benchmarks/results/bench_secure.json]
"""
from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks._results import benchmark_args, provenance, save_result  # noqa: E402

SMALL = {"encoder_widths": [32, 32], "decoder_widths": [32, 32]}


def _measure(client, n: int) -> dict:
    """p50/p99 (ms) of ``n`` info and ``n`` predict queries on skill ``s``, one at a time."""
    out = {}
    for name, ask in (("info", lambda: client.info("s")),
                      ("predict", lambda: client.predict("s", [0.0], [[0.0, 0.0]], n_steps=50))):
        ask()  # warm-up
        times = []
        for _ in range(n):
            t = time.perf_counter()
            ask()
            times.append((time.perf_counter() - t) * 1e3)
        out[name] = {"p50_ms": float(np.percentile(times, 50)), "p99_ms": float(np.percentile(times, 99))}
    return out


def _empty_query_rtt(n: int) -> dict:
    """p50 (ms) of an empty query between two sessions of this process: peer to peer, and client
    to client through a router plain, with user/password, and with user/password and the ACL
    (which of the three costs what)."""
    import json
    import zenoh

    from services.transport import free_port, loopback_endpoint, make_config, open_session
    from services.transport.auth import DeploymentSecrets, client_config

    out = {}
    tmp = Path(tempfile.mkdtemp(prefix="acnmp-bench-secure-"))
    for layout in ("peer", "router", "router+auth", "router+auth+acl"):
        anchor = loopback_endpoint(free_port())
        secrets = DeploymentSecrets(tmp / layout).create(anchor)
        if layout == "peer":
            anchor_cfg = make_config("peer", [anchor], [])
            ends = [make_config("peer", None, [anchor]) for _ in range(2)]
        else:
            anchor_cfg = secrets.router_config([anchor]) if "auth" in layout else make_config("router", [anchor], [])
            if layout == "router+auth":
                anchor_cfg.insert_json5("access_control/enabled", "false")
            ends = []
            for role in ("model", "client"):
                cfg = zenoh.Config()
                settings = client_config(anchor, secrets.credentials[role])
                if "auth" not in layout:
                    del settings["transport"]
                for key, value in settings.items():
                    cfg.insert_json5(key, json.dumps(value))
                ends.append(cfg)
        with open_session(config=anchor_cfg), open_session(config=ends[0]) as server, \
                open_session(config=ends[1]) as client:
            q = server.declare_queryable("acnmp/b/skill/s/info", lambda query: query.reply(query.key_expr, b""))
            times = []
            for i in range(n + 20):
                t = time.perf_counter()
                replies = list(client.get("acnmp/b/skill/s/info", timeout=5))
                if i >= 20 and replies:  # the first ones while routes settle
                    times.append((time.perf_counter() - t) * 1e3)
            q.undeclare()
        out[layout] = {"p50_ms": float(np.percentile(times, 50)), "p99_ms": float(np.percentile(times, 99)),
                       "answered": len(times)}
    return out


def main() -> int:
    args = benchmark_args(__doc__, "bench_secure", None, n=(300, "info queries and small predicts per deployment, one at a time"))
    prov = provenance()
    os.environ.setdefault("ACNMP_RUNTIME_DIR", tempfile.mkdtemp(prefix="acnmp-bench-run-"))
    from acnmp_core.tasks.viapoint.task import obstacle_demos
    from clients.client import ACNMPClient
    from services.launcher import LocalDeployment

    demos = obstacle_demos()
    result: dict = {"provenance": prov, "n": args.n}
    for layout, secure in (("mesh", False), ("secure", True)):
        with LocalDeployment(f"bench-{layout}", workers=0, secure=secure) as dep:
            connect = {} if secure else {"connect": [dep.anchor]}
            with ACNMPClient(f"bench-{layout}", role="operator", timeout=60, **connect) as op:
                op.train("s", demos[0].times, np.stack([d.values for d in demos]), model=SMALL,
                         train={"steps": 20}, timeout=120)
                while True:  # the model service has the weights
                    try:
                        op.info("s")
                        break
                    except Exception:
                        time.sleep(0.1)
            with ACNMPClient(f"bench-{layout}", role="client", timeout=30, **connect) as client:
                result[layout] = _measure(client, args.n)
    result["empty_query"] = _empty_query_rtt(args.n)
    result["ratio_secure_over_mesh"] = {k: result["secure"][k]["p50_ms"] / result["mesh"][k]["p50_ms"]
                                        for k in ("info", "predict")}
    result["headline"] = (f"p50 info {result['mesh']['info']['p50_ms']:.2f} ms mesh, "
                          f"{result['secure']['info']['p50_ms']:.2f} ms secure "
                          f"({result['ratio_secure_over_mesh']['info']:.2f}x); predict "
                          f"{result['ratio_secure_over_mesh']['predict']:.2f}x")
    return save_result(result, args.out)


if __name__ == "__main__":
    sys.exit(main())
