"""Two learners in one deployment (``learners=2``): each skill is trained, adapted and served by
its owner only (its checkpoints in that learner's state directory); every train, adapt, status
and cancel request reaches its skill's owner through the same keys as with one learner and gets
exactly one reply, the owner's; while the owner is dead, the other learner answers each of them
``unavailable`` naming it (and queues or cancels nothing); the owner killed with SIGKILL resumes
its job on restart while the other's job is untouched; the job list (``ACNMPClient.jobs``, ``acnmp
query jobs``) shows the jobs of both learners, and the model service serves both skills."""
from __future__ import annotations

import json
import time

import zenoh

from acnmp_core.experiments.viapoint import make_setup
from clients.client import ACNMPClient
from services.launcher import LocalDeployment
from services.learner.ownership import owner_of
from services.transport import Keyspace, WireError, call
from services.transport.wire import decode, encode, error_from_payload
from tests.e2e.requests import adapt_request, train_request

NS = "learners2"
KEYS = Keyspace(NS)
IDS = ("learner", "learner-2")
#: Liveness bound only (a test waits on replies and polled states).
WAIT = 300.0


def _skill_owned_by(lid: str) -> str:
    return next(s for s in (f"e1-{i}" for i in range(100)) if owner_of(s, IDS) == lid)


def _replies(session: zenoh.Session, key: str, payload: dict | None = None, timeout: float = 10.0) -> list:
    """Every reply to one query on ``key`` sent to every queryable (none merged): ``(replier's
    zenoh id, decoded message or WireError)``, once each learner answered or dropped it."""
    body = None if payload is None else encode(payload)
    out = []
    for reply in session.get(zenoh.Selector(key), payload=body, timeout=timeout, target=zenoh.QueryTarget.ALL,
                             consolidation=zenoh.ConsolidationMode.NONE):
        who = None if reply.replier_id is None else str(reply.replier_id.zid)
        out.append((who, decode(reply.ok.payload.to_bytes()) if reply.ok is not None
                    else error_from_payload(reply.err.payload.to_bytes())))
    return out


def _learner_sessions(session: zenoh.Session) -> dict[str, str]:
    """{zenoh id of a learner's session: its learner id}, from the job list's replies (each names
    its learner)."""
    return {who: msg["learner"] for who, msg in _replies(session, KEYS.jobs(), {"limit": 1})
            if isinstance(msg, dict)}


def _owners_reply(session: zenoh.Session, learners: dict[str, str], owner: str, key: str,
                  payload: dict | None = None, timeout: float = 10.0):
    """The one reply to a query on ``key``, checked to be the only one and to come from learner
    ``owner``; returns it (a message, or the WireError the owner answered)."""
    replies = _replies(session, key, payload, timeout)
    assert [learners.get(who) for who, _ in replies] == [owner], (key, replies)
    return replies[0][1]


def _unavailable(session: zenoh.Session, learners: dict[str, str], dead: str, key: str,
                 payload: dict | None = None) -> None:
    """A query on ``key`` for a skill of ``dead`` gets one reply, the live learner's ``unavailable``
    naming ``dead``."""
    (live,) = set(learners.values()) - {dead}
    err = _owners_reply(session, learners, live, key, payload)
    assert isinstance(err, WireError) and err.code == "unavailable" and repr(dead) in err.message, err


def test_each_skill_lives_on_its_owner_and_a_killed_owner_resumes_its_job(tmp_path, wait_job, run_cli):
    setup = make_setup()
    skills = {lid: _skill_owned_by(lid) for lid in IDS}
    train = train_request(setup.demos, steps=50)
    adapt = {"learner": adapt_request(setup, max_rollouts=10, max_reuse=3, stop_on_success=False),
             # too long to end by itself in this test: it is still running when its learner is
             # killed, whenever the kill comes, and is cancelled once it has resumed
             "learner-2": adapt_request(setup, max_rollouts=1000, max_reuse=3, stop_on_success=False)}
    # unsupervised: the test restarts learner-2 itself, once it has asked the other while it was dead
    with LocalDeployment(NS, workers=1, worker_delay=0.1, state_dir=tmp_path / "state", learners=2,
                         supervise=False) as dep:
        s = dep.session
        learners = _learner_sessions(s)
        assert sorted(learners.values()) == sorted(IDS), learners
        for lid, skill in skills.items():
            assert _owners_reply(s, learners, lid, KEYS.train(skill), train, timeout=120)["version"] == 0
        for lid, skill in skills.items():  # trained by its owner only
            holders = [other for other in IDS if (dep.learner_state_dir(other) / "skills" / skill).is_dir()]
            assert holders == [lid]
        jobs = {lid: _owners_reply(s, learners, lid, KEYS.adapt(skill), adapt[lid])["job"]
                for lid, skill in skills.items()}
        for lid, job in jobs.items():
            assert _owners_reply(s, learners, lid, KEYS.job_status(job))["job"] == job
        first = wait_job(s, KEYS, jobs["learner-2"], lambda st: st["state"] == "running" and st["rollouts"] >= 5,
                         timeout=WAIT)
        dep.kill("learner-2")

        # its skill and job are answered unavailable by the other learner, once it sees it gone
        def seen_dead() -> bool:
            replies = _replies(s, KEYS.job_status(jobs["learner-2"]))
            return any(isinstance(msg, WireError) and msg.code == "unavailable" for _, msg in replies)

        deadline = time.monotonic() + 60  # liveness bound only
        while not seen_dead():
            assert time.monotonic() < deadline, "learner never saw learner-2's token go"
            time.sleep(0.1)
        for key, payload in ((KEYS.job_status(jobs["learner-2"]), None), (KEYS.job_cancel(jobs["learner-2"]), None),
                             (KEYS.adapt(skills["learner-2"]), adapt["learner"]),
                             (KEYS.train(skills["learner-2"]), train)):
            _unavailable(s, learners, "learner-2", key, payload)
        assert _owners_reply(s, learners, "learner", KEYS.job_status(jobs["learner"]))["job"] == jobs["learner"]

        dep.respawn("learner-2")
        learners = _learner_sessions(s)  # the restarted learner has a new session
        assert sorted(learners.values()) == sorted(IDS), learners
        resumed = wait_job(s, KEYS, jobs["learner-2"], lambda st: st["attempt"] == 1 and st["state"] == "running"
                           and st["rollouts_executed"] > first["rollouts_executed"], timeout=WAIT)
        assert not resumed["cancel_requested"]  # the cancel sent while it was dead did not reach it
        assert _owners_reply(s, learners, "learner-2", KEYS.job_cancel(jobs["learner-2"]))["cancel_requested"]
        final = {lid: wait_job(s, KEYS, job, lambda st: st["state"] in ("done", "failed", "cancelled"), timeout=WAIT)
                 for lid, job in jobs.items()}
        assert final["learner-2"]["state"] == "cancelled" and final["learner-2"]["attempt"] == 1
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
