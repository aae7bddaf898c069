"""Two learners in one deployment (``learners=2``): each skill is trained, adapted and served by
its owner only (its checkpoints in that learner's state directory), a job reaches its skill's
owner through the same keys as with one learner, the owner killed with SIGKILL resumes its job on
restart while the other's job is untouched, the job list (``ACNMPClient.jobs``, ``acnmp query
jobs``) shows the jobs of both learners, and the model service serves both skills."""
from __future__ import annotations

import json

from acnmp_core.experiments.viapoint import make_setup
from clients.client import ACNMPClient
from services.launcher import LocalDeployment
from services.learner.ownership import owner_of
from services.transport import Keyspace, call
from tests.e2e.requests import adapt_request, train_request

NS = "learners2"
KEYS = Keyspace(NS)
IDS = ("learner", "learner-2")


def _skill_owned_by(lid: str) -> str:
    return next(s for s in (f"e1-{i}" for i in range(100)) if owner_of(s, IDS) == lid)


def test_each_skill_lives_on_its_owner_and_a_killed_owner_resumes_its_job(tmp_path, wait_job, run_cli):
    setup = make_setup()
    skills = {lid: _skill_owned_by(lid) for lid in IDS}
    train = train_request(setup.demos, steps=50)
    adapt = adapt_request(setup, max_rollouts=10, max_reuse=3, stop_on_success=False)
    with LocalDeployment(NS, workers=1, worker_delay=0.1, state_dir=tmp_path / "state", learners=2) as dep:
        s = dep.session
        for lid, skill in skills.items():
            assert call(s, KEYS.train(skill), train, timeout=120)["version"] == 0
        for lid, skill in skills.items():  # trained by its owner only
            holders = [other for other in IDS if (dep.learner_state_dir(other) / "skills" / skill).is_dir()]
            assert holders == [lid]
        jobs = {lid: call(s, KEYS.adapt(skill), adapt, timeout=10)["job"] for lid, skill in skills.items()}
        wait_job(s, KEYS, jobs["learner-2"], lambda st: st["state"] == "running" and st["rollouts"] >= 5, timeout=300)
        dep.kill("learner-2")
        dep.supervisor.wait_restarts("learner-2", 1, timeout=120)
        final = {lid: wait_job(s, KEYS, job, lambda st: st["state"] in ("done", "failed"), timeout=300)
                 for lid, job in jobs.items()}
        assert final["learner-2"]["state"] == "done" and final["learner-2"]["attempt"] == 1
        assert final["learner"]["state"] == "done" and final["learner"]["attempt"] == 0
        # every learner's jobs are listed, newest first, by the client and by the shell
        with ACNMPClient(NS, session=s, timeout=10) as client:
            rows = client.jobs()
        assert sorted(r.job for r in rows) == sorted(jobs.values())
        assert [r.created for r in rows] == sorted((r.created for r in rows), reverse=True)
        code, out, err = run_cli("query", "jobs", "--json", "-n", NS, "--connect", dep.anchor)
        assert code == 0, err
        assert sorted(r["job"] for r in json.loads(out)) == sorted(jobs.values())
        # the model service serves the latest version of both skills
        for skill in skills.values():
            info = call(s, KEYS.info(skill), None, timeout=30)
            assert info["version"] == 0, info
