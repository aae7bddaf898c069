"""One bad worker never fails the batch (issue 66): beside two healthy workers, a worker answering
NaN, inf, -1e308, the wrong shape, another chunk's reply, too slowly, errors every time, or refusing
a request the others run is excluded and named, its roll-outs come from the healthy workers (equal
to the task run in-process), and the learner's other jobs avoid it; a request every worker refuses
is the request's fault (ValueError); with no healthy worker left the batch fails naming each
excluded one. Real zenoh sessions on loopback, the workers' queryables in this process
(benchmarks/performance/evil_workers.py)."""
from __future__ import annotations

import numpy as np
import pytest

from acnmp_core.experiments.viapoint import make_setup
from benchmarks.performance.evil_workers import MODES, serve_evil
from services.transport import Keyspace, declare_rpc, free_port, loopback_endpoint, open_session
from services.worker.core import Worker
from services.worker.exclusion import WorkerExclusions
from services.worker.remote import RemoteEvaluator

NS = "badworkers"
KEYS = Keyspace(NS)
#: What a refusal's reason names, per mode (the rest: the mode's own words).
NAMED = {"nan": "non_finite", "inf": "non_finite", "huge": "rewards: a value of magnitude 1e+308",
         "shape": "rewards of shape", "stale": "a reply for another chunk", "slow": "too slow: roll-outs",
         "failing": "failed 2 times", "refusing": "refused roll-outs"}


@pytest.fixture(scope="module")
def setup():
    return make_setup()


@pytest.fixture(scope="module")
def pool():
    """A learner-side session and two healthy point2d workers (w0, w1), each on its own session."""
    ep = loopback_endpoint(free_port())
    with open_session("peer", [ep]) as learner, open_session("peer", connect=[ep]) as workers:
        served = []
        for wid in ("w0", "w1"):
            worker = Worker("point2d", wid)
            served.append(declare_rpc(workers, KEYS.worker_rollout("point2d", wid),
                                      lambda req, _q, w=worker: w.handle(req), workers=1))
            served.append(workers.liveliness().declare_token(KEYS.worker_token("point2d", wid)))
        yield learner, workers, ep
        for item in served:
            (item.close if hasattr(item, "close") else item.undeclare)()


def _evaluator(session, setup, exclusions=None, **kwargs) -> RemoteEvaluator:
    # slow: 0.5 s at the least (the default 2 s), still far beyond the healthy workers' milliseconds
    return RemoteEvaluator(session, KEYS, "point2d", "viapoint", setup.task_config, timeout=20.0,
                           discover_timeout=3.0, exclusions=exclusions, slow_min_s=0.5, **kwargs)


def _trajectories(setup, b: int = 6) -> np.ndarray:
    t = setup.target.query_times
    line = np.stack([t, np.sin(np.pi * t)], axis=1)  # a smooth path over the task's time range
    return line[None] + np.random.default_rng(0).normal(scale=0.05, size=(b, len(t), 2))


def _wait_workers(ev: RemoteEvaluator, n: int) -> None:
    import time

    deadline = time.monotonic() + 10
    while len(ev.workers()) < n:
        assert time.monotonic() < deadline, ev.workers()
        time.sleep(0.02)


@pytest.mark.parametrize("mode", MODES)
def test_a_bad_worker_is_excluded_named_and_its_rollouts_come_from_healthy_ones(pool, setup, mode):
    learner, workers, _ = pool
    evil, rpc, token = serve_evil(workers, KEYS, mode, "point2d", f"evil-{mode}", slow_s=60.0)
    try:
        exclusions = WorkerExclusions()
        ev = _evaluator(learner, setup, exclusions)
        _wait_workers(ev, 3)
        trajs = _trajectories(setup)  # 6 roll-outs: a chunk for each of the 3 workers
        for _ in range(2):  # the second batch goes to the healthy workers alone
            batch = ev.evaluate(trajs, setup.target.query_times)
            expected = setup.task.evaluate(trajs, setup.target.query_times)
            np.testing.assert_array_equal(batch.rewards, expected.rewards)
            assert set(batch.workers) <= {"w0", "w1"}
        assert evil.asked >= 1
        (excluded,) = ev.excluded
        assert excluded.worker == f"evil-{mode}" and NAMED[mode] in excluded.reason, excluded
        # another job of the learner avoids it while the healthy ones are live
        other = _evaluator(learner, setup, exclusions)
        asked = evil.asked
        assert set(other.evaluate(trajs, setup.target.query_times).workers) <= {"w0", "w1"}
        assert evil.asked == asked and other.excluded == []
    finally:
        evil.release.set()
        token.undeclare()
        rpc.close()


