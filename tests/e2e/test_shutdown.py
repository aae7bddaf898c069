"""Stopping a deployment: the state directory is locked per deployment, and SIGTERM during a job
stops every process without SIGKILL (the learner abandons the batch in flight instead of waiting
for workers), the job is saved as interrupted and resumes on the next start."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import pytest

from acnmp_core.experiments.viapoint import make_setup
from services.launcher import LocalDeployment
from services.transport.state_dir import StateDirInUse
from services.transport import call
from tests.paths import ROOT
from tests.e2e.requests import adapt_request, train_request

NS = "stop"


def test_a_second_deployment_on_the_same_state_dir_refuses_to_start(tmp_path):
    state = tmp_path / "state"
    with LocalDeployment(NS, workers=0, model=False, learner=False, state_dir=state):
        with pytest.raises(StateDirInUse, match="is in use by another deployment"):
            LocalDeployment(f"{NS}2", workers=0, model=False, learner=False, state_dir=state).start()
        env = dict(os.environ, PYTHONPATH=str(ROOT), RERUN_ANALYTICS="0")
        out = subprocess.run([sys.executable, "-m", "clients.cli", "up", "--state-dir", str(state), "--workers", "0"],
                             cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
        assert out.returncode == 1 and "Traceback" not in out.stderr, out.stderr
        assert f"state directory {state.resolve()} is in use" in out.stderr.strip().splitlines()[-1]
        assert "deployment is up" not in out.stdout
    # released with the first deployment: the directory can be used again
    with LocalDeployment(NS, workers=0, model=False, learner=False, state_dir=state):
        pass


@pytest.mark.parametrize("stop", ["learner", "group"])
def test_sigterm_during_a_job_kills_nothing_saves_it_interrupted_and_it_resumes(tmp_path, wait_job, stop):
    """``learner``: SIGTERM to the learner, what `acnmp up` does when it stops; ``group``: SIGTERM to
    the learner's whole process group, its job process included, as a service manager stopping it
    does (the job process leaves the stop to its learner)."""
    setup = make_setup()
    state = tmp_path / "state"
    train = train_request(setup.demos, steps=50, seed=1)
    adapt = adapt_request(setup, max_rollouts=15, stop_on_success=False)
    # workers slow enough (0.25 s per roll-out) that the job is mid-way when the deployment stops
    with LocalDeployment(NS, workers=1, model=False, worker_delay=0.25, state_dir=state, supervise=False) as dep:
        assert call(dep.session, dep.keys.train("e1"), train, timeout=60)["version"] == 0
        job = call(dep.session, dep.keys.adapt("e1"), adapt, timeout=10)["job"]
        wait_job(dep.session, dep.keys, job, lambda st: st["state"] == "running" and st["rollouts"] >= 3)
        if stop == "group":  # the learner leads a session of its own (the launcher starts it so)
            learner = dep.children["learner"].proc
            os.killpg(learner.pid, signal.SIGTERM)
            assert learner.wait(30) == 0
        codes = dep.stop()  # what SIGTERM of `acnmp up` does
        assert dep.killed == [] and all(code == 0 for code in codes.values()), (codes, dep.killed)
    record = json.loads((state / "jobs" / f"{job}.json").read_text())
    assert record["state"] == "interrupted"  # saved as such; not finished, not failed, not left "running"
    with LocalDeployment(NS, workers=1, model=False, state_dir=state) as dep:
        st = wait_job(dep.session, dep.keys, job, lambda st: st["state"] in ("done", "failed"))
    assert st["state"] == "done" and st["attempt"] == 1, st
    assert st["result"]["rollouts"] == 15
