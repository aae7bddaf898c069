"""Meta-World's reach, push and pick-place as task scenes and robot kinds: the task parameters put the
puck and the goal where asked, a position Meta-World cannot reset to is one line, the regions are the
stated ones, the scripted expert's path executed through the adapter (hand tracked, gripper passed
through) succeeds, failed demonstrations are dropped, and without Meta-World the error names the extra."""
from __future__ import annotations

import sys

import numpy as np
import pytest

pytest.importorskip("metaworld", reason="the metaworld extra is not installed (scripts/setup.sh installs it)")

from acnmp_core.errors import InputError  # noqa: E402
from acnmp_core.robots.registry import robot, robot_kinds  # noqa: E402
from acnmp_core.tasks.metaworld import demos as mw_demos  # noqa: E402
from acnmp_core.robots.metaworld import task_name  # noqa: E402
from acnmp_core.tasks.metaworld.scene import (EXTRAPOLATION_X, MIN_SEPARATION, N_STEPS, TASKS, make_env,  # noqa: E402
                                              set_task, task)


@pytest.mark.parametrize("kind, params", [
    ("metaworld-reach", [0.22, 0.85, 0.2]),
    ("metaworld-push", [0.05, 0.62, -0.21, 0.85]),
    ("metaworld-pick-place", [-0.05, 0.65, 0.23, 0.82, 0.25]),
])
def test_set_task_puts_the_puck_and_the_goal_where_asked_also_beyond_meta_worlds_range(kind, params):
    env = make_env(kind)
    try:
        env.reset(seed=0)
        obs = set_task(kind)(env, np.array(params))
        spec, u = task(kind), env.unwrapped
        goal = np.array(params[-3:] if len(params) in (3, 5) else params[2:])  # push: Meta-World sets z
        np.testing.assert_allclose(u._target_pos[:len(goal)], goal, atol=1e-9)
        np.testing.assert_allclose(obs[-3:][:len(goal)], goal, atol=1e-9)  # the observation shows it, not clipped
        if spec.env_name != "reach-v3":
            np.testing.assert_allclose(obs[4:6], params[:2], atol=1e-3)  # the puck, at rest
    finally:
        env.close()


def test_puck_and_goal_too_close_is_one_line_before_meta_world_loops_forever():
    with pytest.raises(InputError, match=f"apart in x, y; Meta-World needs at least {MIN_SEPARATION} m") as err:
        task("metaworld-push").check(np.array([0.0, 0.6, 0.05, 0.65]))
    assert "\n" not in str(err.value)
    with pytest.raises(InputError, match="expected 4 finite values"):
        task("metaworld-push").check(np.array([0.0, 0.6, 0.05]))
    with pytest.raises(InputError, match="expected one of"):
        task("metaworld-door")


@pytest.mark.parametrize("kind", list(TASKS))
def test_test_positions_lie_in_their_regions(kind):
    spec = task(kind)
    rng = np.random.default_rng(0)
    low, high = map(np.array, spec.training)
    for _ in range(20):
        inside = spec.sample_training(rng)
        assert np.all(inside >= low) and np.all(inside <= high) and spec.valid(inside)
        beyond = spec.sample_extrapolation(rng)
        assert EXTRAPOLATION_X[0] <= abs(beyond[spec.goal_x]) <= EXTRAPOLATION_X[1] and spec.valid(beyond)
        others = np.delete(np.arange(spec.n_params), spec.goal_x)
        assert np.all(beyond[others] >= low[others]) and np.all(beyond[others] <= high[others])


def test_the_kinds_are_built_in_and_the_experts_path_through_the_adapter_succeeds():
    """The adapter tracks the hand with kp = 1 / action_scale and passes the gripper command through:
    the pick-and-place expert's recorded path (hand positions and gripper commands) grasps, carries
    and places the puck when executed as a trajectory."""
    assert {"metaworld-reach", "metaworld-push", "metaworld-pick-place"} <= set(robot_kinds())
    kind, params = "metaworld-pick-place", np.array([0.0, 0.65, 0.05, 0.85, 0.2])
    expert = mw_demos.expert_episode(kind, params)
    assert expert.success and expert.trajectory.shape == (N_STEPS, 4)
    ev = robot(kind).make_evaluator(task_name(kind))
    try:
        batch = ev.evaluate(expert.trajectory[None], np.linspace(0.0, 1.0, N_STEPS), params)
        closed = expert.trajectory.copy()
        closed[:, 3] = -1.0  # the gripper never closes: nothing is carried
        open_hand = ev.evaluate(closed[None], np.linspace(0.0, 1.0, N_STEPS), params)
    finally:
        ev.close()
    assert batch.success.tolist() == [True] and batch.errors[0] <= task(kind).radius
    np.testing.assert_allclose(batch.states["actions"][0, :, 3], expert.trajectory[:, 3])
    assert open_hand.success.tolist() == [False]


def test_demonstrations_that_fail_are_not_used(monkeypatch):
    real = mw_demos.expert_episode
    calls = []

    def sometimes_failing(kind, params, steps=N_STEPS):
        ep = real(kind, params, steps)
        calls.append(ep)
        return ep if len(calls) != 2 else type(ep)(ep.params, ep.trajectory, ep.observations, ep.actions, False, None)

    monkeypatch.setattr(mw_demos, "expert_episode", sometimes_failing)
    mw_demos.expert_episodes.cache_clear()
    try:
        arrays = mw_demos.metaworld_demos("metaworld-reach", n=3, seed=5)
    finally:
        mw_demos.expert_episodes.cache_clear()
    assert len(calls) == 3 and arrays.values.shape == (2, N_STEPS, 4)
    np.testing.assert_array_equal(arrays.task_params, np.stack([calls[0].params, calls[2].params]))
    assert list(arrays.task_param_names) == ["goal_x", "goal_y", "goal_z"]


def test_without_meta_world_the_error_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "metaworld", None)  # an import of it fails
    with pytest.raises(InputError, match=r"metaworld extra: pip install 'acnmp\[metaworld\]'") as err:
        make_env("metaworld-push")
    assert "\n" not in str(err.value)
