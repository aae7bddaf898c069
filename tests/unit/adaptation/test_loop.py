"""Adaptation: reaching an extrapolated via-point, credit assignment, the authors' mode, assimilation,
determinism, the budget and bad input; the paper's method on the paper's CNMP (``e1_model``), and what
the default changes (the mean executed first)."""
import copy

import numpy as np
import pytest

from acnmp_core.adaptation.loop import adapt
from acnmp_core.adaptation.assimilation import AssimilationConfig, assimilate
from acnmp_core.adaptation.config import AdaptConfig
from acnmp_core.adaptation.credit import per_step_advantages
from acnmp_core.adaptation.exploration import CubicNoise, DemoNoise, SmoothNoise
from acnmp_core.data.demos import Demonstration
from acnmp_core.experiments.viapoint import make_setup, trajectory_metrics
from acnmp_core.model.training import reproduction_error
from acnmp_core.rollout import RolloutBatch


@pytest.fixture(scope="module")
def setup():
    return make_setup("2d")


@pytest.fixture(scope="module")
def solved(e1_model, setup):
    """E1 seed 0 adapted with the paper's method: (model, result)."""
    model = copy.deepcopy(e1_model)
    return model, adapt(model, setup.demos, setup.target, setup.task, AdaptConfig.paper(max_rollouts=60), seed=0)


def test_lfd_alone_misses_the_extrapolated_viapoint(e1_model, setup):
    res = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, setup.task, AdaptConfig.paper(mode="lfd_only"))
    assert res.rollouts == 1 and not res.success
    assert trajectory_metrics(setup, res.trajectory)["viapoint_error"] > 5 * setup.task.tolerance[1]


def test_acnmp_passes_every_condition_and_keeps_the_shape(solved, setup):
    _, res = solved
    m = trajectory_metrics(setup, res.trajectory)
    assert res.success and res.solved_by == "mean" and m["success"] and res.rollouts <= 60
    assert m["endpoint_error"] <= 0.03 and m["shape_error"] <= 0.05
    # the per-iteration log accounts for every roll-out, each iteration the mean and 4 noisy ones
    assert res.history[-1].rollouts == res.rollouts == 5 * len(res.history)
    # exploration follows the remaining error and never falls below its floor
    stds = np.array([h.explore_std for h in res.history])
    errs = np.array([h.mean_error for h in res.history])
    assert np.all(stds <= stds[0] + 1e-12) and np.all(stds >= 0.3 * stds[0] - 1e-12)
    assert np.argmin(stds[:, 0]) == np.argmin(errs[:-1]) or stds[-1, 0] == pytest.approx(0.3 * stds[0, 0])


def test_assimilation_keeps_the_solution_and_the_old_demonstrations(e1_model, solved, setup):
    model, res = solved
    model = copy.deepcopy(model)
    before = reproduction_error(e1_model, setup.demos)  # the LfD model's
    demos, _ = assimilate(model, setup.demos, Demonstration(res.times, res.trajectory), AssimilationConfig(),
                          conditions=setup.target, seed=1)
    assert len(demos) == len(setup.demos) + 1
    # conditioned on the same points with no RL, the assimilated skill still solves the task ...
    t = setup.target
    after = trajectory_metrics(setup, model.predict(t.obs_times, t.obs_values, None, t.query_times).mean)
    assert after["success"]
    # ... and the old demonstrations reproduce about as before
    assert reproduction_error(model, setup.demos) <= 1.2 * before


def test_same_seed_same_adaptation(e1_model, setup):
    cfg = AdaptConfig.paper(mode="rl_only", max_rollouts=15)
    a = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, setup.task, cfg, seed=5)
    b = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, setup.task, cfg, seed=5)
    np.testing.assert_array_equal(a.trajectory, b.trajectory)
    assert [h.mean_return for h in a.history] == [h.mean_return for h in b.history]


def test_the_authors_reinforce_update_lowers_the_error(e1_model, setup):
    cfg = AdaptConfig.paper(advantage="reinforce", noisy_per_iter=1, sl_steps=20, sl_steps_reuse=5, max_reuse=10,
                      max_rollouts=30)
    res = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, setup.task, cfg, seed=0)
    assert res.rollouts == 30 and all(h.rollouts == 2 * (i + 1) for i, h in enumerate(res.history))
    errors = [h.mean_error for h in res.history]
    assert min(errors[-5:]) < errors[0]


