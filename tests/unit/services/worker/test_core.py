"""The worker without zenoh: the roll-out messages carry every RolloutBatch field, a batch names the
worker of each roll-out, and bad requests raise their wire codes."""
from __future__ import annotations

import numpy as np
import pytest

from acnmp_core.experiments.viapoint import make_setup
from acnmp_core.rollout import RolloutBatch
from services.transport import WireError, decode, encode, wire_error
from services.worker.core import (ExecutedBatch, Worker, batch_from_reply, disagreement, rollout_reply,
                                  rollout_request, take)


@pytest.fixture(scope="module")
def setup():
    return make_setup()


def test_a_reply_round_trips_the_batch_and_slices_keep_every_field(setup):
    t = setup.target.query_times
    trajs = np.random.default_rng(0).normal(size=(3, len(t), 2))
    batch = setup.task.evaluate(trajs, t)
    back = batch_from_reply(decode(encode(rollout_reply(batch, "w1"))))
    np.testing.assert_array_equal(back.rewards, batch.rewards)
    np.testing.assert_array_equal(back.success, batch.success)
    assert set(back.states) == set(batch.states)
    one = take(back, 1, 2)
    np.testing.assert_array_equal(one.rewards, batch.rewards[1:2])
    np.testing.assert_array_equal(one.states["path"], batch.states["path"][1:2])
    executed = ExecutedBatch.of(RolloutBatch.concat([take(back, 0, 1), one]), ["a", "b"])
    assert executed.workers == ("a", "b") and len(executed) == 2
    # joining executed batches (adapt() runs the LfD mean alone, then the noisy ones) keeps who ran what
    joined = RolloutBatch.concat([executed, ExecutedBatch.of(take(back, 2, 3), ["c"])])
    assert isinstance(joined, ExecutedBatch) and joined.workers == ("a", "b", "c")
    np.testing.assert_array_equal(joined.rewards, batch.rewards)
    assert type(RolloutBatch.concat([executed, take(back, 2, 3)])) is RolloutBatch  # mixed: the plain fields
    with pytest.raises(ValueError, match="workers"):
        ExecutedBatch.of(batch, ["a"])
    with pytest.raises(WireError) as info:
        batch_from_reply({"worker": "w1", "rewards": np.zeros((2, 3)), "success": np.zeros(5, bool)})
    assert info.value.code == "internal"


def test_the_worker_answers_in_process_and_refuses_by_code(setup):
    t = setup.target.query_times
    good = np.random.default_rng(1).normal(size=(2, len(t), 2))
    worker = Worker("point2d", "w0")
    try:
        reply = worker.handle(rollout_request("viapoint", setup.task_config, good, t))
        assert reply["worker"] == "w0" and worker.rollouts == 2
        np.testing.assert_array_equal(reply["rewards"], setup.task.evaluate(good, t).rewards)
        cases = {"unknown_task": {"task": "push"}, "bad_request": {"task_config": {"t_v": 0.5}},
                 "bad_shape": {"times": t[:-1]}}
        for code, change in cases.items():
            with pytest.raises(Exception) as info:
                worker.handle({**rollout_request("viapoint", setup.task_config, good, t), **change})
            assert wire_error(info.value).code == code, (code, info.value)
    finally:
        worker.close()
    with pytest.raises(ValueError, match="ur11"):
        Worker("ur11", "w0")


def test_two_runs_of_the_same_rollouts_agree_unless_a_number_differs_beyond_the_simulators_determinism():
    """Issue 73: what a cross-check compares (services/worker/remote.py)."""
    rng = np.random.default_rng(0)
    rewards = rng.normal(size=(3, 5))
    states = {"xy": rng.normal(size=(3, 5, 2)), "contact": np.array([[0, 1]] * 3)}
    honest = RolloutBatch(rewards, np.array([True, False, False]), states, np.array([0.01, 0.2, 0.3]))
    again = RolloutBatch(rewards * (1 + 1e-12), honest.success, {k: v.copy() for k, v in states.items()}, honest.errors)
    assert disagreement(honest, again) is None
    liar = RolloutBatch(np.full((3, 5), -1.0), honest.success, states, honest.errors)
    assert disagreement(honest, liar).startswith("return ") and "-5 (roll-out 0)" in disagreement(honest, liar)
    assert disagreement(honest, RolloutBatch(rewards, ~honest.success, states, honest.errors)) == \
        "success True against False (roll-out 0)"
    assert disagreement(honest, RolloutBatch(rewards, honest.success, states, honest.errors + 0.1)) == "errors differ"
    moved = {**states, "xy": states["xy"] + 1e-3}
    assert disagreement(honest, RolloutBatch(rewards, honest.success, moved, honest.errors)) == "states['xy'] differ"
    assert disagreement(honest, RolloutBatch(rewards[:2], honest.success[:2])) == "3 roll-outs against 2"
