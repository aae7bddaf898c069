"""The event publishers' caches are bounded: one process keeps cached publishers for at most
``MAX_KEYS`` event keys, the least recently used one is undeclared (its cache with it) when a new
key comes, and a key used again gets a fresh publisher. Real zenoh session on loopback."""
from __future__ import annotations

import numpy as np

from services.recording import publisher as P
from services.recording.events import event_key, rollout_event
from services.transport import open_session

TIMES = np.linspace(0.0, 1.0, 5)


def _event(job: str) -> dict:
    return rollout_event(job, 0, np.zeros((len(TIMES), 2)), TIMES, np.zeros(len(TIMES)), worker="test")


def test_at_most_max_keys_cached_publishers_least_recently_used_evicted(monkeypatch):
    monkeypatch.setattr(P, "MAX_KEYS", 3)
    with open_session() as session:
        pub = P.EventPublisher(session, "bound")
        keys = [event_key(pub.keys, _event(f"job-{i}")) for i in range(5)]
        for i in range(3):
            pub.publish(_event(f"job-{i}"))
        pub.publish(_event("job-0"))  # job-0 is now the most recently used
        pub.publish(_event("job-3"))  # a 4th key: job-1, the least recently used, goes
        assert list(pub._publishers) == [keys[2], keys[0], keys[3]]
        pub.publish(_event("job-1"))  # back with a fresh publisher; job-2 goes
        assert list(pub._publishers) == [keys[0], keys[3], keys[1]]
        pub.close()
        assert not pub._publishers
