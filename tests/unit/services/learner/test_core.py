"""The learner without zenoh: a job runs on the in-process task, is recorded event by event,
assimilates into a new version, and a restart resumes what was running; cancel and shutdown
(a job saved as interrupted) keep their promises."""
from __future__ import annotations

import threading

import pytest

from acnmp_core.adaptation.config import AdaptConfig
from acnmp_core.experiments.viapoint import make_setup
from acnmp_core.jobs.adapt import AdaptJob
from acnmp_core.model.cnmp import CNMPConfig
from acnmp_core.model.training import TrainConfig
from services.learner.core import LearnerCore, TrainSpec, UnknownJobError, UnknownSkillError
from services.learner.store import JobStore
from services.recording.events import job_names, validate_event
from services.transport.wire import jsonable
from services.worker.core import ExecutedBatch
from services.worker.exclusion import Exclusion

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
        spec = TrainSpec(setup.demos, CNMPConfig(n_outputs=2, output_names=("x", "y"), **SMALL),
                         TrainConfig(steps=200), seed=3)
        assert core.train_skill("e1", spec).version == 0 and versions == [0]
        with pytest.raises(UnknownSkillError):
            core.submit("nope", _job(setup))
        record = core.submit("e1", _job(setup, stop_on_success=False))
        assert core.wait_idle(120)
        status = core.status(record.job)
        with pytest.raises(UnknownJobError):
            core.status("e1-nothing")
        # a finished job stays as it ended: a cancel answers its state and changes nothing
        assert jsonable(core.cancel(record.job)) == jsonable(status) == jsonable(core.status(record.job))
    finally:
        core.close()
    assert jsonable(JobStore(tmp_path).load_all()[record.job].status()) == jsonable(status)  # and on disk
    assert status["state"] == "done", status["error"]
    assert status["rollouts"] == status["result"]["rollouts"] == status["rollouts_executed"] == 9
    rollouts = [e for e in events if e["kind"] == "rollout"]
    assert [e["rollout_index"] for e in rollouts] == list(range(9))
    assert {e["worker"] for e in rollouts} == {"w0"} and {e["attempt"] for e in rollouts} == {0}
    assert all(validate_event(e) is e for e in events)
    assert events[-1]["kind"] == "job_progress" and events[-1]["state"] == "done"
    # what the job ran, with the skill's names, which exports of its roll-outs carry (issue 65)
    (about,) = [e for e in events if e["kind"] == "job"]
    assert job_names(about, "output_names") == ["x", "y"] and job_names(about, "task_param_names") == []
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
    from services.transport.state_dir import StateDirInUse

    first = _core(tmp_path, setup, [], [])
    with pytest.raises(StateDirInUse, match=f"state directory {tmp_path.resolve()} is in use .*--state-dir"):
        _core(tmp_path, setup, [], [])
    first.close()
    _core(tmp_path, setup, [], []).close()  # free again once the first one is gone


class Gated(Recorded):
    """The in-process task, but each batch waits until ``gate`` is set (``started`` says one is in)."""

    def __init__(self, task):
        super().__init__(task)
        self.started, self.gate = threading.Event(), threading.Event()

    def evaluate(self, trajectories, times, task_params=None):
        self.started.set()
        assert self.gate.wait(60), "the test never opened the gate"
        return super().evaluate(trajectories, times, task_params)


def _close_in_a_batch(core: LearnerCore, gated: Gated) -> None:
    """Close ``core`` (SIGTERM's way) while its job waits in ``gated``'s batch: the job is saved interrupted."""
    assert gated.started.wait(60)
    closing = threading.Thread(target=core.close)
    closing.start()
    assert core.stopping.wait(10)
    gated.gate.set()
    closing.join(30)
    assert not closing.is_alive()


def _gated_core(tmp_path, setup, events):
    gated = Gated(setup.task)
    core = LearnerCore(tmp_path, evaluator_for=lambda job: gated, publish=events.append)
    spec = TrainSpec(setup.demos, CNMPConfig(n_outputs=2, **SMALL), TrainConfig(steps=50), seed=3)
    core.train_skill("e1", spec)
    return core, gated


