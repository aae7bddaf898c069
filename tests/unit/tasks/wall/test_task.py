"""The wall-with-a-hole task (E3): geometry, reward signs, success, demonstrations, vectorisation."""
from __future__ import annotations


import numpy as np
import pytest

from acnmp_core.rollout import RolloutBatch, RolloutEvaluator
from acnmp_core.tasks.wall import task as W

# Hole centred at (5, 5), goal at (8, 5): a straight line y = 5 passes through the hole's centre.
OPEN = np.array([5.0, 5.0, 8.0, 5.0])
# Same goal, hole low at y_c = 2: the line y = 5 runs into the wall 2.5 above the hole's top edge.
CLOSED = np.array([5.0, 2.0, 8.0, 5.0])


def line(p0, p1, n=200):
    """(1, n, 2) straight path from p0 to p1."""
    s = np.linspace(0.0, 1.0, n)[:, None]
    return ((1 - s) * np.asarray(p0, float) + s * np.asarray(p1, float))[None]


def crossing_fraction(path, x_c):
    """Fraction of the duration elapsed when the path first reaches the wall's centre line."""
    return np.argmax(path[:, 0] >= x_c) / (len(path) - 1)


# --- reward sign conventions on hand-made paths ---------------------------------------------------


def test_path_through_hole_has_positive_margin_and_succeeds():
    path = line(W.START, OPEN[2:])
    r = W.wall_rewards(path, OPEN)
    s = W.wall_scores(path, OPEN)
    assert r.shape == (1, 200)
    assert s.min_margin[0] == pytest.approx(W.HOLE_WIDTH / 2)
    assert r[0, 0] == pytest.approx(0.0) and r[0, -1] == pytest.approx(0.0)
    assert r.sum() == pytest.approx(W.HOLE_WIDTH / 2)
    # The margin is paid at the step where the path is inside the wall.
    k = int(np.argmax(r[0]))
    assert abs(path[0, k, 0] - OPEN[0]) <= W.WALL_THICKNESS / 2 + 8.0 / 199
    assert W.wall_success(path, OPEN).tolist() == [True]
    assert W.wall_errors(path, OPEN)[0] == pytest.approx(0.0)


def test_path_into_wall_has_negative_margin_and_fails():
    path = line(W.START, CLOSED[2:])
    s = W.wall_scores(path, CLOSED)
    expected = W.HOLE_WIDTH / 2 - (5.0 - CLOSED[1])  # penetration depth 2.5 below the wall's surface
    assert s.min_margin[0] == pytest.approx(expected)
    assert W.wall_rewards(path, CLOSED).sum() == pytest.approx(expected)
    assert W.wall_success(path, CLOSED).tolist() == [False]
    assert W.wall_errors(path, CLOSED)[0] == pytest.approx(-expected)


def test_missing_the_goal_costs_twice_the_goal_error_and_fails():
    # Through the hole's centre, then on to a point 1.0 above the goal.
    path = np.array([[[0.0, 5.0], [6.0, 5.0], [8.0, 6.0]]])
    r = W.wall_rewards(path, OPEN)
    assert r[0, -1] == pytest.approx(-W.GOAL_WEIGHT * 1.0)
    assert W.wall_success(path, OPEN).tolist() == [False]
    assert W.wall_errors(path, OPEN)[0] == pytest.approx(1.0)


def test_start_error_is_paid_at_the_first_step():
    path = line((0.0, 5.5), OPEN[2:])
    r = W.wall_rewards(path, OPEN)
    assert r[0, 0] == pytest.approx(-0.5)
    assert W.wall_success(path, OPEN, start_tolerance=0.25).tolist() == [False]
    assert W.wall_success(path, OPEN, start_tolerance=0.6).tolist() == [True]


def test_jumping_over_the_wall_between_samples_is_not_a_success():
    # No sample lies inside the wall's x band [4.9, 5.1]; the segment from x=4 to x=6 crosses it.
    xs = np.array([0.0, 2.0, 4.0, 6.0, 8.0])
    path = np.stack([xs, np.full_like(xs, 5.0)], axis=1)[None]
    s = W.wall_scores(path, CLOSED)
    assert s.reaches_wall[0]
    assert s.min_margin[0] == pytest.approx(-2.5)
    assert W.wall_success(path, CLOSED).tolist() == [False]
    # The same sparse path through an open hole is a success: interpolation does not over-penalise.
    assert W.wall_success(path, OPEN).tolist() == [True]


