"""Jobs side by side in one learner (``jobs`` > 1): each job's result is the one it has alone, on a
thread or in a child process; the queue bound counts every job in flight; cancelling one of several
leaves the others as they would be; a job whose adaptation process dies fails alone."""
from __future__ import annotations

import os
import shutil
import signal
import threading

import numpy as np
import torch
import pytest

from acnmp_core.jobs.adapt import AdaptJob
from acnmp_core.adaptation.config import AdaptConfig
from acnmp_core.model.cnmp import CNMPConfig
from acnmp_core.experiments.viapoint import make_setup
from acnmp_core.model.training import TrainConfig
from services.learner.core import LearnerBusy, LearnerCore, TrainSpec
from services.learner.limits import StateLimits
from services.worker.core import ExecutedBatch

SMALL = dict(encoder_widths=(32, 32), decoder_widths=(32, 32))
WAIT = 120.0  # liveness bound only


class Gate:
    """Evaluators of the in-process task that hold every job's first batch until ``open`` is set,
    so the test knows which jobs are in flight at once; ``started`` counts jobs at their gate."""

    def __init__(self, task):
        self.task = task
        self.open = threading.Event()
        self.open.set()
        self.started: list[int] = []  # seeds of the jobs that reached their first batch
        self.cond = threading.Condition()

    def evaluator_for(self, job: AdaptJob):
        gate = self

        class Evaluator:
            first = True

            def evaluate(self, trajectories, times, task_params=None):
                if self.first:
                    self.first = False
                    with gate.cond:
                        gate.started.append(job.seed)
                        gate.cond.notify_all()
                    assert gate.open.wait(WAIT)
                batch = gate.task.evaluate(trajectories, times, task_params)
                return ExecutedBatch.of(batch, ["w0"] * len(trajectories))

        return Evaluator()

    def wait_started(self, n: int) -> None:
        with self.cond:
            assert self.cond.wait_for(lambda: len(self.started) >= n, WAIT), self.started


@pytest.fixture(scope="module")
def setup():
    return make_setup()


@pytest.fixture(scope="module")
def trained(tmp_path_factory, setup):
    """A state directory holding skill ``e1`` (copied for each test)."""
    root = tmp_path_factory.mktemp("trained")
    core = LearnerCore(root, evaluator_for=lambda job: None)
    try:
        # the paper's CNMP (no linear path): its mean misses the extrapolated via-point, so every job adapts
        core.train_skill("e1", TrainSpec(setup.demos, CNMPConfig(n_outputs=2, prior="none", **SMALL),
                                         TrainConfig(steps=100), seed=3))
    finally:
        core.close()
    return root


def _core(trained, tmp_path, gate, events=None, **kwargs) -> LearnerCore:
    state = tmp_path / "state"
    shutil.copytree(trained, state, ignore=shutil.ignore_patterns("*.lock"))
    return LearnerCore(state, evaluator_for=gate.evaluator_for,
                       publish=(events.append if events is not None else lambda _e: None), **kwargs).start()


def _job(setup, seed: int, rollouts: int = 10) -> AdaptJob:
    return AdaptJob(setup.target, "viapoint", "point2d", setup.task_config,
                    AdaptConfig(max_rollouts=rollouts, max_reuse=3, stop_on_success=False), seed=seed)


def _result(core, job_id):
    status = core.status(job_id)
    assert status["state"] == "done", status["error"]
    return status["result"]


def _alone(trained, tmp_path, setup, seeds) -> dict:
    """The result of each seed's job run alone (one job at a time, on the job thread), by seed."""
    core = _core(trained, tmp_path / "alone", Gate(setup.task))
    try:
        jobs = {seed: core.submit("e1", _job(setup, seed)).job for seed in seeds}
        assert core.wait_idle(WAIT)
        return {seed: _result(core, job) for seed, job in jobs.items()}
    finally:
        core.close()


def _same(a: dict, b: dict) -> None:
    np.testing.assert_array_equal(a["trajectory"], b["trajectory"])
    assert [h["mean_return"] for h in a["history"]] == [h["mean_return"] for h in b["history"]]
    assert a["rollouts"] == b["rollouts"]


@pytest.mark.parametrize("runner", ["process", "thread"])
def test_a_job_gives_the_same_numbers_alone_and_beside_others(trained, tmp_path, setup, runner):
    alone = _alone(trained, tmp_path, setup, (5, 6, 7))

    gate = Gate(setup.task)
    gate.open.clear()
    events: list[dict] = []
    core = _core(trained, tmp_path / "together", gate, events, jobs=3, job_runner=runner)
    try:
        together = {seed: core.submit("e1", _job(setup, seed)).job for seed in (5, 6, 7)}
        gate.wait_started(3)  # all three are in flight: none could reach its gate before another ended
        gate.open.set()
        assert core.wait_idle(WAIT)
        for seed, job in together.items():
            _same(_result(core, job), alone[seed])
    finally:
        core.close()
    # each job's roll-outs are recorded once each, under its own indices
    for job in together.values():
        indices = [e["rollout_index"] for e in events if e["kind"] == "rollout" and e["job"] == job]
        assert indices == list(range(10))