def test_cancel_ends_a_queued_job_at_once_and_a_running_one_after_its_iteration(tmp_path, setup):
    events = []
    core, gated = _gated_core(tmp_path, setup, events)
    running = core.submit("e1", _job(setup, max_rollouts=30, stop_on_success=False))
    queued = core.submit("e1", _job(setup, max_rollouts=3))
    core.start()
    try:
        assert gated.started.wait(60)
        assert core.cancel(queued.job)["state"] == "cancelled"  # never ran
        reply = core.cancel(running.job)
        assert reply["state"] == "running" and reply["cancel_requested"] is True
        gated.gate.set()  # the iteration in flight finishes, then the job stops
        assert core.wait_idle(60)
        with pytest.raises(UnknownJobError):
            core.cancel("e1-nothing")
        st = core.status(running.job)
        assert core.cancel(running.job)["state"] == "cancelled"  # a finished job stays as it is
    finally:
        core.close()
    assert st["state"] == "cancelled" and st["rollouts"] < 30 and st["result"] is None
    assert gated.calls == 1  # one batch ran (its roll-outs are recorded), no second one
    rollouts = [e for e in events if e["kind"] == "rollout" and e["job"] == running.job]
    assert len(rollouts) == st["rollouts_executed"] > 0
    states = {e["job"]: e["state"] for e in events if e["kind"] == "job_progress"}
    assert states == {running.job: "cancelled", queued.job: "cancelled"}
    # saved: a restarted learner knows both as cancelled and runs neither
    fresh = Recorded(setup.task)
    again = LearnerCore(tmp_path, evaluator_for=lambda job: fresh).start()
    try:
        assert again.wait_idle(30)
        assert {again.status(j.job)["state"] for j in (running, queued)} == {"cancelled"}
    finally:
        again.close()
    assert fresh.calls == 0


def test_close_saves_the_running_job_as_interrupted_and_a_restart_resumes_it(tmp_path, setup):
    events = []
    core, gated = _gated_core(tmp_path, setup, events)
    job = core.submit("e1", _job(setup, max_rollouts=6, stop_on_success=False))
    core.start()
    _close_in_a_batch(core, gated)
    saved = JobStore(tmp_path).load_all()[job.job]
    assert saved.state == "interrupted"
    assert [e["state"] for e in events if e["kind"] == "job_progress"][-1] == "interrupted"

    again = LearnerCore(tmp_path, evaluator_for=lambda j: Recorded(setup.task)).start()
    try:
        assert again.wait_idle(120)
        st = again.status(job.job)
    finally:
        again.close()
    assert st["state"] == "done" and st["attempt"] == 1 and st["rollouts"] == 6


class Excluding(Gated):
    """The in-process task whose first batch reports ``worker`` excluded (as a remote evaluator
    whose worker went down with its launcher does); later batches wait for the gate."""

    def __init__(self, task, worker: str, reason: str):
        super().__init__(task)
        self.excluded = [Exclusion(worker, reason)]
        self.gate_from = 2

    def evaluate(self, trajectories, times, task_params=None):
        if self.calls + 1 >= self.gate_from:
            return super().evaluate(trajectories, times, task_params)
        return Recorded.evaluate(self, trajectories, times, task_params)