def test_a_request_every_worker_refuses_is_the_requests_fault_and_nobody_is_excluded(pool, setup):
    learner, _, _ = pool
    ev = _evaluator(learner, setup)
    _wait_workers(ev, 2)
    three_dims = np.concatenate([_trajectories(setup), np.zeros((6, len(setup.target.query_times), 1))], axis=2)
    with pytest.raises(ValueError, match="bad_request"):  # a point2d worker runs 2-D paths
        ev.evaluate(three_dims, setup.target.query_times)
    assert ev.excluded == []


def test_with_no_healthy_worker_left_the_batch_fails_naming_every_excluded_one(setup):
    ep = loopback_endpoint(free_port())
    with open_session("peer", [ep]) as learner, open_session("peer", connect=[ep]) as workers:
        served = [serve_evil(workers, KEYS, mode, "point2d", f"evil-{mode}") for mode in ("nan", "failing")]
        try:
            ev = RemoteEvaluator(learner, KEYS, "point2d", "viapoint", setup.task_config, discover_timeout=0.5)
            _wait_workers(ev, 2)
            with pytest.raises(RuntimeError, match="no healthy point2d worker left") as info:
                ev.evaluate(_trajectories(setup), setup.target.query_times)
            assert "evil-nan: answered" in str(info.value) and "evil-failing: failed 2 times" in str(info.value)
        finally:
            for _, rpc, token in served:
                token.undeclare()
                rpc.close()


def test_a_job_beside_a_bad_worker_completes_naming_it_in_its_status_and_events(pool, setup, tmp_path):
    """The learner's side: the job that met the bad worker is done, and its status, its record (what a
    restart reads) and its progress events name the worker and why."""
    from acnmp_core.adaptation.config import AdaptConfig
    from acnmp_core.jobs.adapt import AdaptJob
    from acnmp_core.model.cnmp import CNMPConfig
    from acnmp_core.model.training import TrainConfig
    from services.learner.core import LearnerCore, TrainSpec

    learner, workers, _ = pool
    evil, rpc, token = serve_evil(workers, KEYS, "huge", "point2d", "evil-job")
    events: list[dict] = []
    exclusions = WorkerExclusions()
    core = LearnerCore(tmp_path / "state", publish=events.append,
                       evaluator_for=lambda job: _evaluator(learner, setup, exclusions))
    try:
        core.train_skill("e1", TrainSpec(setup.demos, CNMPConfig(n_outputs=2, encoder_widths=(16,), decoder_widths=(16,)),
                                         TrainConfig(steps=20)))
        _wait_workers(_evaluator(learner, setup), 3)
        core.start()
        job = core.submit("e1", AdaptJob(setup.target, "viapoint", "point2d", setup.task_config,
                                         AdaptConfig(max_rollouts=12, noisy_per_iter=5, stop_on_success=False))).job
        assert core.wait_idle(120)
        status = core.status(job)
    finally:
        core.close()
        token.undeclare()
        rpc.close()
    assert status["state"] == "done", status["error"]
    (named,) = status["excluded_workers"]
    assert named["worker"] == "evil-job" and "1e+308" in named["reason"]
    progress = [ev for ev in events if ev["kind"] == "job_progress" and ev["job"] == job]
    assert progress[-1]["state"] == "done" and progress[-1]["excluded_workers"].startswith("evil-job: answered")
    assert {ev["worker"] for ev in events if ev["kind"] == "rollout"} <= {"w0", "w1"}
    again = LearnerCore(tmp_path / "state", evaluator_for=lambda job: None)
    try:
        assert again.status(job)["excluded_workers"] == status["excluded_workers"]
    finally:
        again.close()


