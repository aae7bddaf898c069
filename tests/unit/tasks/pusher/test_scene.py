"""The Pusher-v5 scene (issue 33): set_pusher_task places object and goal where asked; the scripted
expert's joint targets are smooth in time and in the task parameters, stay within the joint limits,
and, tracked by the fixed PD controller (PUSHER_KP / PUSHER_KD, torques clipped to 2), push the
object to within PUSHER_SUCCESS_M of the goal at three training-region positions."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco", reason="gymnasium[mujoco] is not installed (scripts/setup.sh installs it)")
gym = pytest.importorskip("gymnasium", reason="gymnasium[mujoco] is not installed (scripts/setup.sh installs it)")

from acnmp_core.tasks.pusher import scene  # noqa: E402

#: three training-region positions: two corners and the centre
PARAMS = [scene.TRAINING_REGION.params(0.31, -0.10, -5.0), scene.TRAINING_REGION.params(0.32, -0.075, 0.0),
          scene.TRAINING_REGION.params(0.33, -0.05, 5.0)]


def _run(env, q_targets: np.ndarray, params: np.ndarray, seed: int = 0) -> tuple[float, np.ndarray]:
    """One episode with the fixed PD controller: final object-goal distance (m), rewards (T,)."""
    env.reset(seed=seed)
    scene.set_pusher_task(env, params)
    data, rewards = env.unwrapped.data, []
    for target in q_targets:
        action = np.clip(scene.PUSHER_KP * (target - data.qpos[:7]) - scene.PUSHER_KD * data.qvel[:7], -2.0, 2.0)
        _, reward, _, _, _ = env.step(action)
        rewards.append(reward)
    u = env.unwrapped
    return float(np.linalg.norm(u.get_body_com("object")[:2] - u.get_body_com("goal")[:2])), np.asarray(rewards)


@pytest.fixture(scope="module")
def env():
    e = gym.make(scene.ENV_ID)
    yield e
    e.close()


def test_set_pusher_task_places_object_and_goal_in_world_metres_at_rest(env):
    env.reset(seed=3)
    params = np.array([0.30, -0.20, 0.40, -0.15])
    obs = scene.set_pusher_task(env, params)
    u = env.unwrapped
    np.testing.assert_allclose(u.get_body_com("object")[:2], params[:2], atol=1e-9)
    np.testing.assert_allclose(u.get_body_com("goal")[:2], params[2:], atol=1e-9)
    np.testing.assert_allclose(u.data.qvel[7:], 0.0)
    assert obs.shape == (23,)


def test_the_expert_succeeds_in_the_training_region_with_smooth_limited_targets(env):
    lo, hi = env.unwrapped.model.jnt_range[:7].T
    for params in PARAMS:
        q = scene.pusher_expert(params)
        assert q.shape == (scene.N_STEPS, 7) and np.all(np.isfinite(q))
        assert np.all(q >= lo - 1e-9) and np.all(q <= hi + 1e-9)
        assert np.abs(np.diff(q, axis=0)).max() < 0.25  # rad per 0.05 s step: no IK branch jump
        final, rewards = _run(env, q, params)
        assert final <= scene.PUSHER_SUCCESS_M, (params, final)
        assert rewards.shape == (scene.N_STEPS,)


def test_the_targets_vary_continuously_with_the_task_parameters():
    base = PARAMS[1]
    q0 = scene.pusher_expert(base)
    for delta in (np.array([0.002, 0.0, 0.002, 0.0]), np.array([0.0, 0.002, 0.0, 0.002]),
                  scene.TRAINING_REGION.params(0.32, -0.075, 0.5) - base):
        change = np.abs(scene.pusher_expert(base + delta) - q0).max()
        assert change < 0.05, (delta, change)  # a few mm or half a degree moves every target < 0.05 rad
