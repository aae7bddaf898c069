"""The launcher's restart rule: exponential backoff, and a limit of restarts within a window after
which a child is given up (services/launcher/supervision.py; the e2e tests run it on processes)."""
from __future__ import annotations

import pytest

from services.launcher.supervision import RestartPolicy
from services.recording.events import process_event, validate_event
from services.transport.wire import WireError


def test_backoff_doubles_per_restart_in_the_window_up_to_its_maximum():
    policy = RestartPolicy(max_restarts=10, window=60.0, first_delay=0.25, factor=2.0, max_delay=2.0)
    history: list[float] = []
    delays = []
    for i in range(6):
        delays.append(policy.delay(history, now=float(i)))
        history.append(float(i))
    assert delays == [0.25, 0.5, 1.0, 2.0, 2.0, 2.0]


def test_a_child_is_given_up_after_the_limit_within_the_window_and_forgiven_after_it():
    policy = RestartPolicy(max_restarts=5, window=60.0)
    history = [0.0, 1.0, 2.0, 3.0, 4.0]
    assert policy.delay(history, now=5.0) is None  # a sixth death within 60 s: give up
    # restarts older than the window no longer count: a child that ran for a while starts afresh
    assert policy.delay(history, now=64.5) == policy.first_delay
    assert policy.delay([0.0, 50.0], now=100.0) == policy.first_delay * policy.factor


@pytest.mark.parametrize("bad", [dict(max_restarts=-1), dict(window=0), dict(factor=0.5),
                                 dict(first_delay=3.0, max_delay=1.0)])
def test_an_inconsistent_policy_is_refused(bad):
    with pytest.raises(ValueError, match="restart policy"):
        RestartPolicy(**bad)


def test_the_process_event_is_validated_as_the_recorder_does():
    ev = process_event("learner", "restarted", pid=123, exit_code=-9, restarts=1, delay=0.25, live_after=2.5)
    assert validate_event(dict(ev)) == ev and ev["kind"] == "process"
    with pytest.raises(WireError, match="action"):
        validate_event({**ev, "action": "exploded"})