def test_a_resumed_job_shows_the_exclusions_of_its_own_attempt(tmp_path, setup):
    """Issue 73, defect 4: a worker excluded by an attempt that ended with its learner (it was only
    going down with its launcher) is not the resumed job's; each exclusion says its attempt."""
    events = []
    dying = Excluding(setup.task, "point2d-1", "failed 2 times; last for roll-outs 0..1: unavailable: gone")
    core = LearnerCore(tmp_path, evaluator_for=lambda job: dying, publish=events.append)
    core.train_skill("e1", TrainSpec(setup.demos, CNMPConfig(n_outputs=2, **SMALL), TrainConfig(steps=50), seed=3))
    job = core.submit("e1", _job(setup, max_rollouts=8, stop_on_success=False)).job
    core.start()
    _close_in_a_batch(core, dying)  # the second batch's: the first one's exclusion is on disk
    assert core.status(job)["excluded_workers"][0]["attempt"] == 0  # while attempt 0 ran, it was its own

    healthy = Excluding(setup.task, "point2d-2", "answered for roll-outs 2..3: rewards: a value of magnitude 1e+308")
    healthy.gate.set()
    again = LearnerCore(tmp_path, evaluator_for=lambda job: healthy, publish=events.append).start()
    try:
        assert again.wait_idle(120)
        status = again.status(job)
    finally:
        again.close()
    assert status["state"] == "done" and status["attempt"] == 1, status["error"]
    assert status["excluded_workers"] == [{"worker": "point2d-2", "reason": healthy.excluded[0].reason, "attempt": 1}]
    assert events[-1]["kind"] == "job_progress" and events[-1]["excluded_workers"].startswith("point2d-2: answered")
    # the record keeps both, each with its attempt
    kept = JobStore(tmp_path).load_all()[job].excluded_workers
    assert [(e.worker, e.attempt) for e in kept] == [("point2d-1", 0), ("point2d-2", 1)]


def test_a_cancel_asked_before_a_crash_ends_the_job_on_restart(tmp_path, setup):
    core, _ = _gated_core(tmp_path, setup, [])  # not started
    job = core.submit("e1", _job(setup, max_rollouts=3))
    job.state, job.cancel_requested = "running", True  # the learner died before the job saw it
    core.job_store.save(job)
    core.close()
    fresh = Recorded(setup.task)
    again = LearnerCore(tmp_path, evaluator_for=lambda j: fresh).start()
    try:
        assert again.wait_idle(30) and again.status(job.job)["state"] == "cancelled"
    finally:
        again.close()
    assert fresh.calls == 0


def test_a_solution_found_on_an_older_version_is_assimilated_into_the_skills_newest(tmp_path, setup):
    """A train request may commit a new version while a job adapts the old one: the job's solution
    is then assimilated into the new version's model (it was into the old adapted copy)."""
    import numpy as np

    class Succeeds(Gated):
        def evaluate(self, trajectories, times, task_params=None):
            self.started.set()
            assert self.gate.wait(60)
            b, t = trajectories.shape[:2]
            return ExecutedBatch(np.zeros((b, t)), np.ones(b, dtype=bool), workers=("w0",) * b)

    gated = Succeeds(setup.task)
    core = LearnerCore(tmp_path, evaluator_for=lambda job: gated)
    try:
        spec = TrainSpec(setup.demos, CNMPConfig(n_outputs=2, **SMALL), TrainConfig(steps=5), seed=3)
        core.train_skill("e1", spec)
        job = core.submit("e1", AdaptJob(setup.target, "viapoint", "point2d", setup.task_config,
                                         AdaptConfig(max_rollouts=5), seed=5, commit=True, assimilate_steps=1))
        core.start()
        assert gated.started.wait(60)
        newer = core.train_skill("e1", TrainSpec(setup.demos, spec.model_cfg, spec.train_cfg, seed=4))  # other weights
        gated.gate.set()
        assert core.wait_idle(60) and core.status(job.job)["committed_version"] == 2
        committed = core.skills["e1"].model.state_dict()
    finally:
        core.close()
    name, weights = next(iter(newer.model.named_parameters()))
    # one assimilation step at lr 1e-4 from version 1's weights, not from version 0's
    assert float((committed[name] - weights.detach()).abs().max()) < 1e-2