def test_step_credit_touches_only_the_rewarded_steps():
    rewards = np.zeros((3, 6))
    rewards[:, 2] = [-1.0, -0.5, -2.0]  # noisy 1 better than the mean at step 2, noisy 2 worse
    rows, adv = per_step_advantages(rewards, "awr", 0.1, "step")
    assert list(rows) == [0, 1, 2]
    assert np.all(adv[:, [0, 1, 3, 4, 5]] == 0) and adv[1, 2] > 0.95 and np.all(adv >= 0)
    rows, adv = per_step_advantages(rewards, "reinforce", credit="step")
    assert list(rows) == [1, 2] and adv[0, 2] > 0 > adv[1, 2] and np.all(adv[:, 3:] == 0)
    assert adv.std() == pytest.approx(1.0)


def test_future_credit_gives_earlier_steps_the_later_rewards():
    rewards = np.zeros((3, 6))
    rewards[:, -1] = [-1.0, -0.5, -2.0]  # only the end is rewarded, as in a push
    _, step_adv = per_step_advantages(rewards, "awr", 0.1, "step")
    _, future_adv = per_step_advantages(rewards, "awr", 0.1, "future")
    assert np.all(step_adv[:, :-1] == 0)
    assert np.all(future_adv[1] > 0.95)  # the better roll-out is the target at every step
    assert per_step_advantages(np.zeros((3, 6)), "awr", 0.1, "future") is None  # nothing to learn
    with pytest.raises(ValueError, match="credit"):
        per_step_advantages(rewards, "awr", 0.1, "later")


def test_episode_credit_gives_every_step_the_whole_return():
    rewards = np.zeros((3, 6))
    rewards[:, 1] = [-1.0, -0.2, -2.0]
    rewards[:, 4] = [-1.0, -1.5, -0.5]  # noisy 1: better at step 1, worse at step 4; returns -2, -1.7, -2.5
    _, adv = per_step_advantages(rewards, "awr", 0.1, "episode")
    assert np.all(adv == adv[:, :1])  # one weight per roll-out, at every step
    assert adv[1, 0] > adv[0, 0] > adv[2, 0]  # ordered by the returns
    _, adv = per_step_advantages(rewards, "reinforce", credit="episode")
    assert np.all(adv == adv[:, :1]) and adv[0, 0] > 0


def test_demo_noise_moves_the_outputs_as_the_demonstrations_differ():
    rng = np.random.default_rng(0)
    t = np.linspace(0, 1, 50)
    demos = np.stack([np.stack([np.sin(t) * a, np.cos(t) * a, np.full(50, 3.0)], axis=1) for a in (1.0, 2.0, 4.0)])
    noise = DemoNoise(demos)
    x = noise.sample(5000, 3, rng, std=0.5)
    assert x.shape == (5000, 50, 3)
    np.testing.assert_array_equal(x[..., 2], 0.0)  # an output the demonstrations never vary stays put
    dev = (demos - demos.mean(0)).reshape(3, -1).T  # (T*D, N)
    flat = x.reshape(5000, -1).T
    resid = flat - dev @ np.linalg.lstsq(dev, flat, rcond=None)[0]
    assert np.abs(resid).max() < 1e-9 * np.abs(flat).max()  # every draw lies in the demonstrations' span
    assert np.sqrt((x ** 2).mean()) == pytest.approx(0.5, rel=0.05)  # the std is its root mean square
    with pytest.raises(ValueError, match="at least 2"):
        DemoNoise(demos[:1])
    with pytest.raises(ValueError, match="all the same"):
        DemoNoise(np.stack([demos[0], demos[0]]))
    with pytest.raises(ValueError, match="n_dims"):
        noise.sample(1, 2, rng)


