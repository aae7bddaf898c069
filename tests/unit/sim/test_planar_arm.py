"""The PyBullet planar arm, the pushing task and the scripted expert."""

import numpy as np
import pybullet as p
import pytest

from acnmp_core.sim.kinematics import planar_fk, planar_ik
from acnmp_core.sim.planar_arm import PlanarArmSim, PushObject, default_geometry
from acnmp_core.tasks.push.task import PlanarPushTask
from acnmp_core.sim.urdf import ArmGeometry, planar_arm_urdf
from acnmp_core.rollout import RolloutEvaluator
from acnmp_core.tasks.push.demos import START_XY, expert_push_trajectory, push_demos, push_targets

T = np.linspace(0.0, 1.0, 300)


@pytest.fixture(scope="module")
def demos(tmp_path_factory):
    path = tmp_path_factory.mktemp("demos") / "push3.npz"
    d = push_demos(3, path=str(path))
    assert path.exists()
    again = push_demos(3, path=str(path))  # second call loads the cached file
    np.testing.assert_array_equal(again.values, d.values)
    return d


@pytest.fixture(scope="module")
def task():
    with PlanarPushTask(3, obj=PushObject(start_xy=START_XY)) as t:
        yield t


def test_task_is_a_rollout_evaluator(task):
    assert isinstance(task, RolloutEvaluator)


def test_demo_file_layout(demos):
    assert demos.times.shape == (11, 300) and demos.values.shape == (11, 300, 3)
    assert demos.task_params.shape == (11, 2)
    assert list(demos.roles).count("train") == 9
    tg = push_targets()
    train = demos.with_role("train").task_params
    extra = demos.with_role("extrapolation").task_params[0]
    inter = demos.with_role("interpolation").task_params[0]
    np.testing.assert_allclose(demos.task_params, tg.targets)
    # the extrapolation target lies outside the training targets' box, the interpolation one inside
    assert np.any((extra < train.min(axis=0)) | (extra > train.max(axis=0)))
    assert np.all((inter > train.min(axis=0)) & (inter < train.max(axis=0)))


def test_expert_demos_push_object_to_targets(task, demos):
    batch = task.evaluate(demos.values, T, demos.task_params[0])  # reward vs target 0 for all rows
    final = batch.states["object_xy"][:, -1]
    errors = np.linalg.norm(final - demos.task_params, axis=1)
    assert np.all(errors < 0.01), errors
    for i in range(len(demos)):  # each against its own target, through the task's reward
        b = task.evaluate(demos.values[i : i + 1], T, demos.task_params[i])
        assert b.success[0]
        assert b.errors[0] == pytest.approx(errors[i], abs=1e-12)
        # the default dense reward: minus the cylinder's distance to the target at every step, over T
        dist = np.linalg.norm(b.states["object_xy"][0] - demos.task_params[i], axis=1)
        np.testing.assert_allclose(b.rewards[0], -dist / T.size, atol=1e-12)


def test_final_reward_is_minus_the_final_error(demos):
    task = PlanarPushTask(reward="final")
    try:
        b = task.evaluate(demos.values[:2], T, demos.task_params[0])
    finally:
        task.close()
    final = np.linalg.norm(b.states["object_xy"][:, -1] - demos.task_params[0], axis=1)
    assert np.all(b.rewards[:, :-1] == 0)
    np.testing.assert_allclose(b.rewards[:, -1], -final, atol=1e-12)
    np.testing.assert_allclose(b.errors, final, atol=1e-12)
    with pytest.raises(ValueError, match="reward"):
        PlanarPushTask(reward="sparse")


def test_rollout_shapes_rewards_and_determinism(task, demos):
    traj = demos.values[:2]
    a = task.evaluate(traj, T, demos.task_params[0])
    b = task.evaluate(traj, T, demos.task_params[0])
    assert a.rewards.shape == (2, 300) and a.success.shape == (2,)
    assert np.all(a.rewards <= 0.0)  # minus a distance at every step
    assert a.states["joint_angles"].shape == (2, 300, 3)
    assert a.states["ee_xy"].shape == (2, 300, 2)
    assert a.states["object_xy"].shape == (2, 300, 2)
    for k in a.states:
        np.testing.assert_array_equal(a.states[k], b.states[k])
    np.testing.assert_array_equal(a.rewards, b.rewards)
    # a fresh simulator (its own physics client) reproduces the roll-out exactly
    with PlanarPushTask(3, obj=PushObject(start_xy=START_XY)) as other:
        assert other.sim.client_id != task.sim.client_id
        c = other.evaluate(traj, T, demos.task_params[0])
    np.testing.assert_array_equal(a.states["object_xy"], c.states["object_xy"])


