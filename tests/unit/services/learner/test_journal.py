"""The roll-out journal: a learner killed between writing a batch's events, reserving their
indices and publishing them publishes them at its next start, before the job runs again, and the
new attempt's indices follow every index the journal holds."""
from __future__ import annotations

import threading

import numpy as np
import pytest

from services.learner.core import LearnerCore
from services.learner.journals import Settled
from services.learner.store import JobStore
from services.recording.event_ids import IndexRanges

from .test_concurrent_jobs import WAIT, Gate, _core, _job, setup, trained  # noqa: F401 (fixtures)


class Killed(BaseException):
    """Ends a job thread the way a kill ends the process: no handler of the learner runs."""


def _kill_at(core: LearnerCore, where: str, batch: int) -> None:
    """Make ``core``'s job thread die at its ``batch``-th batch (1-based), either before the
    reservation is written (``where="reserve"``) or before the first event is published
    (``where="publish"``)."""
    seen = {"n": 0}
    persist, publish = core._persist, core.publish

    def dying_persist(job, **changes):
        if "next_index" in changes:
            seen["n"] += 1
            if where == "reserve" and seen["n"] == batch:
                raise Killed()
        return persist(job, **changes)

    def dying_publish(ev):
        if where == "publish" and ev["kind"] == "rollout" and seen["n"] == batch:
            raise Killed()
        return publish(ev)

    core._persist, core.publish = dying_persist, dying_publish


@pytest.mark.parametrize("where", ["reserve", "publish"])
def test_a_killed_batch_is_published_at_the_next_start_and_its_indices_stay_reserved(trained, tmp_path, setup, where):
    before: list[dict] = []
    core = _core(trained, tmp_path, Gate(setup.task), before)
    _kill_at(core, where, batch=2)
    job = core.submit("e1", _job(setup, 5)).job
    for thread in core._threads:
        thread.join(WAIT)  # the job thread died at batch 2
    core.close()
    store = JobStore(tmp_path / "state")
    journal = store.take_journal(job)
    assert journal, "the killed batch is in the journal"
    killed = {ev["rollout_index"] for ev in journal}
    published = {ev["rollout_index"] for ev in before if ev["kind"] == "rollout"}
    assert not killed <= published  # the kill kept some roll-outs from the recording

    after: list[dict] = []
    core = LearnerCore(tmp_path / "state", evaluator_for=Gate(setup.task).evaluator_for, publish=after.append).start()
    try:
        assert core.wait_idle(WAIT)
        status = core.status(job)
    finally:
        core.close()
    assert status["state"] == "done" and status["attempt"] == 1
    rollouts = [ev for ev in after if ev["kind"] == "rollout"]
    first = [ev["rollout_index"] for ev in rollouts if ev["attempt"] == 0]
    again = [ev["rollout_index"] for ev in rollouts if ev["attempt"] == 1]
    assert set(first) == killed and rollouts[:len(first)] == [ev for ev in rollouts if ev["attempt"] == 0]
    # every index of the killed attempt is held once, the new attempt's come after them all
    assert published | killed == set(range(max(killed) + 1))
    assert again == list(range(max(killed) + 1, max(killed) + 1 + status["result"]["rollouts"]))
    assert status["rollouts_executed"] == max(again) + 1


def _killed_journal(trained, tmp_path, setup) -> tuple[str, set[int]]:
    """A state directory (``tmp_path/state``) whose job was killed at its second batch, before
    publishing it: (the job's id, the indices its journal holds)."""
    core = _core(trained, tmp_path, Gate(setup.task), [])
    _kill_at(core, "publish", batch=2)
    job = core.submit("e1", _job(setup, 5)).job
    for thread in core._threads:
        thread.join(WAIT)
    core.close()
    return job, {ev["rollout_index"] for ev in JobStore(tmp_path / "state").take_journal(job)}


def test_a_journal_that_cannot_be_published_is_quarantined_and_named_and_never_blocks_the_others(
        trained, tmp_path, setup):
    """Issue 66: a journal whose events made the publish fail (a return of -inf, from rewards of
    -1e308) stopped every journal after it, at every start, and status said nothing."""
    from services.recording.events import rollout_event

    job, killed = _killed_journal(trained, tmp_path, setup)
    store = JobStore(tmp_path / "state")
    good = rollout_event("a0-0000000000", 0, np.zeros((3, 2)), [0, 0.5, 1], [0.0, 0.0, 1.0])
    bad = {**good, "rollout_index": 1, "return": float("-inf")}
    store.save_journal("a0-0000000000", [{**good, "attempt": 0}, {**bad, "attempt": 0}])  # sorted before `job`
    after: list[dict] = []
    core = LearnerCore(tmp_path / "state", evaluator_for=Gate(setup.task).evaluator_for, publish=after.append).start()
    try:
        assert core.wait_idle(WAIT)
        problems = core.health().problems()
        status = core.status(job)
    finally:
        core.close()
    published = {(ev["job"], ev["rollout_index"]) for ev in after if ev["kind"] == "rollout"}
    assert {(job, i) for i in killed} <= published  # the journal after the bad one
    assert ("a0-0000000000", 0) in published and ("a0-0000000000", 1) not in published  # its good event too
    (line,) = [p for p in problems if "a0-0000000000.rollouts" in p]
    assert line.startswith("quarantined jobs/a0-0000000000.rollouts: 1 of its 2 roll-out events cannot be "
                           "published (event 1: non_finite"), line
    # its publishable event is journalled again, until the recorder holds it
    assert status["state"] == "done" and [ev["rollout_index"] for ev in store.take_journal("a0-0000000000")] == [0]