def test_clipping_a_hole_edge_inside_the_band_is_detected():
    # Both samples of the crossing segment are outside the band; inside it y runs 5.4 -> 5.6,
    # so the path grazes the wall above the hole's top edge (5.5) by 0.1.
    path = np.array([[[0.0, 5.0], [4.5, 5.0], [5.5, 6.0], [8.0, 5.0]]])
    s = W.wall_scores(path, OPEN)
    assert s.min_margin[0] == pytest.approx(-0.1)
    assert W.wall_success(path, OPEN).tolist() == [False]


def test_vertical_segment_inside_the_wall_band():
    path = np.array([[[0.0, 5.0], [5.0, 5.0], [5.0, 7.0], [8.0, 5.0]]])
    assert W.wall_scores(path, OPEN).min_margin[0] == pytest.approx(0.5 - 2.0)


def test_path_that_never_reaches_the_wall_gets_no_margin_term():
    path = line(W.START, (3.0, 5.0))
    s = W.wall_scores(path, OPEN)
    assert not s.reaches_wall[0] and s.margin_step[0] == -1
    r = W.wall_rewards(path, OPEN)
    assert np.count_nonzero(r[0, 1:-1]) == 0
    assert r[0, -1] == pytest.approx(-2 * 5.0)
    assert W.wall_success(path, OPEN).tolist() == [False]


# --- environments -----------------------------------------------------------------------------------


def test_sampled_environments_respect_the_ranges():
    p = W.sample_environments(2000, np.random.default_rng(0))
    assert p.shape == (2000, 4)
    assert np.all((p[:, 0] >= 2) & (p[:, 0] <= 8))
    assert np.all((p[:, 1] >= 1) & (p[:, 1] <= 9))
    assert np.all((p[:, 2] >= p[:, 0] + 1.5) & (p[:, 2] <= 10))
    assert np.all((p[:, 3] >= 0) & (p[:, 3] <= 10))


def test_test_set_is_fixed_and_prefix_stable():
    a = W.test_environments()
    assert a.shape == (1000, 4)
    np.testing.assert_array_equal(a, W.test_environments())
    np.testing.assert_array_equal(a[:30], W.test_environments(30))
    assert not np.array_equal(a[:30], W.test_environments(30, seed=1))


# --- demonstrations ---------------------------------------------------------------------------------


def test_demonstrations_succeed_in_many_random_environments():
    rng = np.random.default_rng(1)
    times, values, params = W.make_demo_set(300, rng)
    assert times.shape == (300, 200) and values.shape == (300, 200, 2) and params.shape == (300, 4)
    np.testing.assert_allclose(values[:, 0], np.broadcast_to(W.START, (300, 2)), atol=1e-12)
    np.testing.assert_allclose(values[:, -1], params[:, 2:], atol=1e-12)
    assert W.wall_success(values, params).all()
    assert np.all(W.wall_scores(values, params).min_margin > 0.3)
    # Without variation the demonstration passes through the hole's centre.
    _, path = W.demonstrate(params[0])
    assert W.wall_scores(path[None], params[0]).min_margin[0] == pytest.approx(W.HOLE_WIDTH / 2)


def test_demonstrations_move_at_uniform_speed_and_are_not_time_aligned():
    times, values, params = W.make_demo_set(100, np.random.default_rng(2))
    steps = np.linalg.norm(np.diff(values, axis=1), axis=2)
    # Equal arc length per step; a chord is a little shorter than its arc where the path turns
    # sharply, so single steps may be a few per cent short, the typical step not.
    rel = np.abs(steps / steps.mean(axis=1, keepdims=True) - 1)
    assert np.median(rel) < 1e-3 and rel.max() < 0.08
    crossing = np.array([crossing_fraction(values[i], params[i, 0]) for i in range(100)])
    assert crossing.max() - crossing.min() > 0.3
    assert crossing.std() > 0.05


def test_random_variation_changes_the_demonstration_but_keeps_success():
    rng = np.random.default_rng(3)
    env = W.test_environments(1)[0]
    paths = np.stack([W.demonstrate(env, rng=rng)[1] for _ in range(10)])
    assert np.ptp(paths[:, 100, 1]) > 1e-3
    assert W.wall_success(paths, env).all()


def test_demo_set_loads_into_a_demoset():
    from acnmp_core.data.demos import DemoSet

    times, values, params = W.make_demo_set(4, np.random.default_rng(4), n_steps=50)
    demos = DemoSet.from_arrays(times, values, params)
    assert len(demos) == 4


# --- vectorisation and the evaluator ----------------------------------------------------------------


