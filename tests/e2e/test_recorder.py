"""The recorder as a real process: it records what is published, survives bad events, and leaves a
valid .rrd on SIGTERM and SIGINT; the replay summary counts exactly the roll-outs published."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from services.recording.events import job_progress_event, latent_event, model_version_event, rollout_event
from services.recording.publisher import EventPublisher
from services.recording.replay import format_summary, summarize
from services.transport import Keyspace, call, encode, free_port, loopback_endpoint, open_session
from tests.paths import ROOT



def _env() -> dict:
    return dict(os.environ, PYTHONPATH=str(ROOT), RERUN="on")


def _publish_job(pub: EventPublisher, job: str, n: int, dims: int, space: str = "cartesian") -> None:
    rng = np.random.default_rng(len(job))
    times = np.linspace(0.0, 1.0, 50)
    for i in range(n):
        traj = np.cumsum(rng.normal(size=(50, dims)), axis=0)
        pub.publish(rollout_event(job, i, traj, times, -np.abs(rng.normal(size=50)), success=i % 3 == 0,
                                  worker=f"w{i % 2}", condition={"times": [0.5], "values": traj[25:26]},
                                  iteration=i // 4, space=space))
        if i % 4 == 3:
            pub.publish(job_progress_event(job, i // 4, i + 1, -1.0 / (i + 1)))
    pub.publish(job_progress_event(job, n // 4, n, -0.1, state="done"))


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_recorder_process_writes_a_valid_rrd(tmp_path, sig, verify_rrd):
    ns = f"rec{sig.value}"
    keys = Keyspace(ns)
    out = tmp_path / "run.rrd"
    port = free_port()
    with open_session("peer", [loopback_endpoint(port)]) as session:
        proc = subprocess.Popen(
            [sys.executable, "-m", "services.recording", "--out", str(out), "--namespace", ns,
             "--connect", loopback_endpoint(port)],
            cwd=ROOT, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        try:
            pub = EventPublisher(session, keys)
            assert pub.wait_for_recorder(timeout=20), "recorder never became live"
            _publish_job(pub, "viapoint-1", 23, dims=2)
            _publish_job(pub, "arm-2", 9, dims=3, space="joint")
            _publish_job(pub, "ur10-3", 5, dims=3)
            for v in range(3):
                pub.publish(model_version_event("viapoint", v, loss=1.0 / (v + 1), n_demos=6))
                pub.publish(latent_event("viapoint", v, np.arange(8.0) * v, label="demo0"))
            # a hostile event: valid msgpack, wrong shape. It must be rejected, not recorded.
            bad = rollout_event("viapoint-1", 99, np.zeros((5, 2)), np.linspace(0, 1, 5), np.zeros(5))
            bad["times"] = np.zeros(4)
            session.put(keys.event("rollout", "viapoint-1"), encode(bad))
            session.put(keys.event("rollout", "viapoint-1"), b"\xc1 not msgpack")

            deadline = time.monotonic() + 20
            while True:  # the status queryable says when everything published has been logged
                status = call(session, keys.recorder_status(), None, timeout=5)
                if status["rollouts"].get("viapoint-1") == 23 and status["rejected"] == 2 \
                        and status["events"].get("latent") == 3:
                    break
                assert time.monotonic() < deadline, status
                time.sleep(0.05)
            assert status["rollouts"] == {"viapoint-1": 23, "arm-2": 9, "ur10-3": 5}

            proc.send_signal(sig)
            rc = proc.wait(timeout=20)  # it exits by itself (how fast is benchmarks' business)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        log = proc.stdout.read()
    assert rc == 0, log
    verify_rrd(out)

    summary = summarize(out)
    assert summary["footer"] is True
    assert {j: s["rollouts"] for j, s in summary["jobs"].items()} == {"viapoint-1": 23, "arm-2": 9, "ur10-3": 5}
    assert all(s["unique_rollouts"] == s["rollouts"] and not s["duplicates"] for s in summary["jobs"].values())
    assert summary["jobs"]["viapoint-1"]["workers"] == {"w0": 12, "w1": 11}
    assert summary["jobs"]["viapoint-1"]["last_progress"]["state"] == "done"
    assert summary["skills"]["viapoint"] == {"versions": [0, 1, 2], "latents": 3}
    text = format_summary(summary)
    assert "viapoint-1: 23 roll-outs" in text and f"rerun {out}" in text
