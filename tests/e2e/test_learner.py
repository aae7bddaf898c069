"""The learner as a real process: training over zenoh, bad requests, and kill -9 + restart by the
launcher's supervisor: the skill and its dataset come back intact and an unfinished job resumes and
completes; a running job is cancelled through the client and the command line."""
from __future__ import annotations

import json

import numpy as np
import pytest

from acnmp_core.experiments.viapoint import make_setup
from clients.client import ACNMPClient
from services.launcher import LocalDeployment
from services.model.weights import decode_weights
from services.transport import Keyspace, WireError, call
from tests.e2e import requests
from tests.e2e.requests import adapt_request

NS = "lrn"
KEYS = Keyspace(NS)


def train_request(demos, steps=200):
    return requests.train_request(demos, steps, value_names=("x", "y"))


def latest(session, skill="e1"):
    replies = [r for r in session.get(KEYS.weights_latest(skill), timeout=10)]
    assert len(replies) == 1 and replies[0].ok is not None
    return decode_weights(replies[0].ok.payload.to_bytes())


def test_learner_survives_kill_9_with_skill_dataset_and_job(tmp_path, wait_job):
    setup = make_setup()
    with LocalDeployment(NS, workers=1, model=False, worker_delay=0.25, state_dir=tmp_path) as dep:
        s = dep.session
        rep = call(s, KEYS.train("e1"), train_request(setup.demos), timeout=60)
        assert rep["version"] == 0 and rep["n_demos"] == 6
        before = latest(s)
        assert before.data_hash == setup.demos.content_hash()

        # bad requests: an error code each, and the learner keeps serving
        for key, payload, code in [
            (KEYS.adapt("nope"), adapt_request(setup), "unknown_skill"),
            (KEYS.adapt("e1"), {**adapt_request(setup), "task": "juggle"}, "unknown_task"),
            (KEYS.adapt("e1"), adapt_request(setup, max_rollouts=0), "bad_request"),
            (KEYS.adapt("e1"), adapt_request(setup, warp_speed=9), "bad_request"),
            (KEYS.train("e2"), {**train_request(setup.demos), "times": np.zeros(3)}, "bad_shape"),
            (KEYS.job_status("e1-nothing"), None, "unknown_job"),
        ]:
            with pytest.raises(WireError) as info:
                call(s, key, payload, timeout=10)
            assert info.value.code == code, (key, info.value)

        # a job slow enough (0.25 s per roll-out) to be killed in the middle
        job = call(s, KEYS.adapt("e1"),
                    adapt_request(setup, max_rollouts=9, stop_on_success=False), timeout=10)["job"]
        wait_job(s, KEYS, job, lambda st: st["state"] == "running" and st["rollouts"] >= 3)
        dep.kill("learner")  # SIGKILL: no chance to save anything
        (restart,) = dep.supervisor.wait_restarts("learner", 1, timeout=60)  # the launcher restarts it
        assert restart.exit_code == -9 and restart.pid == dep.children["learner"].pid

        after = latest(s)
        assert (after.version, after.data_hash, after.n_demos) == (0, before.data_hash, 6)
        ref = before.model.predict(setup.target.obs_times, setup.target.obs_values, None, setup.target.query_times)
        got = after.model.predict(setup.target.obs_times, setup.target.obs_values, None, setup.target.query_times)
        np.testing.assert_array_equal(got.mean, ref.mean)
        np.testing.assert_array_equal(got.std, ref.std)

        st = wait_job(s, KEYS, job, lambda st: st["state"] in ("done", "failed"))
        assert st["state"] == "done", st["error"]
        assert st["attempt"] == 1  # restarted once, from the beginning with the same seed
        assert st["result"]["rollouts"] == 9 == st["rollouts"]
        assert st["rollouts_executed"] >= 9 + 3  # the first attempt's roll-outs keep their indices
        assert st["result"]["trajectory"].shape == (len(setup.target.query_times), 2)


def test_a_running_job_is_cancelled_by_the_client_and_the_cli_reports_it(tmp_path, wait_job, run_cli):
    setup = make_setup()
    with LocalDeployment(NS, workers=1, model=False, worker_delay=0.25, state_dir=tmp_path) as dep, \
            ACNMPClient(NS, session=dep.session, timeout=10) as client:
        call(dep.session, KEYS.train("e1"), train_request(setup.demos, steps=50), timeout=60)
        job = call(dep.session, KEYS.adapt("e1"),
                   adapt_request(setup, max_rollouts=200, stop_on_success=False), timeout=10)["job"]
        wait_job(dep.session, KEYS, job, lambda st: st["state"] == "running" and st["rollouts"] >= 1)
        reply = client.cancel(job)
        assert reply["state"] == "running" and reply["cancel_requested"] is True  # stops after this iteration
        st = client.wait_job(job, timeout=60, progress=False)
        assert st["state"] == "cancelled" and st["rollouts"] < 200 and st["result"] is None
        # the shell: a finished job answers its state; an unknown one is a one-line error
        code, out, _ = run_cli("query", "cancel", job, "-n", NS, "--connect", dep.anchor)
        assert code == 0 and out.strip() == f"job {job}: cancelled"
        code, _, err = run_cli("query", "cancel", "e1-nothing", "-n", NS, "--connect", dep.anchor)
        assert code == 1 and len(err.strip().splitlines()) == 1 and err.startswith("acnmp query: unknown_job"), err
    record = json.loads((tmp_path / "jobs" / f"{job}.json").read_text())
    assert record["state"] == "cancelled"
