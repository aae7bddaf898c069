"""Adaptation: reaching an extrapolated via-point, the ablations, assimilation, bad input."""
import copy

import numpy as np
import pytest

from acnmp_core.adaptation import AdaptConfig, adapt
from acnmp_core.data import Demonstration
from acnmp_core.exploration import SmoothNoise
from acnmp_core.experiments.viapoint import make_setup
from acnmp_core.rollout import RolloutBatch
from acnmp_core.training import TrainConfig, reproduction_error, train


@pytest.fixture(scope="module")
def setup():
    return make_setup("2d")


def test_lfd_alone_misses_the_extrapolated_viapoint(e1_model, setup):
    res = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, setup.task, AdaptConfig(mode="lfd_only"))
    assert res.rollouts == 1 and not res.success
    assert setup.task.errors(res.trajectory[None], res.times)[0] > 5 * setup.task.tolerance


def test_acnmp_reaches_the_viapoint_and_assimilation_keeps_old_demos(e1_model, setup):
    model = copy.deepcopy(e1_model)
    res = adapt(model, setup.demos, setup.target, setup.task, AdaptConfig(mode="acnmp", max_rollouts=90), seed=0)
    assert res.success and res.rollouts <= 90
    err = setup.task.errors(res.trajectory[None], res.times)[0]
    assert err <= setup.task.tolerance
    # the per-iteration log accounts for every roll-out
    assert res.history[-1].rollouts == res.rollouts
    # assimilation: the solution joins the demos; the old demos stay reproducible
    before = reproduction_error(model, setup.demos)
    demos2 = setup.demos.added(Demonstration(res.times, res.trajectory))
    train(model, demos2, TrainConfig(steps=800), seed=1, fit_normalization=False, progress=False)
    assert reproduction_error(model, setup.demos) < max(1.5 * before, 0.05 * setup.demos.extent())
    pred = model.predict(setup.target.obs_times, setup.target.obs_values, None, res.times)
    assert setup.task.errors(pred.mean[None], res.times)[0] < 3 * setup.task.tolerance
    # conditioned from another point of the assimilated solution, it reproduces the solution
    i = 70
    pred = model.predict([res.times[i]], res.trajectory[i:i + 1], None, res.times)
    assert np.sqrt(np.mean((pred.mean - res.trajectory) ** 2)) < 0.1 * setup.demos.extent()


def test_same_seed_same_adaptation(e1_model, setup):
    cfg = AdaptConfig(mode="rl_only", max_rollouts=12)
    a = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, setup.task, cfg, seed=5)
    b = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, setup.task, cfg, seed=5)
    np.testing.assert_array_equal(a.trajectory, b.trajectory)
    assert [h.mean_return for h in a.history] == [h.mean_return for h in b.history]


def test_budget_is_respected_and_every_rollout_goes_through_the_evaluator(e1_model, setup):
    seen = []

    class Counting:
        def evaluate(self, trajectories, times, task_params=None):
            seen.append(len(trajectories))
            out = setup.task.evaluate(trajectories, times, task_params)
            return RolloutBatch(out.rewards, np.zeros(len(trajectories), bool))  # never succeeds

    res = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, Counting(), AdaptConfig(max_rollouts=10))
    assert sum(seen) == res.rollouts == 10 and not res.success


def test_evaluator_returning_the_wrong_count_is_an_error(e1_model, setup):
    class Broken:
        def evaluate(self, trajectories, times, task_params=None):
            return RolloutBatch(np.zeros((1, len(times))), [False])

    with pytest.raises(ValueError, match="evaluator"):
        adapt(copy.deepcopy(e1_model), setup.demos, setup.target, Broken(), AdaptConfig(max_rollouts=6))


def test_config_validation():
    with pytest.raises(ValueError, match="mode"):
        AdaptConfig(mode="magic")
    with pytest.raises(ValueError, match="advantage"):
        AdaptConfig(advantage="nope")
    with pytest.raises(ValueError, match="max_rollouts"):
        AdaptConfig(max_rollouts=0)


def test_smooth_noise_is_smooth_with_the_requested_std():
    noise = SmoothNoise(200, n_knots=6)
    x = noise.sample(4000, 2, np.random.default_rng(0), std=[0.5, 2.0])
    assert x.shape == (4000, 200, 2)
    np.testing.assert_allclose(x.std(axis=0).mean(axis=0), [0.5, 2.0], rtol=0.05)
    # neighbouring steps are strongly correlated: smooth, not white
    assert np.corrcoef(x[:, 100, 0], x[:, 101, 0])[0, 1] > 0.99