def test_a_skill_is_found_trained_as_asked_until_another_version_replaces_it(tmp_path, setup):
    """What a train request with ``reuse`` relies on: the current version is "trained from" the
    request only when the same demonstrations, architecture (not its labels), settings and seed made
    it; a restart keeps that; a later version made otherwise does not inherit it."""
    from dataclasses import replace

    from acnmp_core.data.demos import DemoSet

    core = _core(tmp_path, setup, [], [])
    spec = TrainSpec(setup.demos, CNMPConfig(n_outputs=2, output_names=("x", "y"), **SMALL), TrainConfig(steps=20),
                     seed=3)
    assert core.trained_from("e1", spec) is None  # no skill yet
    state = core.train_skill("e1", spec)
    assert core.trained_from("e1", replace(spec, model_cfg=CNMPConfig(n_outputs=2, **SMALL))) is state  # labels only
    for other in (replace(spec, seed=4), replace(spec, train_cfg=TrainConfig(steps=21)),
                  replace(spec, model_cfg=CNMPConfig(n_outputs=2, encoder_widths=(16, 16), decoder_widths=(32, 32))),
                  replace(spec, demos=DemoSet(setup.demos.demos[:-1]))):
        assert core.trained_from("e1", other) is None
    core.close()
    again = _core(tmp_path, setup, [], [])
    try:
        assert again.trained_from("e1", spec).version == 0  # kept in the checkpoint
        again.train_skill("e1", replace(spec, seed=4))
        assert again.trained_from("e1", spec) is None and again.trained_from("e1", replace(spec, seed=4)).version == 1
        # a version that is not a training's (an assimilation's, a pair's) is no training's
        again._commit_skill(replace(again.skills["e1"], version=2, trained_as=None), note="assimilated")
        assert again.trained_from("e1", replace(spec, seed=4)) is None
    finally:
        again.close()


class Solves(Recorded):
    """Every roll-out succeeds (rewards 0): a job's first mean is its solution."""

    def evaluate(self, trajectories, times, task_params=None):
        import numpy as np

        self.calls += 1
        b, t = trajectories.shape[:2]
        return ExecutedBatch(np.zeros((b, t)), np.ones(b, dtype=bool), workers=("w0",) * b)


class Fails(Recorded):
    """No roll-out succeeds (rewards -1 per step)."""

    def evaluate(self, trajectories, times, task_params=None):
        import numpy as np

        self.calls += 1
        b, t = trajectories.shape[:2]
        return ExecutedBatch(-np.ones((b, t)), np.zeros(b, dtype=bool), workers=("w0",) * b)


def test_a_committing_job_that_finds_no_solution_commits_nothing(tmp_path, setup):
    versions = []
    core = LearnerCore(tmp_path, evaluator_for=lambda job: Fails(setup.task),
                       on_version=lambda state: versions.append(state.version))
    try:
        core.train_skill("e1", TrainSpec(setup.demos, CNMPConfig(n_outputs=2, **SMALL), TrainConfig(steps=5), seed=3))
        job = core.submit("e1", _job(setup, max_rollouts=5)).job
        core.start()
        assert core.wait_idle(60)
        status = core.status(job)
    finally:
        core.close()
    assert status["state"] == "done" and not status["result"]["success"]
    assert status["committed_version"] is None and versions == [0] and core.skills["e1"].version == 0


def test_a_job_that_died_after_committing_its_solution_is_not_assimilated_twice(tmp_path, setup):
    """kill -9 after the new version's checkpoint but before the job's record said so: the restarted
    job finds its solution already in the skill and is done with that version, not a second one."""
    core = LearnerCore(tmp_path, evaluator_for=lambda job: Solves(setup.task))
    try:
        core.train_skill("e1", TrainSpec(setup.demos, CNMPConfig(n_outputs=2, **SMALL), TrainConfig(steps=5), seed=3))
        record = core.submit("e1", _job(setup, max_rollouts=5))
        core.start()
        assert core.wait_idle(60) and core.status(record.job)["committed_version"] == 1
    finally:
        core.close()
    record.state, record.committed_version = "running", None  # its record as the kill left it
    JobStore(tmp_path).save(record)
    fresh = Solves(setup.task)
    again = LearnerCore(tmp_path, evaluator_for=lambda job: fresh).start()
    try:
        assert again.wait_idle(60)
        status = again.status(record.job)
        skill = again.skills["e1"]
    finally:
        again.close()
    assert status["state"] == "done" and status["attempt"] == 1 and status["committed_version"] == 1
    assert skill.version == 1 and len(skill.demos) == len(setup.demos) + 1 and fresh.calls == 0
