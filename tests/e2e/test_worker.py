"""Workers as real processes: bad input gets an error code and the worker keeps serving; a batch
spread over two workers completes on the survivor when one is kill -9'd mid-batch, in order and
with every roll-out executed once; ``acnmp serve worker`` runs a worker."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from acnmp_core.experiments.viapoint import make_setup
from services.launcher import LocalDeployment
from services.transport import Keyspace, WireError, call, encode, free_port, loopback_endpoint, open_session
from services.transport import wait_for_liveliness
from services.worker.core import rollout_request
from services.worker.remote import RemoteEvaluator
from tests.paths import ROOT



@pytest.fixture(scope="module")
def setup():
    return make_setup()


def _request(setup, trajs, **over):
    return {**rollout_request("viapoint", setup.task_config, trajs, setup.target.query_times), **over}


def test_worker_rejects_bad_input_and_keeps_serving(tmp_path, setup):
    with LocalDeployment("wbad", workers=1, model=False, learner=False, state_dir=tmp_path) as dep:
        key = dep.keys.worker_rollout("point2d", "point2d-0")
        t = setup.target.query_times
        good = np.random.default_rng(0).normal(size=(3, len(t), 2))
        cases = {
            "malformed": b"\xc1 not msgpack",
            "bad_version": {"v": 7, "task": "viapoint"},
            "unknown_task": _request(setup, good, task="push"),
            "bad_shape": _request(setup, good, times=t[:-1]),
            "non_finite": None,  # filled below: NaN in the trajectories
            "bad_request": _request(setup, good, task_config={"t_v": 0.5}),  # missing point/tolerance
        }
        nan = good.copy()
        nan[0, 3, 1] = np.nan
        for code, payload in cases.items():
            if code == "non_finite":
                payload = encode(_request(setup, nan), allow_non_finite=True)
            with pytest.raises(WireError) as info:
                call(dep.session, key, payload, timeout=10)
            assert info.value.code == code, (code, info.value)
        # a 2-D trajectory for a 3-D via-point: the task's own validation, reported as bad_request
        with pytest.raises(WireError) as info:
            call(dep.session, key, _request(setup, good[..., :1]), timeout=10)
        assert info.value.code == "bad_request"
        # ... and the worker still serves, with the same numbers as in-process evaluation
        reply = call(dep.session, key, _request(setup, good), timeout=10)
        ref = setup.task.evaluate(good, t)
        np.testing.assert_allclose(reply["rewards"], ref.rewards)
        np.testing.assert_array_equal(reply["success"], ref.success)
        assert reply["worker"] == "point2d-0"
        assert dep.children["worker-point2d-0"].proc.poll() is None


def test_batch_survives_a_worker_killed_mid_batch(tmp_path, setup):
    t = setup.target.query_times
    trajs = np.random.default_rng(1).normal(scale=0.3, size=(8, len(t), 2))
    # supervise=False: this is the evaluator's fail-over alone, the killed worker stays dead
    with LocalDeployment("wkill", workers=2, model=False, learner=False, worker_delay=0.4,
                         state_dir=tmp_path, supervise=False) as dep:
        ev = RemoteEvaluator(dep.session, dep.keys, "point2d", "viapoint", setup.task_config, timeout=30)
        assert ev.workers() == ["point2d-0", "point2d-1"]
        out = {}
        thread = threading.Thread(target=lambda: out.update(batch=ev.evaluate(trajs, t)))
        thread.start()
        time.sleep(0.6)  # both chunks of 4 roll-outs (1.6 s each) are in flight
        dep.kill("worker-point2d-0")
        thread.join(timeout=30)
        assert not thread.is_alive()
    batch = out["batch"]
    ref = setup.task.evaluate(trajs, t)
    assert len(batch) == 8
    np.testing.assert_allclose(batch.rewards, ref.rewards)  # in order: roll-out i is trajectory i
    np.testing.assert_allclose(batch.states["path"], trajs)
    # the killed worker's chunk ran on the survivor; nothing ran twice into the result
    assert batch.workers == ("point2d-1",) * 8


def test_remote_evaluator_rejects_a_bad_request_without_retrying(tmp_path, setup):
    with LocalDeployment("wval", workers=1, model=False, learner=False, state_dir=tmp_path) as dep:
        ev = RemoteEvaluator(dep.session, dep.keys, "point2d", "push", {})
        with pytest.raises(ValueError, match="unknown_task"):
            ev.evaluate(np.zeros((2, 5, 2)), np.linspace(0, 1, 5))
        nobody = RemoteEvaluator(dep.session, dep.keys, "planar3", "push", {}, discover_timeout=0.5)
        with pytest.raises(RuntimeError, match="no live planar3 worker"):
            nobody.evaluate(np.zeros((2, 5, 3)), np.linspace(0, 1, 5))


def test_acnmp_serve_worker_runs_a_worker_until_sigterm(setup):
    """The command line reaches the worker process: it goes live under its id, executes a roll-out
    exactly as in-process evaluation does, and exits 0 on SIGTERM."""
    ns, port = "wserve", free_port()
    keys = Keyspace(ns)
    t = setup.target.query_times
    trajs = np.random.default_rng(2).normal(size=(2, len(t), 2))
    with open_session("peer", [loopback_endpoint(port)]) as session:
        proc = subprocess.Popen([sys.executable, "-m", "clients.cli", "serve", "worker", "--robot", "point2d",
                                 "--id", "cli-w", "--namespace", ns, "--connect", loopback_endpoint(port)],
                                cwd=ROOT, env=dict(os.environ, PYTHONPATH=str(ROOT)), stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True)
        try:
            assert wait_for_liveliness(session, keys.worker_token("point2d", "cli-w"), timeout=60)
            reply = call(session, keys.worker_rollout("point2d", "cli-w"), _request(setup, trajs), timeout=30)
            proc.send_signal(signal.SIGTERM)
            rc = proc.wait(timeout=30)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        out = proc.stdout.read()
    assert reply["worker"] == "cli-w"
    np.testing.assert_array_equal(reply["rewards"], setup.task.evaluate(trajs, t).rewards)
    assert rc == 0, out
    assert "worker live as acnmp/wserve/worker/point2d/cli-w" in out


def test_small_batches_take_turns_over_the_workers(tmp_path, setup):
    """Batches smaller than the pool rotate over it: no worker is left idle while one takes all."""
    t = setup.target.query_times
    with LocalDeployment("wturn", workers=3, model=False, learner=False, state_dir=tmp_path) as dep:
        ev = RemoteEvaluator(dep.session, dep.keys, "point2d", "viapoint", setup.task_config, timeout=30)
        used = [w for _ in range(6) for w in ev.evaluate(np.zeros((1, len(t), 2)), t).workers]
    assert sorted(used) == sorted(["point2d-0", "point2d-1", "point2d-2"] * 2)
