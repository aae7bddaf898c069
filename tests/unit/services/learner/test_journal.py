"""The roll-out journal: a learner killed between writing a batch's events, reserving their
indices and publishing them publishes them at its next start, before the job runs again, and the
new attempt's indices follow every index the journal holds."""
from __future__ import annotations

import pytest

from services.learner.core import LearnerCore
from services.learner.store import JobStore

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
