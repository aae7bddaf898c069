"""ACNMPClient.jobs with several learners: the replies are merged only once every learner a reply
names live has answered (a fresh session may know neither every learner's queryable nor every
learner's token when it first asks)."""
from __future__ import annotations

import clients.client as client_module
from clients.client import ACNMPClient


class _Session:
    """Stands for a zenoh session where ACNMPClient.jobs needs only its id (its queries are scripted)."""

    def zid(self) -> str:
        return "1a"


def _reply(learner: str, created: float, live: list[str]) -> dict:
    return {"v": 1, "total": 1, "learner": learner, "live": live,
            "jobs": [{"job": f"e1-{learner}-0123456789", "state": "done", "created": created}]}


def test_jobs_asks_again_until_every_learner_named_live_has_answered(monkeypatch):
    both = ["learner", "learner-2"]
    answers = [[_reply("learner", 1.0, both)],  # the fresh session reaches one learner first ...
               [_reply("learner", 1.0, both), _reply("learner-2", 2.0, both)]]
    asked = []

    def call_when_available(session, key, payload, timeout, caller):
        asked.append((key, payload))
        return answers[min(len(asked), len(answers)) - 1]

    # ... and sees one learner token: the count alone would take the first answer as complete
    monkeypatch.setattr(client_module, "call_when_available", call_when_available)
    monkeypatch.setattr(client_module, "alive_tokens", lambda session, key, timeout: ["acnmp/ns/learner/learner"])
    rows = ACNMPClient("ns", session=_Session()).jobs(limit=10, timeout=30)
    assert [r.job for r in rows] == ["e1-learner-2-0123456789", "e1-learner-0123456789"]  # newest first
    assert len(asked) == 2 and asked[0] == ("acnmp/ns/jobs", {"v": 1, "limit": 10})


def test_jobs_of_a_lone_learner_take_one_answer(monkeypatch):
    asked = []

    def call_when_available(session, key, payload, timeout, caller):
        asked.append(key)
        return [_reply("learner", 1.0, ["learner"])]

    monkeypatch.setattr(client_module, "call_when_available", call_when_available)
    monkeypatch.setattr(client_module, "alive_tokens", lambda session, key, timeout: ["acnmp/ns/learner/learner"])
    assert [r.job for r in ACNMPClient("ns", session=_Session()).jobs(timeout=30)] == ["e1-learner-0123456789"]
    assert len(asked) == 1
