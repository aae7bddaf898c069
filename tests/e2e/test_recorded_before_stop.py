"""Stopping a deployment never loses roll-outs the experiment published through its launcher:
``stop()`` ends the recorder only once the recorder's counts hold them (the events in flight
between the launcher and the recorder would otherwise go with it)."""
from __future__ import annotations

import numpy as np

from clients.distributed import experiment_deployment
from services.recording.events import rollout_event
from services.recording.replay import summarize

N = 400  # a burst far larger than what is in flight at any moment


def test_stop_waits_until_every_published_rollout_is_recorded(tmp_path):
    path = tmp_path / "burst.rrd"
    rng = np.random.default_rng(0)
    times = np.linspace(0.0, 1.0, 101)
    with experiment_deployment("t-burst", workers=0, robot="point2d", record=str(path),
                               model=False, learner=False) as dep:
        assert dep.events.wait_for_recorder(timeout=30)
        for i in range(N):
            dep.events.publish(rollout_event("burst-0", i, rng.normal(size=(101, 2)), times, np.zeros(101)))
        assert dep.events.rollouts_published() == {"burst-0": N}
    # the block's exit is dep.stop(), straight after the last put
    job = summarize(path)["jobs"]["burst-0"]
    assert job["rollouts"] == job["unique_rollouts"] == N


def test_wait_recorded_returns_once_the_recorder_counts_them_and_false_without_a_recorder(tmp_path):
    from services.transport import call

    times = np.linspace(0.0, 1.0, 11)
    with experiment_deployment("t-wait", workers=0, robot="point2d", record=str(tmp_path / "w.rrd"),
                               model=False, learner=False) as dep:
        assert dep.events.wait_recorded(timeout=1)  # nothing published yet: nothing to wait for
        assert dep.events.wait_for_recorder(timeout=30)
        for i in range(50):
            dep.events.publish(rollout_event("w-0", i, np.zeros((11, 2)), times, np.zeros(11)))
        assert dep.events.wait_recorded(timeout=30)
        assert call(dep.session, dep.keys.recorder_status(), None, timeout=10)["rollouts"]["w-0"] == 50
    with experiment_deployment("t-norec", workers=0, robot="point2d", model=False, learner=False) as dep:
        dep.events.publish(rollout_event("n-0", 0, np.zeros((11, 2)), times, np.zeros(11)))
        assert dep.events.wait_recorded(timeout=30) is False  # no recorder answers: at once, not after 30 s