def test_the_queue_bound_counts_every_job_in_flight(trained, tmp_path, setup):
    gate = Gate(setup.task)
    gate.open.clear()
    core = _core(trained, tmp_path, gate, jobs=2, state_limits=StateLimits(max_queued_jobs=3))
    try:
        jobs = [core.submit("e1", _job(setup, seed, rollouts=5)).job for seed in (1, 2, 3)]
        gate.wait_started(2)  # two running, one queued
        with pytest.raises(LearnerBusy, match="3 unfinished jobs"):
            core.submit("e1", _job(setup, 4))
        assert [core.status(j)["state"] for j in jobs] == ["running", "running", "queued"]
        gate.open.set()
        assert core.wait_idle(WAIT)
        assert [core.status(j)["state"] for j in jobs] == ["done"] * 3
        core.submit("e1", _job(setup, 4, rollouts=5))  # room again
        assert core.wait_idle(WAIT)
    finally:
        core.close()


def test_cancelling_one_of_several_running_jobs_leaves_the_others_as_alone(trained, tmp_path, setup):
    alone = _alone(trained, tmp_path, setup, (5, 7))

    gate = Gate(setup.task)
    gate.open.clear()
    core = _core(trained, tmp_path / "together", gate, jobs=3, job_runner="process")
    try:
        jobs = {seed: core.submit("e1", _job(setup, seed)).job for seed in (5, 6, 7)}
        gate.wait_started(3)
        assert core.cancel(jobs[6])["state"] == "running"  # ends after its iteration in flight
        gate.open.set()
        assert core.wait_idle(WAIT)
        cancelled = core.status(jobs[6])
        assert cancelled["state"] == "cancelled" and cancelled["rollouts"] == 5  # one iteration, recorded
        for seed in (5, 7):
            _same(_result(core, jobs[seed]), alone[seed])
    finally:
        core.close()


def test_a_job_whose_adaptation_process_dies_fails_alone(trained, tmp_path, setup):
    gate = Gate(setup.task)
    gate.open.clear()
    core = _core(trained, tmp_path, gate, jobs=2, job_runner="process")
    try:
        jobs = [core.submit("e1", _job(setup, seed)).job for seed in (5, 6)]
        gate.wait_started(2)
        victim = core._runners[0]._proc  # the first job thread's child
        os.kill(victim.pid, signal.SIGKILL)
        victim.join(WAIT)
        gate.open.set()
        assert core.wait_idle(WAIT)
        states = sorted((core.status(j)["state"], core.status(j)["error"] or "") for j in jobs)
        assert states[0][0] == "done" and states[1][0] == "failed"
        assert "adaptation process ended (exit code -9)" in states[1][1]
        again = core.submit("e1", _job(setup, 5)).job  # the slot has a new child
        assert core.wait_idle(WAIT) and core.status(again)["state"] == "done"
        assert core.health().problems() == []
    finally:
        core.close()


class SolvedOnThirdBatch:
    """The in-process task's rewards, with success only from the third batch on: iteration 0 (the
    mean alone, then the noisy roll-outs) fails, so the policy is updated once before the mean of
    iteration 1 succeeds and the job commits what it adapted."""

    def __init__(self, task):
        self.task, self.calls = task, 0

    def evaluate(self, trajectories, times, task_params=None):
        self.calls += 1
        batch = self.task.evaluate(trajectories, times, task_params)
        batch.success = np.full(len(trajectories), self.calls >= 3)
        return ExecutedBatch.of(batch, ["w0"] * len(trajectories))


def _committed(trained, tmp_path, setup, runner: str) -> tuple[dict, dict]:
    """Run one committing job on ``runner``; returns (its status, the committed version's weights)."""
    core = _core(trained, tmp_path / runner, Gate(setup.task), job_runner=runner)
    core.evaluator_for = lambda job: SolvedOnThirdBatch(setup.task)
    try:
        job = AdaptJob(setup.target, "viapoint", "point2d", setup.task_config, AdaptConfig(max_rollouts=20),
                       seed=5, commit=True, assimilate_steps=1)
        job_id = core.submit("e1", job).job
        assert core.wait_idle(WAIT)
        status = core.status(job_id)
        return status, core.skills["e1"].model
    finally:
        core.close()


def test_the_version_a_job_commits_holds_the_weights_it_adapted_on_either_runner(trained, tmp_path, setup):
    """What a committing job promises: the new version is the adapted model (trained on with the
    solution), whichever runner computed it; the process runner hands its child's weights back."""
    from acnmp_core.model.checkpoint import load_checkpoint

    on_thread, model = _committed(trained, tmp_path, setup, "thread")
    assert on_thread["state"] == "done" and on_thread["committed_version"] == 1, on_thread
    # the mean failed, the policy was updated, the updated mean succeeded: the weights changed
    assert [h["mean_success"] for h in on_thread["result"]["history"]] == [False, True]
    # the new version predicts the solution for the target (1 assimilation step from the adapted
    # weights), not what the version it adapted predicted
    solution = on_thread["result"]["trajectory"]
    before = load_checkpoint(trained / "skills" / "e1" / "model-v0.pt")[0]
    off = {name: float(np.abs(m.predict_query(setup.target.query(m)).mean - solution).max())
           for name, m in (("committed", model), ("version 0", before))}
    assert off["committed"] < 0.1 * off["version 0"], off
    in_process, child_model = _committed(trained, tmp_path, setup, "process")
    assert in_process["committed_version"] == 1
    np.testing.assert_array_equal(in_process["result"]["trajectory"], solution)
    weights, child_weights = model.state_dict(), child_model.state_dict()
    assert weights.keys() == child_weights.keys()
    for name in weights:  # bit-equal: the same adapted weights were assimilated
        assert torch.equal(weights[name], child_weights[name]), name