def test_a_worker_lying_with_finite_numbers_is_found_by_a_cross_check_and_its_results_replaced(pool, setup):
    """Issue 73: a worker answering rewards of -1.0 (finite, the right shape, its own chunk's tag)
    passes every check of a reply; with cross-checks a second worker runs its chunk again, a third
    tells which of the two is right, the liar is excluded and named and the batch holds the healthy
    workers' results only (equal to the task run in-process). Without cross-checks it goes unseen."""
    learner, workers, _ = pool
    evil, rpc, token = serve_evil(workers, KEYS, "liar", "point2d", "evil-liar")
    try:
        trajs = _trajectories(setup)
        expected = setup.task.evaluate(trajs, setup.target.query_times)
        unseen = _evaluator(learner, setup)
        _wait_workers(unseen, 3)
        batch = unseen.evaluate(trajs, setup.target.query_times)
        assert "evil-liar" in batch.workers and unseen.excluded == [] and unseen.checks == 0
        assert not np.array_equal(batch.rewards, expected.rewards)  # its lie is in the batch

        ev = _evaluator(learner, setup, cross_check=1.0)
        batch = ev.evaluate(trajs, setup.target.query_times)
        np.testing.assert_array_equal(batch.rewards, expected.rewards)
        assert set(batch.workers) <= {"w0", "w1"}
        (excluded,) = ev.excluded
        assert excluded.worker == "evil-liar" and "disagree with" in excluded.reason, excluded
        assert ev.disagreements >= 1 and ev.checks == ev.chunks == 3 and ev.check_rollouts >= 6
    finally:
        token.undeclare()
        rpc.close()


def test_two_workers_that_disagree_with_no_third_are_both_excluded_and_a_single_one_is_never_checked(setup):
    """The batch never rests on one worker alone: with a liar and one healthy worker and no third to
    tell which is right, both are excluded and the batch fails naming both; a deployment of one
    worker checks nothing (there is no second to ask)."""
    ep = loopback_endpoint(free_port())
    with open_session("peer", [ep]) as learner, open_session("peer", connect=[ep]) as workers:
        worker = Worker("point2d", "w0")
        rpc0 = declare_rpc(workers, KEYS.worker_rollout("point2d", "w0"), lambda req, _q: worker.handle(req), workers=1)
        token0 = workers.liveliness().declare_token(KEYS.worker_token("point2d", "w0"))
        try:
            alone = RemoteEvaluator(learner, KEYS, "point2d", "viapoint", setup.task_config, discover_timeout=0.5,
                                    cross_check=1.0, check_success=True)
            _wait_workers(alone, 1)
            alone.evaluate(_trajectories(setup), setup.target.query_times)
            assert alone.checks == 0 and alone.chunks == 1 and alone.excluded == []
            evil, rpc, token = serve_evil(workers, KEYS, "liar", "point2d", "evil-liar")
            try:
                ev = RemoteEvaluator(learner, KEYS, "point2d", "viapoint", setup.task_config, discover_timeout=0.5,
                                     cross_check=1.0)
                _wait_workers(ev, 2)
                with pytest.raises(RuntimeError, match="no healthy point2d worker left") as info:
                    ev.evaluate(_trajectories(setup), setup.target.query_times)
                assert {e.worker for e in ev.excluded} == {"w0", "evil-liar"}
                assert "no third worker to tell which is right" in str(info.value)
            finally:
                token.undeclare()
                rpc.close()
        finally:
            token0.undeclare()
            rpc0.close()
