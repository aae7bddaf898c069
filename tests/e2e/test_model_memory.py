"""The model service gives back what large payloads cost it (issue 66: after predicts of 57-60 MB
it held 1.6 GB when idle again, 6.6x its start).

The mechanism, in a child process of its own (RSS is per process): three threads decode payloads
of 1-8 MiB as the service does; with :func:`services.transport.heap.map_large_blocks` and
:func:`~services.transport.heap.trim` the resident set is back near its start, without them it
holds several times that. And the service itself: a large predict makes its trimmer trim.
benchmarks/performance/bench_model_memory.py measures the deployment's model process under 100
predicts at the bound from 4 senders. And refusals: 100 large predicts refused ``too_large`` and
100 refused ``malformed`` leave the service process within 1.5x of its idle memory (issue 73)."""
from __future__ import annotations

import os
import subprocess
import sys
import time

import msgpack
import numpy as np

from clients.client import ACNMPClient, ClientError
from services.model.handlers import SkillModel
from services.model.service import ModelService
from services.transport import Keyspace, encode, free_port, loopback_endpoint, open_session
from services.transport.payload_limits import request_limit
from tests.paths import ROOT

DECODE_FLOOD = r"""
import sys, threading, numpy as np
from services.transport.heap import map_large_blocks, trim
from services.transport.wire import decode, encode
fixed = sys.argv[1] == "1"
if fixed:
    map_large_blocks()
def rss():
    return next(int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmRSS:")) / 1024
base = {"v": 1, "obs_times": np.array([0.0, 1.0]), "obs_values": np.zeros((2, 2)), "n_steps": 20}
start = rss()
def work(seed):
    rng = np.random.default_rng(seed)
    for _ in range(8):
        n = int(rng.integers(1, 9)) << 20
        body = encode({**base, "pad": bytes(n), "x": rng.standard_normal(n // 64)})
        msg, copies = decode(body), [bytes(body[: n // 3]) for _ in range(2)]
        del msg, body, copies
threads = [threading.Thread(target=work, args=(seed,)) for seed in range(3)]
[t.start() for t in threads]
[t.join() for t in threads]
if fixed:
    trim()
print(rss() / start)
"""


def _held(fixed: bool) -> float:
    out = subprocess.run([sys.executable, "-c", DECODE_FLOOD, "1" if fixed else "0"], cwd=ROOT, capture_output=True,
                         text=True, timeout=120, check=True)
    return float(out.stdout.strip())


def test_decoded_payloads_are_given_back_to_the_system_once_freed():
    assert _held(fixed=True) < 1.5
    assert _held(fixed=False) > 2  # glibc's defaults keep them: what the service did before


def test_a_large_predict_makes_the_model_service_trim(small_model):
    ep = loopback_endpoint(free_port())
    with open_session("peer", [ep]) as server, ACNMPClient("memtest", connect=[ep], timeout=10.0) as client, \
            ModelService(server, "memtest", fetch_latest=False) as service:
        service.load(SkillModel("reach", 1, small_model))
        request = {"v": 1, "obs_times": np.array([0.0, 1.0]), "obs_values": np.zeros((2, 2)), "n_steps": 5}
        body = encode({**request, "pad": bytes(request_limit("acnmp/memtest/skill/reach/predict") - 1024)})
        deadline = time.monotonic() + 10
        while True:  # the client's session may not know the queryable yet
            try:
                assert client.request("acnmp/memtest/skill/reach/predict", body)["mean"].shape == (5, 2)
                break
            except ClientError as exc:
                if exc.code not in ("unavailable", "unknown_skill") or time.monotonic() > deadline:
                    raise
                time.sleep(0.05)
        deadline = time.monotonic() + 10  # liveness bound: it trims within a second
        while service.trimmer.trims == 0:
            assert time.monotonic() < deadline, "no trim after a 16 MiB predict"
            time.sleep(0.05)


def _rss_mib(pid: int) -> float:
    with open(f"/proc/{pid}/status") as status:
        return next(int(line.split()[1]) for line in status if line.startswith("VmRSS:")) / 1024


def test_refused_large_predicts_leave_no_memory_behind():
    """Issue 73, defect 2: 100 predicts just under the key's bound refused ``too_large`` (a list of
    1.86 M floats) and 100 refused ``malformed`` (16 MiB that is not msgpack) held 2.5-2.8x the
    model service's idle memory for good: each refusal's traceback, kept in a cycle through the
    batcher's failed future, held its payload. The service, a process of its own, is back within
    1.5x of idle within 10 s of each flood (its resident set polled, the 10 s a deadline)."""
    ep, ns = loopback_endpoint(free_port()), "memrefused"
    key = Keyspace(ns).predict("e1")
    bound = request_limit(key)
    too_large = msgpack.packb({"v": 1, "obs_times": [0.5] * ((bound - 64) // 9)})
    malformed = bytes([0xC1]) * (bound - 16)  # 0xc1 is no msgpack type
    assert len(too_large) <= bound and len(malformed) <= bound
    proc = subprocess.Popen([sys.executable, "-m", "services.model", "--namespace", ns, "--listen", ep], cwd=ROOT,
                            env=dict(os.environ, PYTHONPATH=str(ROOT), RERUN_ANALYTICS="0"),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        with ACNMPClient(ns, connect=[ep], timeout=30.0) as client:
            deadline = time.monotonic() + 60
            while True:  # live once it answers (no skill: unknown_skill)
                try:
                    client.request(Keyspace(ns).info("e1"), None)
                except ClientError as exc:
                    if exc.code != "unavailable":
                        break
                assert time.monotonic() < deadline and proc.poll() is None, "the model service did not start"
                time.sleep(0.1)
            idle = _rss_mib(proc.pid)
            for code, body in (("too_large", too_large), ("malformed", malformed)):
                answers = []
                for _ in range(100):
                    try:
                        client.request(key, body)
                        answers.append("ok")
                    except ClientError as exc:
                        answers.append(exc.code)
                assert answers == [code] * 100, sorted(set(answers))
                deadline = time.monotonic() + 10  # liveness bound: freed memory goes back within a moment
                while (now := _rss_mib(proc.pid)) > 1.5 * idle:
                    assert time.monotonic() < deadline, f"{code}: {now:.0f} MiB 10 s after the refusals, idle {idle:.0f}"
                    time.sleep(0.1)
    finally:
        proc.terminate()
        proc.wait(30)
