"""Issue 31's probes, repeated as tests: holding one role's password of an authenticated deployment
(client, worker, operator), wildcard key expressions and keys outside the role's grants change
nothing and stall nothing (services/transport/acl.py, docs/SECURITY.md)."""
from __future__ import annotations

import time

import numpy as np
import pytest

from acnmp_core.experiments.viapoint import make_setup
from benchmarks.performance.hostile_acl import acl_deployment
from benchmarks.performance.hostile_inputs import SMALL, valid_requests
from services.model.weights import encode_weights
from services.recording.events import rollout_event
from services.transport import call, encode, open_session

FORGED_VERSION = 2**62
ROLES = ("client", "worker", "operator")


@pytest.fixture(scope="module")
def dep(tmp_path_factory):
    """An authenticated deployment (router + learner + model + one point2d worker + recorder) with
    skill ``e1`` trained (version 0) and served; its router session is the test's trusted side."""
    with acl_deployment(tmp_path_factory.mktemp("aclp")) as d:
        yield d


def _session(dep, role: str):
    return open_session(None, config_file=dep.announcement.secrets.config_path(role))


def _wildcards(dep, *tail: str) -> list[str]:
    ns = dep.keys.prefix
    return [f"{ns}/**", "acnmp/**", *(f"{ns}/{t}" for t in tail)]


def _forged_weights(dep) -> bytes:
    from acnmp_core import CNMP, CNMPConfig, TrainConfig, train

    model = CNMP(CNMPConfig(n_outputs=2, **SMALL), seed=9)
    train(model, make_setup().demos, TrainConfig(steps=1), seed=9)
    return encode_weights("e1", FORGED_VERSION, model, data_hash="forged", n_demos=1)


def _job_done(dep, job: str, timeout: float = 90.0) -> dict:
    end = time.monotonic() + timeout
    while True:
        status = call(dep.session, dep.keys.job_status(job), None, timeout=10)
        if status["state"] in ("done", "failed", "cancelled") or time.monotonic() > end:
            return status
        time.sleep(0.2)


def _recorded(dep, job: str, rollouts: int, timeout: float = 30.0) -> dict:
    """The recorder's roll-out counts per job once ``job`` has ``rollouts`` recorded."""
    end = time.monotonic() + timeout
    while True:
        counts = call(dep.session, dep.keys.recorder_status(), None, timeout=10)["rollouts"]
        if counts.get(job, 0) >= rollouts or time.monotonic() > end:
            return counts
        time.sleep(0.2)


@pytest.mark.parametrize("role", ROLES)
def test_wildcards_and_ungranted_keys_change_nothing_and_stall_nothing(dep, role):
    keys, valid = dep.keys, valid_requests()
    forged = _forged_weights(dep)
    event = encode(rollout_event("forged", 0, np.zeros((3, 2)), [0.0, 0.5, 1.0], [0.0, 0.0, 1.0], worker="w"))
    heard: list[str] = []
    with _session(dep, role) as s, _session(dep, role) as spy:  # the spy's own session hears no puts of s
        # eavesdropping: every event and every weights version on the wide expressions
        subs = [spy.declare_subscriber(k, lambda sample: heard.append(str(sample.key_expr)))
                for k in _wildcards(dep, "event/**", "skill/*/weights")]
        # a token on a wildcard, and (for the worker role, inside its grant) on a wildcard worker id:
        # the learner must neither crash on it nor wait for it
        tokens = [s.liveliness().declare_token(k) for k in _wildcards(dep, "worker/point2d/*", "worker/**")]
        # forged weights and a forged roll-out on every wildcard
        for key in _wildcards(dep, "skill/*/weights", "skill/e1/*", "skill/*/*"):
            s.put(key, forged)
        for key in _wildcards(dep, "event/**", "event/rollout/*", "event/*/forged"):
            s.put(key, event)
        # jobs started, jobs cancelled, workers called, weights read, through wildcards: nobody answers
        for key, body in [(f"{keys.prefix}/skill/e1/*", valid["train"]), (f"{keys.prefix}/skill/*/adapt", valid["adapt"]),
                          (f"{keys.prefix}/job/*/cancel", {}), (f"{keys.prefix}/job/e1-0/*", {}),
                          (f"{keys.prefix}/worker/point2d/*/rollout", valid["rollout"]),
                          (f"{keys.prefix}/**", valid["train"]), (f"{keys.prefix}/skill/**", {})]:
            assert list(s.get(key, payload=encode({"v": 1, **body}), timeout=5)) == [], key
        if role != "operator":  # concrete keys outside the grants of client and worker
            s.put(keys.weights("e1"), forged)
            s.put(keys.event("rollout", "forged"), event)
            for key, body in [(keys.train("e1"), valid["train"]), (keys.adapt("e1"), valid["adapt"]),
                              (keys.job_cancel("e1-0"), {}), (keys.weights_latest("e1"), {}),
                              (keys.worker_rollout("point2d", "point2d-0"), valid["rollout"])]:
                assert list(s.get(key, payload=encode({"v": 1, **body}), timeout=5)) == [], (role, key)
            subs.append(spy.declare_subscriber(keys.event("rollout", "e1-next"), lambda sample: heard.append("concrete")))

        # meanwhile a legitimate adaptation job (started by the trusted side) runs to its end
        job = call(dep.session, keys.adapt("e1"), {**valid["adapt"], "assimilate_steps": 10}, timeout=30)["job"]
        status = _job_done(dep, job)
        assert status["state"] == "done", status
        counts = _recorded(dep, job, status["rollouts"])
        for x in subs + tokens:
            x.undeclare()
    assert counts[job] == status["rollouts"] and "forged" not in counts, counts
    assert heard == [], heard[:5]  # no event and no weights reached a subscriber no grant allows
    # the forged 2^62 was not taken: the learner's next version is what is served
    setup = make_setup()
    train = {"times": np.stack([x.times for x in setup.demos]), "values": np.stack([x.values for x in setup.demos]),
             "model": SMALL, "train": {"steps": 5}}
    version = call(dep.session, dep.keys.train("e1"), train, timeout=60)["version"]
    end = time.monotonic() + 30
    while (info := call(dep.session, keys.info("e1"), None, timeout=10))["version"] < version and time.monotonic() < end:
        time.sleep(0.1)
    assert info["version"] == version and info["data_hash"] != "forged" and info["source"] == "learner", info
    for child in dep.children.values():
        assert child.proc.poll() is None, f"{child.name} died"