def _noisy_batch(n_envs=12, per_env=5, seed=5):
    rng = np.random.default_rng(seed)
    _, values, params = W.make_demo_set(n_envs, rng, n_steps=60)
    noise = rng.normal(0.0, 0.3, size=(n_envs, per_env, 60, 2))
    trajs = (values[:, None] + noise).reshape(-1, 60, 2)
    return trajs, np.repeat(params, per_env, axis=0), params


def test_vectorised_scores_equal_a_per_environment_loop():
    trajs, params_b, params = _noisy_batch()
    rewards, success, errors = (
        W.wall_rewards(trajs, params_b),
        W.wall_success(trajs, params_b),
        W.wall_errors(trajs, params_b),
    )
    assert 0 < success.sum() < len(success)  # the batch mixes successes and failures
    per_env = len(trajs) // len(params)
    for i, p in enumerate(params):
        sl = slice(i * per_env, (i + 1) * per_env)
        np.testing.assert_allclose(W.wall_rewards(trajs[sl], p), rewards[sl])
        np.testing.assert_array_equal(W.wall_success(trajs[sl], p), success[sl])
        np.testing.assert_allclose(W.wall_errors(trajs[sl], p), errors[sl])
        for j in range(sl.start, sl.stop):
            np.testing.assert_allclose(W.wall_rewards(trajs[j : j + 1], p)[0], rewards[j])


def test_wall_task_is_a_rollout_evaluator_and_batches_agree():
    task = W.WallTask()
    assert isinstance(task, RolloutEvaluator)
    trajs, params_b, params = _noisy_batch(n_envs=4, per_env=3, seed=6)
    times = np.linspace(0.0, 1.0, 60)
    batch = task.evaluate_batch(trajs, times, params_b)
    singles = RolloutBatch.concat(
        [task.evaluate(trajs[i * 3 : i * 3 + 3], times, p) for i, p in enumerate(params)]
    )
    np.testing.assert_allclose(batch.rewards, singles.rewards)
    np.testing.assert_array_equal(batch.success, singles.success)
    np.testing.assert_array_equal(batch.states["path"], trajs)
    np.testing.assert_allclose(batch.returns, W.wall_rewards(trajs, params_b).sum(axis=1))


def test_scoring_1000_environments_in_one_batch():
    """The demonstrations of the whole test set succeed when scored in one vectorised batch (its
    speed is measured by benchmarks/performance/bench_tasks.py)."""
    params = W.test_environments()
    _, values, _ = W.make_demo_set(1000, np.random.default_rng(7), task_params=params)
    batch = W.WallTask().evaluate_batch(values, np.linspace(0, 1, 200), params)
    assert batch.success.shape == (1000,) and batch.success.all()


# --- input validation -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "trajectories, task_params, name",
    [
        (np.zeros((2, 10, 3)), OPEN, "trajectories"),
        (np.zeros((10, 2)), OPEN, "trajectories"),
        (np.zeros((2, 1, 2)), OPEN, "trajectories"),
        (np.full((2, 10, 2), np.nan), OPEN, "trajectories"),
        (np.zeros((2, 10, 2)), OPEN[:3], "task_params"),
        (np.zeros((2, 10, 2)), np.zeros((3, 4)), "task_params"),
        (np.zeros((2, 10, 2)), [np.inf, 5, 8, 5], "task_params"),
        ("path", OPEN, "trajectories"),
    ],
)
def test_scoring_rejects_bad_inputs_naming_the_argument(trajectories, task_params, name):
    for fn in (W.wall_rewards, W.wall_success, W.wall_errors):
        with pytest.raises(ValueError, match=name):
            fn(trajectories, task_params)


def test_evaluator_and_generators_reject_bad_inputs():
    task = W.WallTask()
    traj = line(W.START, OPEN[2:], n=20)
    with pytest.raises(ValueError, match="times"):
        task.evaluate(traj, np.linspace(0, 1, 19), OPEN)
    with pytest.raises(ValueError, match="task_params"):
        task.evaluate(traj, np.linspace(0, 1, 20), None)
    with pytest.raises(ValueError, match="task_params"):
        task.evaluate(traj, np.linspace(0, 1, 20), np.zeros((1, 4)))
    with pytest.raises(ValueError, match="n"):
        W.sample_environments(0, np.random.default_rng(0))
    with pytest.raises(ValueError, match="rng"):
        W.sample_environments(3, 0)
    with pytest.raises(ValueError, match="task_params"):
        W.demonstrate([5.0, 5.0, 4.0, 5.0])  # goal before the wall
    with pytest.raises(ValueError, match="n_steps"):
        W.demonstrate(OPEN, n_steps=1)
    with pytest.raises(ValueError, match="task_params"):
        W.make_demo_set(2, np.random.default_rng(0), task_params=np.zeros((3, 4)))