def test_demo_noise_option_perturbs_only_in_the_demonstrations_span(e1_model, setup):
    """noise="demos": every noisy roll-out differs from its mean by a combination of the
    demonstrations' deviations from their mean (in raw units too: the normalisation is affine)."""
    seen = []
    adapt(copy.deepcopy(e1_model), setup.demos, setup.target, setup.task,
          AdaptConfig.paper(max_rollouts=10, noise="demos", stop_on_success=False), seed=0,
          on_iteration=lambda log, trajs, batch: seen.append(trajs[1:] - trajs[:1]))
    q = setup.target.query_times
    demos = np.stack([np.stack([np.interp(q, (d.times - d.times[0]) / (d.times[-1] - d.times[0]) * (q[-1] - q[0]) + q[0],
                                          d.values[:, j]) for j in range(d.values.shape[1])], axis=1)
                      for d in setup.demos.demos])
    dev = (demos - demos.mean(0)).reshape(len(demos), -1).T
    flat = np.concatenate([d.reshape(len(d), -1) for d in seen]).T
    assert flat.shape[1] == 8 and np.abs(flat).max() > 0
    resid = flat - dev @ np.linalg.lstsq(dev, flat, rcond=None)[0]
    assert np.abs(resid).max() < 1e-4 * np.abs(flat).max()


def test_a_task_with_dynamics_is_solved_through_future_credit(e1_model, setup):
    """The reward arrives at the last step but is decided at step 25 (a 'push'): with the evaluator's
    credit = "future" the adaptation moves step 25 and succeeds; credited per step it cannot."""

    class Delayed:
        def __init__(self, credit):
            self.credit = credit

        def evaluate(self, trajectories, times, task_params=None):
            err = np.linalg.norm(trajectories[:, 25] - setup.target.obs_values[1], axis=1)
            rewards = np.zeros(trajectories.shape[:2])
            rewards[:, -1] = -err
            return RolloutBatch(rewards, err <= 0.03, errors=err)

    cfg = AdaptConfig.paper(max_rollouts=60)  # "future" succeeds within about 35; "step" stays far off
    good = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, Delayed("future"), cfg, seed=0)
    bad = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, Delayed("step"), cfg, seed=0)
    assert good.success and not bad.success


def test_budget_is_respected_and_every_rollout_goes_through_the_evaluator(e1_model, setup):
    seen = []

    class Counting:
        def evaluate(self, trajectories, times, task_params=None):
            seen.append(len(trajectories))
            out = setup.task.evaluate(trajectories, times, task_params)
            return RolloutBatch(out.rewards, np.zeros(len(trajectories), bool))  # never succeeds

    res = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, Counting(), AdaptConfig.paper(max_rollouts=12))
    # the LfD mean runs alone first (a solved target costs one roll-out), then mean + 4 noisy per iteration
    assert sum(seen) == res.rollouts == 12 and not res.success and seen == [1, 4, 5, 2]


def test_evaluator_returning_the_wrong_count_is_an_error(e1_model, setup):
    class Broken:
        def evaluate(self, trajectories, times, task_params=None):
            return RolloutBatch(np.zeros((1, len(times))), [False])

    with pytest.raises(ValueError, match="evaluator"):
        adapt(copy.deepcopy(e1_model), setup.demos, setup.target, Broken(), AdaptConfig.paper(max_rollouts=6))


@pytest.mark.parametrize("field, value", [("mode", "magic"), ("advantage", "nope"), ("max_rollouts", 0),
                                          ("lr", -1.0), ("explore_min", 1.5), ("sl_steps", -1),
                                          ("noisy_per_iter", True), ("stop_on_success", "yes"),
                                          ("explore_error_gain", 3.0), ("explore_cap", -0.1)])
def test_config_validation_names_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        AdaptConfig(**{field: value})


def test_config_round_trips_and_refuses_unknown_fields():
    cfg = AdaptConfig.paper(max_rollouts=7, n_knots=5)
    assert AdaptConfig.from_dict(cfg.to_dict()) == cfg
    with pytest.raises(ValueError, match="explore_from_return"):
        AdaptConfig.from_dict({"explore_from_return": 1.0})


def test_error_tied_exploration_is_min_of_gain_times_error_and_cap(e1_model, setup):
    """The authors' E4 rule: every output's std (raw units) is min(gain x last mean error, cap)."""
    cfg = AdaptConfig.paper(max_rollouts=12, noisy_per_iter=1, explore_error_gain=1.0, explore_cap=0.1)
    res = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, setup.task, cfg, seed=0)
    assert len(res.history) >= 3
    assert res.history[0].explore_std == pytest.approx([0.1] * len(res.history[0].explore_std))
    for before, log in zip(res.history, res.history[1:]):
        want = min(1.0 * before.mean_error, 0.1)
        assert log.explore_std == pytest.approx([want] * len(log.explore_std))
    assert any(h.mean_error < 0.1 for h in res.history[:-1])  # the error, not only the cap, set it


