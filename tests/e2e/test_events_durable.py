"""No event lost while the recorder is down: events published while a SIGKILLed recorder is being
restarted are recovered by the new recorder from the publishers' caches (zenoh-ext advanced
pub/sub), and the deployment's recording files together hold every event exactly once; those
that left a (small) cache meanwhile are counted as ``missed``. Secure deployment (router, ACL),
the events published by the operator role as a client of the router."""
from __future__ import annotations

import time

import numpy as np

from services.launcher import LocalDeployment
from services.launcher.supervision import RestartPolicy
from services.recording.events import rollout_event
from services.recording.publisher import EventPublisher
from services.recording.replay import recorded_event_ids, summarize
from services.recording.tables import read_recording
from services.transport import call, open_session, wait_for_liveliness_gone
from services.transport.runfile import RunFile

JOB = "durable-1"
#: A job published with a cache of SMALL_CACHE events: more are published while no recorder runs.
SHORT, SMALL_CACHE = "short-1", 3
TIMES = np.linspace(0.0, 1.0, 20)
#: The first restart waits 3 s: time enough to publish while no recorder runs, on a loaded machine too.
POLICY = RestartPolicy(max_restarts=2, window=60.0, first_delay=3.0, max_delay=3.0)


def _publish(pub: EventPublisher, first: int, n: int, job: str = JOB) -> None:
    rng = np.random.default_rng(first)
    for i in range(first, first + n):
        pub.publish(rollout_event(job, i, rng.normal(size=(len(TIMES), 2)), TIMES, -np.ones(len(TIMES)),
                                  worker="test"))


def _wait_status(dep, done, timeout: float = 60.0) -> dict:
    """Query the recorder's status until ``done(status)``; returns the last status."""
    deadline = time.monotonic() + timeout
    while True:
        status = call(dep.session, dep.keys.recorder_status(), timeout=10)
        if done(status) or time.monotonic() > deadline:
            return status
        time.sleep(0.1)


def test_events_published_while_the_recorder_is_down_are_recorded_once(tmp_path, verify_rrd):
    rrd = tmp_path / "durable.rrd"
    with LocalDeployment("durable", workers=1, model=False, learner=False, record=rrd, state_dir=tmp_path / "state",
                         secure=True, restart_policy=POLICY) as dep:
        run = RunFile.read(dep.announcement.directory / "run.json")
        with open_session(None, config_file=run.operator_credentials) as operator:
            pub = EventPublisher(operator, dep.keys)
            small = EventPublisher(operator, dep.keys, cache_samples=SMALL_CACHE)
            _publish(small, 0, 5, SHORT)
            _publish(pub, 0, 10)
            before = _wait_status(dep, lambda s: s["rollouts"].get(JOB, 0) >= 10 and s["rollouts"].get(SHORT, 0) >= 5)
            assert before["rollouts"][JOB] == 10 and before["missed"] == 0, before
            dep.kill("recorder")  # SIGKILL: its file keeps what reached it, no footer
            _publish(pub, 10, 10)  # no recorder runs: only the publisher's cache holds these
            _publish(small, 5, 8, SHORT)  # ... of these only the last 3 (10..12): 5..9 are gone
            # no recorder was live meanwhile: the router dropped the killed one's token, the restart is
            # still in its backoff (POLICY.first_delay); the short job's ``missed`` below proves it too
            wait_for_liveliness_gone(operator, dep.keys.tokens("recorder"), timeout=10)
            assert not [r for r in dep.supervisor.restarts if r.name == "recorder"], "restarted too early"
            dep.supervisor.wait_restarts("recorder", 1, timeout=60)
            _publish(pub, 20, 10)
            # the new recorder writes what the first file lacks and skips (duplicates) what it has
            after = _wait_status(dep, lambda s: s["rollouts"].get(JOB, 0) + s["duplicates"] >= 30
                                 and s["rollouts"].get(SHORT, 0) >= SMALL_CACHE)
            assert after["rollouts"].get(JOB, 0) + after["duplicates"] == 30, after
            # the short job's 10..12 came from its cache, 5..9 never will: counted missed (plus any of
            # 0..4 the killed recorder had not yet flushed to its file, gone from the cache too)
            assert after["rollouts"][SHORT] == SMALL_CACHE and after["missed"] >= 5, after
            missed = after["missed"]
            # the client role may not publish events: the ACL denies its advanced publisher's puts
            with open_session(None, config_file=run.credentials) as client:
                intruder = EventPublisher(client, dep.keys)
                intruder.publish(rollout_event("intruder", 0, np.zeros((len(TIMES), 2)), TIMES, np.zeros(len(TIMES))))
                intruder.close()
            first, second = dep.recordings
            ids = [recorded_event_ids(first), recorded_event_ids(second)]
            # exported as data: the killed recorder's file, without footer, holds what it flushed
            killed = read_recording(first).rollouts.to_pylist()
            flushed = summarize(first)["jobs"].get(JOB, {"rollouts": 0})["rollouts"]  # what reached the file
            assert len([r for r in killed if r["job"] == JOB]) == flushed
            pub.close()
            small.close()
        dep.stop()
    assert not ids[0] & ids[1]  # no event in both files
    merged = read_recording(rrd).rollouts.to_pylist()
    assert sorted(r["rollout_index"] for r in merged if r["job"] == JOB) == list(range(30))
    summary = summarize(rrd)  # the merged recording: both files
    job = summary["jobs"][JOB]
    assert job["rollouts"] == job["unique_rollouts"] == 30 and job["duplicates"] == [], job
    # every event of the short job is in the recording or counted missed, none twice
    short = summary["jobs"][SHORT]
    assert short["rollouts"] == short["unique_rollouts"] == 13 - missed and short["duplicates"] == [], short
    # the restarted recorder's marks file went with its merged file; the recording's own stays, for a
    # deployment that continues the recording (services/recording/segments.py)
    assert [p.name for p in tmp_path.glob("*.seen.json")] == ["durable.rrd.seen.json"]
    assert "intruder" not in summary["jobs"]
    assert [p["action"] for p in summary["processes"]] == ["restarted"]
    verify_rrd(rrd)