def test_a_journal_whose_publishing_fails_is_kept_named_and_published_once_it_can_be(
        trained, tmp_path, setup, monkeypatch):
    import services.learner.core as core_module

    monkeypatch.setattr(core_module, "JOURNAL_RETRY_S", 0.05)
    job, killed = _killed_journal(trained, tmp_path, setup)
    after: list[dict] = []
    session_down = threading.Event()
    session_down.set()

    def publish(ev):
        if session_down.is_set() and ev["kind"] == "rollout" and ev["attempt"] == 0:
            raise ConnectionError("the session is closing")
        after.append(ev)

    gate = Gate(setup.task)
    gate.open.clear()  # the job waits at its first batch: the held events must survive its journal writes
    core = LearnerCore(tmp_path / "state", evaluator_for=gate.evaluator_for, publish=publish).start()
    try:
        gate.wait_started(1)
        (line,) = core.health().problems()
        assert line.startswith(f"job {job}: {len(killed)} journalled roll-out event(s) not published yet "
                               "(ConnectionError: the session is closing)"), line
        gate.open.set()
        assert core.wait_idle(WAIT)  # the job ran again, writing its journal at every batch ...
        assert {ev["rollout_index"] for ev in JobStore(tmp_path / "state").take_journal(job)} >= killed  # ... with them
        session_down.clear()
        _wait(lambda: not core.health().problems())
    finally:
        core.close()
    first = {ev["rollout_index"] for ev in after if ev["kind"] == "rollout" and ev["attempt"] == 0}
    assert killed <= first


def test_a_finished_jobs_journal_goes_once_the_recorder_holds_its_rollouts(trained, tmp_path, setup):
    """Issue 66: the journal of a finished job stayed, and the next session published its last
    batches into a new recording (10 of an old job's 40 roll-outs)."""
    core = _core(trained, tmp_path, Gate(setup.task), [])
    try:
        job = core.submit("e1", _job(setup, 5)).job
        assert core.wait_idle(WAIT)
        path = core.job_store.journal_path(job)
        assert path.exists()
        assert core.settle_journals(lambda jobs: {}) == Settled((), 0, (job,)) and path.exists()  # not confirmed
        every = lambda jobs: {j: IndexRanges.everything() for j in jobs}  # noqa: E731
        assert core.settle_journals(every) == Settled((job,), 10, ()) and not path.exists()
    finally:
        core.close()


def test_a_journal_keeps_every_rollout_until_the_recorder_holds_it(trained, tmp_path, setup):
    """Issue 73, defect 1: a journal kept the last two batches of a running job, so a recorder
    killed with the learner lost the roll-outs it had received but not yet written. Now a job's
    journal holds every roll-out the recorder has not confirmed, whatever the batches, and drops
    exactly those it confirms."""
    events: list[dict] = []
    gate = Gate(setup.task)
    core = _core(trained, tmp_path, gate, events)
    try:
        job = core.submit("e1", _job(setup, 5, rollouts=20)).job
        assert core.wait_idle(WAIT)
        path = core.job_store.journal_path(job)
        published = sorted(ev["rollout_index"] for ev in events if ev["kind"] == "rollout")
        batches = {ev["iteration"] for ev in events if ev["kind"] == "rollout"}
        assert len(batches) > 2 and published == list(range(core.status(job)["rollouts_executed"]))
        # nothing confirmed: the journal holds every batch's roll-outs, not the last two
        assert [ev["rollout_index"] for ev in core.job_store.take_journal(job)] == published
        held = IndexRanges(((0, 6), (9, 11)))
        settled = core.settle_journals(lambda jobs: {job: held})
        assert settled == Settled((), 10, (job,)) and path.exists()
        assert core.journals.unconfirmed() == {job: len(published) - 10}
        every = lambda jobs: {j: IndexRanges.everything() for j in jobs}  # noqa: E731
        assert core.settle_journals(every).removed == (job,) and not path.exists()
    finally:
        core.close()


def _wait(predicate, timeout: float = WAIT) -> None:
    import time

    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline
        time.sleep(0.02)