def test_smooth_noise_is_smooth_with_the_requested_std():
    noise = SmoothNoise(200, n_knots=6)
    x = noise.sample(4000, 2, np.random.default_rng(0), std=[0.5, 2.0])
    assert x.shape == (4000, 200, 2)
    np.testing.assert_allclose(x.std(axis=0).mean(axis=0), [0.5, 2.0], rtol=0.05)
    # neighbouring steps are strongly correlated: smooth, not white
    assert np.corrcoef(x[:, 100, 0], x[:, 101, 0])[0, 1] > 0.99


def test_cubic_noise_is_the_least_squares_cubic_through_its_samples():
    """The authors' E4 noise: each draw is a cubic in time (4 degrees of freedom, whatever the
    number of samples), the samples' least-squares cubic, scaled per dimension by ``std``."""
    noise = CubicNoise(300, n_knots=20)
    x = noise.sample(3, 2, np.random.default_rng(0), std=[0.05, 2.0])
    s = np.linspace(-1, 1, 300)
    for draw in x.transpose(0, 2, 1).reshape(-1, 300):
        np.testing.assert_allclose(np.polyval(np.polyfit(s, draw, 3), s), draw, atol=1e-9)
    knots = np.random.default_rng(0).standard_normal((3, 20, 2))  # the same samples, refitted by numpy
    c = np.linspace(-1, 1, 20)
    want = np.polyval(np.polyfit(c, knots[1, :, 1], 3), s) * 2.0
    np.testing.assert_allclose(x[1, :, 1], want, atol=1e-9)
    # a cubic through 20 samples keeps about 4/20 of their variance: the ends swing most
    st = noise.step_std()
    assert 0.38 < np.sqrt(np.mean(st ** 2)) < 0.47 and st[0] > 2 * st[150]
    with pytest.raises(ValueError, match="n_knots"):
        CubicNoise(300, n_knots=3)


def test_cubic_noise_option_changes_only_the_noise_and_defaults_off(e1_model, setup):
    """noise="cubic": every noisy roll-out deviates from its mean by a cubic in time; the default
    ("rbf") by the 20-knot noise, not a cubic; a cubic needs 4 samples."""
    assert AdaptConfig().noise == "rbf"

    def deviations(**kw) -> list[np.ndarray]:
        seen = []
        adapt(copy.deepcopy(e1_model), setup.demos, setup.target, setup.task,
              AdaptConfig.paper(max_rollouts=6, noisy_per_iter=1, n_knots=20, stop_on_success=False, **kw), seed=0,
              on_iteration=lambda log, trajs, batch: seen.append(trajs[1:] - trajs[:1]))
        return [d for d in seen if len(d)]

    def cubic_residual(d: np.ndarray) -> float:
        """Largest distance of one deviation (T, D) from its least-squares cubic, relative to it."""
        s = np.linspace(-1, 1, d.shape[0])
        fit = np.stack([np.polyval(np.polyfit(s, d[:, j], 3), s) for j in range(d.shape[1])], axis=1)
        return float(np.abs(fit - d).max() / np.abs(d).max())

    cubic, rbf = deviations(noise="cubic"), deviations()
    assert len(cubic) == len(rbf) == 3
    assert max(cubic_residual(d[0]) for d in cubic) < 1e-6  # the normalisation is per output: still a cubic
    assert min(cubic_residual(d[0]) for d in rbf) > 0.05
    with pytest.raises(ValueError, match="noise"):
        AdaptConfig(noise="white")
    with pytest.raises(ValueError, match="n_knots"):
        AdaptConfig(noise="cubic", n_knots=3)


