"""The UR10 pick-and-place simulator, its task and the scripted expert's demonstrations (E5)."""
import xml.etree.ElementTree as ET

import numpy as np
import pybullet as p
import pytest

from acnmp_core.robots.ur10 import START_POSE_DEG
from acnmp_core.robots.ur10_description import UR10_ARM_JOINTS, ur10_source_urdf
from acnmp_core.rollout import RolloutEvaluator
from acnmp_core.tasks.ur10_demos import TEST_HEIGHTS, TRAIN_HEIGHTS, expert_trajectory, ur10_demos
from acnmp_core.tasks.ur10_pick_place import N_STEPS, UR10PickPlaceTask, gripper_schedule, reward_steps

T = np.linspace(0.0, 1.0, N_STEPS)


@pytest.fixture(scope="module")
def task():
    with UR10PickPlaceTask() as t:
        yield t


@pytest.fixture(scope="module")
def demos(tmp_path_factory):
    path = tmp_path_factory.mktemp("demos") / "ur10.npz"
    d = ur10_demos(path=str(path))
    assert path.exists()
    again = ur10_demos(path=str(path))  # the second call reads the cached file
    np.testing.assert_array_equal(again.values, d.values)
    return d


def test_task_is_a_rollout_evaluator(task):
    assert isinstance(task, RolloutEvaluator)


def test_joint_limits_and_meshes_come_from_the_urdf(task):
    root = ET.parse(ur10_source_urdf()).getroot()
    joints = {j.get("name"): j for j in root.findall("joint")}  # not the transmissions' <joint>s
    want = np.array([[float(joints[n].find("limit").get(k)) for k in ("lower", "upper")] for n in UR10_ARM_JOINTS])
    vel = np.array([float(joints[n].find("limit").get("velocity")) for n in UR10_ARM_JOINTS])
    np.testing.assert_allclose(task.sim.limits, want)
    np.testing.assert_allclose(task.sim.velocity_limits, vel)
    assert task.sim.limits[2, 1] == pytest.approx(np.pi)  # the elbow's +-pi, not the others' +-2 pi
    files = [s[4].decode() for j in task.sim.arm_joints
             for s in p.getCollisionShapeData(task.sim.robot, j, physicsClientId=task.sim.client_id)]
    assert len(files) == 6 and all(f.endswith(".stl") and "example-robot-data" in f for f in files)
    # a target past a limit is clipped to it
    traj = np.tile(np.deg2rad(START_POSE_DEG), (3, 1))
    traj[:, 2] = 4.0
    assert task.sim.check_trajectory(traj)[0, 2] == pytest.approx(np.pi)


def test_demo_set_layout_and_expert(demos, task):
    assert demos.values.shape == (10, N_STEPS, 6) and demos.times.shape == (10, N_STEPS)
    np.testing.assert_allclose(demos.task_params, np.array(TRAIN_HEIGHTS + TEST_HEIGHTS))
    assert list(demos.roles) == ["train"] * 8 + ["extrapolation"] * 2
    np.testing.assert_allclose(demos.values[:, 0], np.tile(np.deg2rad(START_POSE_DEG), (10, 1)))
    # the expert stays below the URDF's joint velocity limits (the simulator does not enforce them)
    speed = np.abs(np.diff(demos.values, axis=1)).max(axis=(0, 1)) / task.sim.control_dt
    assert np.all(speed < 0.9 * task.sim.velocity_limits), speed


def test_every_demo_succeeds_in_physics(demos, task):
    for i in range(len(demos)):
        batch = task.evaluate(demos.values[i : i + 1], T, demos.task_params[i])
        assert batch.success[0], demos.task_params[i]
        assert batch.errors[0] < 0.005  # the executed TCP passes the grasp and avoidance points
        assert batch.returns[0] == pytest.approx(-batch.errors[0])
        assert not batch.states["obstacle_contact"][0].any()
        # reward only at the grasp and the crossing steps
        assert set(np.flatnonzero(batch.rewards[0])) <= set(reward_steps(T))


def test_reset_is_bit_exact(task, demos):
    traj = demos.values[5]
    a = task.evaluate(np.stack([traj, traj]), T, demos.task_params[5])
    task.evaluate(demos.values[:1], T, demos.task_params[0])  # other heights in between
    b = task.evaluate(traj[None], T, demos.task_params[5])
    for key in a.states:
        np.testing.assert_array_equal(a.states[key][0], a.states[key][1], err_msg=key)
        np.testing.assert_array_equal(a.states[key][0], b.states[key][0], err_msg=key)
    np.testing.assert_array_equal(a.rewards[0], b.rewards[0])
    with UR10PickPlaceTask() as fresh:  # another worker's simulator gives the same roll-out
        c = fresh.evaluate(traj[None], T, demos.task_params[5])
    for key in a.states:
        np.testing.assert_array_equal(a.states[key][0], c.states[key][0], err_msg=key)


def test_carrying_into_the_obstacle_fails_with_a_worse_reward(task):
    heights = (0.06, 0.08)
    good = expert_trajectory(heights, sim=task.sim)
    low = expert_trajectory((0.06, 0.02), sim=task.sim)  # carries 6 cm too low for this obstacle
    batch = task.evaluate(np.stack([good, low]), T, heights)
    assert batch.success.tolist() == [True, False]
    assert batch.states["obstacle_contact"][1].any()
    assert batch.returns[1] < batch.returns[0] - 0.05


def test_grasp_is_physical_closing_above_the_object_lifts_nothing(task):
    # The expert for a 6 cm box closes the fingers 4 cm above a 2 cm box: nothing may carry it.
    traj = expert_trajectory((0.06, 0.02), sim=task.sim)
    batch = task.evaluate(traj[None], T, (0.02, 0.02))
    assert not batch.success[0]
    assert batch.states["finger_contacts"][0].max() == 0
    np.testing.assert_allclose(batch.states["object_xyz"][0, -1], [*task.scene.pick_xy, 0.01], atol=1e-3)


def test_gripper_schedule_follows_the_phase():
    closed = gripper_schedule(T)
    k_grasp, k_cross = reward_steps(T)
    assert not closed[0] and not closed[-1]
    assert closed[k_grasp] and not closed[k_grasp - 1] and closed[k_cross]
    # the same phases on a coarser time grid
    coarse = np.linspace(0.0, 5.0, 126)
    assert abs(np.flatnonzero(gripper_schedule(coarse))[0] / 125 - k_grasp / (N_STEPS - 1)) < 0.01


def test_bad_input_raises_naming_the_argument(task, demos):
    traj = demos.values[:1]
    with pytest.raises(ValueError, match="trajectories"):
        task.evaluate(traj[..., :5], T, (0.02, 0.02))
    with pytest.raises(ValueError, match="trajectories"):
        task.evaluate(traj[0], T, (0.02, 0.02))
    bad = traj.copy()
    bad[0, 100, 2] = np.nan
    with pytest.raises(ValueError, match="trajectories"):
        task.evaluate(bad, T, (0.02, 0.02))
    with pytest.raises(ValueError, match="times"):
        task.evaluate(traj, T[:-1], (0.02, 0.02))
    with pytest.raises(ValueError, match="times"):
        task.evaluate(traj, T[::-1], (0.02, 0.02))
    for params in (None, (0.02,), (0.02, np.nan), (0.5, 0.02)):
        with pytest.raises(ValueError, match="task_params"):
            task.evaluate(traj, T, params)
    with pytest.raises(ValueError, match="gripper_closed"):
        task.sim.rollout(traj[0], np.zeros(10, dtype=bool))
