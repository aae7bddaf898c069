"""The learner without zenoh: a job runs on the in-process task, is recorded event by event,
assimilates into a new version, and a restart resumes what was running."""
from __future__ import annotations

import pytest

from acnmp_core.adapt_job import AdaptJob
from acnmp_core.adaptation import AdaptConfig
from acnmp_core.cnmp import CNMPConfig
from acnmp_core.experiments.viapoint import make_setup
from acnmp_core.training import TrainConfig
from services.learner.core import LearnerCore, TrainSpec, UnknownJobError, UnknownSkillError
from services.recording.events import validate_event
from services.worker.core import ExecutedBatch

SMALL = dict(encoder_widths=(32, 32), decoder_widths=(32, 32))


class Recorded:
    """The in-process task as the job's evaluator; batches name a worker, as a remote one's do."""

    def __init__(self, task):
        self.task, self.calls = task, 0

    def evaluate(self, trajectories, times, task_params=None):
        self.calls += 1
        return ExecutedBatch.of(self.task.evaluate(trajectories, times, task_params), ["w0"] * len(trajectories))


@pytest.fixture(scope="module")
def setup():
    return make_setup()


def _core(tmp_path, setup, events, versions):
    return LearnerCore(tmp_path, evaluator_for=lambda job: Recorded(setup.task), publish=events.append,
                       on_version=lambda state: versions.append(state.version))


def _job(setup, **config) -> AdaptJob:
    return AdaptJob(setup.target, "viapoint", "point2d", setup.task_config,
                    AdaptConfig(**{"max_rollouts": 9, "max_reuse": 5, **config}),
                    seed=5, commit=True, assimilate_steps=20)


def test_a_job_runs_records_every_rollout_and_assimilates(tmp_path, setup):
    events, versions = [], []
    core = _core(tmp_path, setup, events, versions).start()
    try:
        spec = TrainSpec(setup.demos, CNMPConfig(n_outputs=2, **SMALL), TrainConfig(steps=200), seed=3)
        assert core.train_skill("e1", spec).version == 0 and versions == [0]
        with pytest.raises(UnknownSkillError):
            core.submit("nope", _job(setup))
        record = core.submit("e1", _job(setup, stop_on_success=False))
        assert core.wait_idle(120)
        status = core.status(record.job)
        with pytest.raises(UnknownJobError):
            core.status("e1-nothing")
    finally:
        core.close()
    assert status["state"] == "done", status["error"]
    assert status["rollouts"] == status["result"]["rollouts"] == status["rollouts_executed"] == 9
    rollouts = [e for e in events if e["kind"] == "rollout"]
    assert [e["rollout_index"] for e in rollouts] == list(range(9))
    assert {e["worker"] for e in rollouts} == {"w0"} and {e["attempt"] for e in rollouts} == {0}
    assert all(validate_event(e) is e for e in events)
    assert events[-1]["kind"] == "job_progress" and events[-1]["state"] == "done"
    # commit: a successful solution becomes version 1, else the skill stays at 0
    if status["result"]["success"]:
        assert status["committed_version"] == 1 and versions == [0, 1]
        assert len(core.skills["e1"].demos) == len(setup.demos) + 1
    else:
        assert status["committed_version"] is None and versions == [0]


def test_a_restart_picks_up_skills_and_requeues_a_running_job(tmp_path, setup):
    events, versions = [], []
    core = _core(tmp_path, setup, events, versions)  # not started: the job stays queued
    spec = TrainSpec(setup.demos, CNMPConfig(n_outputs=2, **SMALL), TrainConfig(steps=50), seed=3)
    core.train_skill("e1", spec)
    record = core.submit("e1", _job(setup, max_rollouts=3))
    record.state = "running"  # as if the process died in the middle of it
    core.job_store.save(record)
    core.close()  # the process is gone: its lock on the state directory with it

    again = _core(tmp_path, setup, [], [])
    assert again.skills["e1"].demos.content_hash() == setup.demos.content_hash()
    assert again.jobs[record.job].state == "queued" and again.jobs[record.job].attempt == 1
    again.start()
    try:
        assert again.wait_idle(120)
    finally:
        again.close()
    assert again.status(record.job)["state"] == "done"


def test_a_second_learner_on_the_same_state_dir_is_refused(tmp_path, setup):
    from services.learner.store import StateDirInUse

    first = _core(tmp_path, setup, [], [])
    with pytest.raises(StateDirInUse, match=f"state directory {tmp_path.resolve()} is in use .*--state-dir"):
        _core(tmp_path, setup, [], [])
    first.close()
    _core(tmp_path, setup, [], []).close()  # free again once the first one is gone
