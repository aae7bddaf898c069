"""The PyBullet pouring rig, the pouring task and the scripted expert's demonstrations (E6)."""
import numpy as np
import pytest

from acnmp_core.robots.pour import PourConfig, PourTask
from acnmp_core.rollout import RolloutEvaluator
from acnmp_core.tasks.pour_demos import (DEMO_ANGLES_DEG, N_STEPS, demo_weights_g, expert_pour_trajectory,
                                         pour_demos)

T = np.linspace(0.0, 1.0, N_STEPS)
LIGHT = 650.0  # the lightest demonstration: 23 marbles, the cheapest roll-outs


@pytest.fixture(scope="module")
def task():
    with PourTask(max_worlds=2) as t:
        yield t


@pytest.fixture(scope="module")
def demos(tmp_path_factory):
    path = tmp_path_factory.mktemp("demos") / "pour.npz"
    d = pour_demos(str(path))
    assert path.exists()
    again = pour_demos(str(path))  # the second call loads the cached file
    np.testing.assert_array_equal(again.task_params, d.task_params)
    return d


def pour(task, angle_deg, weight=LIGHT, target=0.0, **phases):
    return task.evaluate(expert_pour_trajectory(angle_deg, **phases)[None], T, [weight, target])


def test_task_is_a_rollout_evaluator(task):
    assert isinstance(task, RolloutEvaluator)


def test_marble_count_follows_the_weight(task):
    cfg = task.config
    m, tare = cfg.marbles.mass_g, cfg.tare_g
    assert cfg.n_marbles(tare) == 0
    assert cfg.n_marbles(650) == round((650 - tare) / m)
    assert cfg.n_marbles(1400) == round((1400 - tare) / m)
    assert cfg.n_marbles(tare + 2.5 * m) == 3  # half a marble rounds up
    sim = task.world(LIGHT)
    assert sim.n_marbles == cfg.n_marbles(LIGHT)
    assert sim.marble_positions().shape == (sim.n_marbles, 3)
    assert sim.initial_weight_g == pytest.approx(LIGHT)


def test_no_tilt_pours_nothing(task):
    batch = task.evaluate(np.zeros((1, N_STEPS, 1)), T, [LIGHT, 100.0])
    assert batch.states["poured_g"][0] == 0.0
    assert np.all(batch.states["poured_g_t"] == 0.0)
    assert batch.errors[0] == 100.0 and not batch.success[0]
    assert batch.rewards[0, -1] == -100.0 and np.all(batch.rewards[0, :-1] == 0.0)
    # every marble is still in the cup, near where it settled
    xyz = batch.states["marble_xyz"][0]
    assert np.abs(xyz[-1] - xyz[0]).max() < 0.01


def test_a_full_tilt_empties_the_cup_a_small_tilt_pours_nothing(task):
    load = LIGHT - task.config.tare_g
    small = pour(task, 30.0)
    full = pour(task, 170.0)
    assert small.states["poured_g"][0] == 0.0
    assert full.states["poured_g"][0] == load  # every marble lands in the receiving cup
    assert np.all(np.diff(full.states["poured_g_t"][0]) >= 0)  # nothing bounces back out
    # the demonstrations' 85-95 deg pour part of the load
    mid = pour(task, 90.0).states["poured_g"][0]
    assert 0.0 < mid < load


def test_same_trajectory_same_result(task):
    traj = np.stack([expert_pour_trajectory(92.0), expert_pour_trajectory(92.0)])
    a = task.evaluate(traj, T, [LIGHT, 200.0])
    pour(task, 150.0, weight=1000.0)  # another world and another motion in between
    pour(task, 120.0)
    b = task.evaluate(traj[:1], T, [LIGHT, 200.0])
    for k in ("wrist_angle", "poured_g_t", "marble_xyz", "poured_g"):
        np.testing.assert_array_equal(a.states[k][0], a.states[k][1])
        np.testing.assert_array_equal(a.states[k][0], b.states[k][0])
    with PourTask() as other:  # a fresh physics client
        c = other.evaluate(traj[:1], T, [LIGHT, 200.0])
    np.testing.assert_array_equal(a.states["marble_xyz"][0], c.states["marble_xyz"][0])
    assert a.errors[0] == abs(a.states["poured_g"][0] - 200.0)


def test_states_shapes_and_wrist_tracking(task):
    b = pour(task, 200.0)  # past the wrist's limit: clipped to pi
    cfg = task.config
    n = cfg.n_marbles(LIGHT)
    assert b.rewards.shape == (1, N_STEPS) and b.errors.shape == (1,)
    assert b.states["wrist_angle"].shape == (1, N_STEPS)
    assert b.states["poured_g_t"].shape == (1, N_STEPS)
    assert b.states["marble_xyz"].shape == (1, task.n_frames, n, 3)
    assert b.states["frame_steps"][0, -1] == N_STEPS
    assert b.states["wrist_angle"].max() <= cfg.wrist_limits[1] + 0.05
    assert b.states["wrist_angle"].max() > cfg.wrist_limits[1] - 0.05


def test_demos_cover_the_papers_range_and_reproduce(demos):
    assert demos.values.shape == (16, N_STEPS, 1) and demos.task_params.shape == (16, 2)
    weights, poured = demos.task_params.T
    np.testing.assert_array_equal(weights, demo_weights_g())
    assert weights.min() == 650.0 and weights.max() == 1200.0
    np.testing.assert_allclose(np.rad2deg(demos.values[:, :, 0].max(axis=1)), DEMO_ANGLES_DEG)
    assert np.all(poured > 0) and np.all(poured < weights - PourConfig().tare_g)
    rows = [0, 5, 15]
    with PourTask(max_worlds=1) as fresh:
        for i in rows:
            b = fresh.evaluate(demos.values[i : i + 1], demos.times[i], demos.task_params[i])
            assert b.errors[0] == 0.0 and b.success[0], (i, b.states["poured_g"][0], poured[i])


def test_bad_input_raises_naming_the_argument(task):
    good = expert_pour_trajectory(90.0)[None]
    tp = [LIGHT, 100.0]
    cases = [
        ("trajectories", dict(trajectories=np.zeros((1, N_STEPS, 2)))),
        ("trajectories", dict(trajectories=np.zeros((N_STEPS, 1)))),
        ("trajectories", dict(trajectories=np.where(np.arange(N_STEPS)[None, :, None] == 7, np.nan, good))),
        ("times", dict(times=T[:-1])),
        ("times", dict(times=T[::-1])),
        ("task_params", dict(task_params=None)),
        ("task_params", dict(task_params=[LIGHT])),
        ("task_params", dict(task_params=[np.nan, 100.0])),
        ("task_params", dict(task_params=[task.config.tare_g - 1.0, 100.0])),  # below the tare
        ("task_params", dict(task_params=[task.config.max_weight_g + 100.0, 100.0])),
        ("task_params", dict(task_params=[LIGHT, -5.0])),
    ]
    for name, override in cases:
        args = dict(trajectories=good, times=T, task_params=tp) | override
        with pytest.raises(ValueError, match=name):
            task.evaluate(**args)
    with pytest.raises(ValueError, match="n_steps"):
        expert_pour_trajectory(90.0, hold_steps=200)
    with pytest.raises(ValueError, match="angle_deg"):
        expert_pour_trajectory(float("nan"))