def test_object_noise_is_seeded():
    traj = np.zeros((50, 3))
    runs = []
    for _ in range(2):
        with PlanarArmSim(object_noise=0.01, seed=5) as sim:
            runs.append(sim.rollout(traj)["object_start"])
    np.testing.assert_array_equal(runs[0], runs[1])
    assert not np.allclose(runs[0], START_XY)


def test_tracking_and_forward_kinematics(task, demos):
    b = task.evaluate(demos.values[3:4], T, demos.task_params[3])
    q = b.states["joint_angles"][0]
    assert np.abs(q - demos.values[3]).max() < 0.06  # position control tracks the plan
    np.testing.assert_allclose(b.states["ee_xy"][0], planar_fk(q, task.sim.geometry.link_lengths)[:, :2])
    sim = task.sim
    sim.reset([0.3, -0.5, 0.8])
    np.testing.assert_allclose(sim.ee_pose_from_sim(), planar_fk([0.3, -0.5, 0.8], sim.geometry.link_lengths),
                               atol=1e-6)


def test_targets_past_joint_limits_are_clipped(task):
    lim = np.asarray(task.sim.geometry.joint_limits)
    traj = np.zeros((60, 3))
    traj[:, 1] = np.linspace(0.0, 4.0, 60)  # joint 2 asked well past its upper limit
    b = task.evaluate(traj[None], T[:60], [0.5, 0.0])
    q = b.states["joint_angles"][0]
    assert q[:, 1].max() <= lim[1, 1] + 0.05  # clipped target; only a small dynamic overshoot
    assert q[-1, 1] == pytest.approx(lim[1, 1], abs=0.01)


def test_bad_inputs_raise_value_error(task):
    good = np.zeros((1, 20, 3))
    t = T[:20]
    with pytest.raises(ValueError, match="trajectories"):
        task.evaluate(np.zeros((1, 20, 4)), t, [0.4, 0.0])
    bad = good.copy()
    bad[0, 5, 1] = np.nan
    with pytest.raises(ValueError, match="trajectories"):
        task.evaluate(bad, t, [0.4, 0.0])
    with pytest.raises(ValueError, match="trajectories"):
        task.evaluate(np.zeros((20, 3)), t, [0.4, 0.0])
    with pytest.raises(ValueError, match="times"):
        task.evaluate(good, T[:10], [0.4, 0.0])
    with pytest.raises(ValueError, match="task_params"):
        task.evaluate(good, t, [0.4])
    with pytest.raises(ValueError, match="task_params"):
        task.evaluate(good, t, None)
    with pytest.raises(ValueError, match="trajectory"):
        task.sim.rollout(np.zeros((5, 2)))
    # the task still works after rejecting bad input
    assert task.evaluate(good, t, [0.4, 0.0]).rewards.shape == (1, 20)


def test_geometry_validation_and_urdf():
    with pytest.raises(ValueError, match="link_lengths"):
        ArmGeometry(link_lengths=(0.3, -0.1), joint_limits=((-1, 1), (-1, 1)))
    with pytest.raises(ValueError, match="joint_limits"):
        ArmGeometry(link_lengths=(0.3, 0.2), joint_limits=((-1, 1),))
    with pytest.raises(ValueError, match="joint_limits"):
        ArmGeometry(link_lengths=(0.3,), joint_limits=((1, -1),))
    g = default_geometry(5, link_lengths=(0.2, 0.15, 0.1, 0.1, 0.05))
    text = planar_arm_urdf(g)
    assert text.count('type="revolute"') == 5 and 'name="ee"' in text


def test_four_dof_arm_and_expert():
    geom = default_geometry(4)
    target = push_targets().targets[4]
    traj = expert_push_trajectory(target, geometry=geom, obj=PushObject(start_xy=START_XY))
    assert traj.shape == (300, 4)
    with PlanarPushTask(4, obj=PushObject(start_xy=START_XY)) as task4:
        assert p.getNumJoints(task4.sim.arm, physicsClientId=task4.sim.client_id) == 5
        b = task4.evaluate(traj[None], T, target)
    assert b.success[0], b.rewards[0, -1]


def test_ik_reaches_pose():
    g = default_geometry(3)
    pose = np.array([0.45, 0.1, 0.5])
    q = planar_ik(pose, np.array([-0.5, 1.0, -0.5]), g.link_lengths, g.joint_limits)
    np.testing.assert_allclose(planar_fk(q, g.link_lengths), pose, atol=1e-5)


def test_closed_task_refuses_work():
    t = PlanarPushTask(3)
    t.close()
    t.close()  # idempotent
    with pytest.raises(RuntimeError, match="closed"):
        t.evaluate(np.zeros((1, 5, 3)), T[:5], [0.4, 0.0])
