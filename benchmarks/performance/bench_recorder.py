"""How many roll-out events one recorder process writes per second (the deployment's one writer).

A LocalDeployment with only a recorder; this process publishes ``--events`` rollout events of a
given size as fast as the bus takes them (CongestionControl.BLOCK, as the learner does) and polls
the recorder's status until every one is logged. Two shapes: a point robot's roll-out (E1: T=101,
D=2, with its condition points) and a planar arm's (E2: T=300, 3 joints, the arm and the object
drawn per step).

    python benchmarks/performance/bench_recorder.py [--events 300] [--out benchmarks/results/bench_recorder.json]
"""
from __future__ import annotations

import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from acnmp_core.robots.registry import robot  # noqa: E402
from benchmarks._results import benchmark_args  # noqa: E402
from clients.experiments.common import write_json  # noqa: E402
from services.launcher import LocalDeployment  # noqa: E402
from services.recording.events import rollout_event  # noqa: E402
from services.recording.publisher import EventPublisher  # noqa: E402
from services.transport import call, encode  # noqa: E402


def _events(kind: str, n: int, job: str) -> list[dict]:
    rng = np.random.default_rng(0)
    out = []
    for i in range(n):
        if kind == "point2d":
            t = np.linspace(0, 1, 101)
            traj = np.cumsum(rng.normal(size=(101, 2)), axis=0)
            ev = rollout_event(job, i, traj, t, -np.abs(rng.normal(size=101)), worker="w0",
                               condition={"times": [0.25], "values": traj[25:26]})
        else:
            t = np.linspace(0, 1, 300)
            q = np.cumsum(rng.normal(0, 0.01, size=(300, 3)), axis=0) + np.array([-0.8, 1.2, -1.0])
            ev = rollout_event(job, i, q, t, np.zeros(300), worker="w0", space="joint", task_params=[0.4, 0.1])
            drawing = robot("planar3").drawing
            ev.update(drawing.event_fields(), drawing=drawing.kind, joint_angles=q,
                      object_xy=np.stack([np.linspace(0.35, 0.42, 300), np.zeros(300)], axis=1))
        out.append(ev)
    return out


def measure(dep: LocalDeployment, kind: str, n: int) -> dict:
    """Publish ``n`` events of ``kind`` and wait until the recorder has logged them all."""
    job = f"bench-{kind}"
    events = _events(kind, n, job)
    size = len(encode(events[0]))
    pub = EventPublisher(dep.session, dep.keys)
    t0 = time.perf_counter()
    for ev in events:
        pub.publish(ev)
    published = time.perf_counter() - t0
    while call(dep.session, dep.keys.recorder_status(), None, timeout=10)["rollouts"].get(job, 0) < n:
        time.sleep(0.01)
    total = time.perf_counter() - t0
    return {"kind": kind, "events": n, "bytes_per_event": size, "publish_s": round(published, 3),
            "recorded_s": round(total, 3), "events_per_s": round(n / total, 1),
            "mb_per_s": round(n * size / total / 1e6, 2)}


def main(argv: list[str] | None = None) -> int:
    args = benchmark_args(__doc__, "bench_recorder", argv, events=(300, "events per shape"))
    os.environ.setdefault("RERUN_ANALYTICS", "0")
    with tempfile.TemporaryDirectory(prefix="bench-rec-") as tmp:
        with LocalDeployment(f"benchrec-{os.getpid()}", workers=0, model=False, learner=False,
                             record=Path(tmp) / "bench.rrd", state_dir=tmp) as dep:
            rows = [measure(dep, kind, args.events) for kind in ("point2d", "planar3")]
    for r in rows:
        print(r)
    write_json({"benchmark": "recorder", "results": rows,
                "machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                            "note": "shared machine; numbers from one run"}}, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