def test_signal_tolerance_treats_jittered_equal_rewards_as_no_signal(e1_model, setup):
    """A simulator jitters an untouched object: rewards that should be equal differ by ~1e-7. With
    the default tolerance that is a signal (a policy step moves the mean); with a tolerance above
    it, it is none (no step: the mean stays where it was)."""

    class Jittered:
        """The E1 task's rewards replaced by tiny seeded noise for the first three iterations."""

        def __init__(self):
            self.calls, self.rng = 0, np.random.default_rng(0)

        def evaluate(self, trajectories, times, task_params=None):
            out = setup.task.evaluate(trajectories, times, task_params)
            self.calls += 1
            if self.calls <= 4:  # the first mean runs alone: one call more
                b = len(trajectories)
                return RolloutBatch(1e-7 * self.rng.standard_normal(out.rewards.shape), np.zeros(b, bool),
                                    out.states, np.ones(b))
            return out

    def means(**kw) -> list[np.ndarray]:
        """The mean roll-out of every iteration."""
        seen = []
        adapt(copy.deepcopy(e1_model), setup.demos, setup.target, Jittered(),
              AdaptConfig.paper(max_rollouts=12, noisy_per_iter=1, **kw), seed=0,
              on_iteration=lambda log, trajs, batch: seen.append(trajs[0].copy()))
        return seen

    exact, tolerant = means(), means(signal_tolerance=1e-5)
    assert not np.array_equal(exact[0], exact[1])  # the jitter taken for a signal: a policy step
    assert all(np.array_equal(tolerant[0], m) for m in tolerant[1:4])  # three blind iterations, no step
    assert not np.array_equal(tolerant[3], tolerant[4])  # the fourth has the task's rewards: a step
    assert per_step_advantages(1e-7 * np.eye(2, 6), "awr", 0.1, "step", tolerance=1e-5) is None


def test_solution_any_stops_at_the_first_noisy_roll_out_that_succeeds_and_returns_it(e1_model, setup):
    """A noisy roll-out that succeeds ends the adaptation with solution="any" and is the returned
    trajectory (the one executed, bit for bit); with the default "mean" the adaptation goes on."""

    class SecondNoisyOfThirdBatchSucceeds:
        """The E1 task, except that every success is dropped and row 2 of the 3rd call succeeds."""

        def __init__(self):
            self.calls, self.seen = 0, []

        def evaluate(self, trajectories, times, task_params=None):
            out = setup.task.evaluate(trajectories, times, task_params)
            self.calls += 1
            self.seen.append(np.array(trajectories))
            success = np.zeros(len(trajectories), bool)
            if self.calls == 3:  # the first mean alone, its noisy ones, then the 2nd iteration
                success[2] = True
            return RolloutBatch(out.rewards, success, out.states, out.errors)

    cfg = dict(max_rollouts=30)
    ev = SecondNoisyOfThirdBatchSucceeds()
    res = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, ev, AdaptConfig.paper(**cfg, solution="any"), seed=0)
    assert res.success and res.solved_by == "noisy" and ev.calls == 3 and res.solution_error is not None
    assert res.rollouts == 10 and not res.history[-1].mean_success
    np.testing.assert_array_equal(res.trajectory, ev.seen[2][2])
    mean_only = SecondNoisyOfThirdBatchSucceeds()
    res = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, mean_only, AdaptConfig.paper(**cfg), seed=0)
    assert not res.success and res.solved_by is None and res.rollouts == 30
    with pytest.raises(ValueError, match="solution"):
        AdaptConfig(solution="best")


def test_the_default_executes_each_mean_first_and_a_succeeding_mean_costs_one_episode(e1_model, setup):
    """The same adaptation with the default (each iteration's mean alone first) and the paper's
    accounting (the mean and the noisy roll-outs as one batch): the same trajectories until the
    mean succeeds, then the default stops after that mean alone, the paper's after the whole batch."""

    class MeanSucceedsAtThirdCall:
        def __init__(self):
            self.calls = []

        def evaluate(self, trajectories, times, task_params=None):
            n, t, _ = np.shape(trajectories)
            self.calls.append(np.array(trajectories))
            success = np.zeros(n, dtype=bool)
            success[0] = len(self.calls) == 3  # the first trajectory of the third call
            rewards = -np.abs(np.asarray(trajectories)).mean(axis=2)
            return RolloutBatch(rewards=rewards, success=success, errors=np.ones(n))

    default, paper = MeanSucceedsAtThirdCall(), MeanSucceedsAtThirdCall()
    a = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, default, AdaptConfig(max_rollouts=50), seed=0)
    b = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, paper, AdaptConfig.paper(max_rollouts=50), seed=0)
    assert [len(c) for c in default.calls] == [1, 4, 1] and [len(c) for c in paper.calls] == [1, 4, 5]
    assert (a.rollouts, b.rollouts) == (6, 10) and a.success and b.success
    for x, y in zip(default.calls[:2], paper.calls[:2]):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(default.calls[2][0], paper.calls[2][0])  # the same mean succeeded
    assert AdaptConfig().mean_first and not AdaptConfig.paper().mean_first
