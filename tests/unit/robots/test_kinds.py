"""The ur10 and pour robot kinds: registry entries (joints, limits, drawing, simulator) and a worker
that evaluates roll-outs through the registry, in process (no zenoh)."""
from __future__ import annotations

import numpy as np
import pytest

from acnmp_core.robots.registry import MeshChainDrawing, PointSetDrawing, robot, robot_kinds
from acnmp_core.sim.ur10 import START_POSE_DEG
from acnmp_core.sim.ur10_description import UR10_ARM_JOINTS
from services.transport import decode, encode, wire_error
from services.worker.core import Worker, batch_from_reply, rollout_request


def test_ur10_and_pour_are_registered_kinds():
    assert {"ur10", "pour"} <= set(robot_kinds())
    assert set(robot("ur10").tasks) == {"pick_place"} and set(robot("pour").tasks) == {"pour"}


def test_ur10_entry_has_the_urdf_joints_a_mesh_drawing_and_a_simulator():
    spec = robot("ur10")
    assert tuple(j.name for j in spec.joints) == UR10_ARM_JOINTS
    start = np.deg2rad(START_POSE_DEG)
    assert all(j.lower <= q <= j.upper for j, q in zip(spec.joints, start))
    assert isinstance(spec.drawing, MeshChainDrawing) and spec.drawing.joint_names == UR10_ARM_JOINTS
    fields = spec.drawing.event_fields()
    assert fields["robot_kind"] == "ur10" and fields["pick_xy"].shape == (2,)
    sim = spec.make_simulator()
    try:
        np.testing.assert_allclose(sim.limits, [[j.lower, j.upper] for j in spec.joints])
    finally:
        sim.close()


def test_pour_entry_has_one_wrist_joint_and_a_point_drawing():
    spec = robot("pour")
    assert [j.name for j in spec.joints] == ["wrist"] and spec.joints[0].lower < 0 < spec.joints[0].upper
    assert isinstance(spec.drawing, PointSetDrawing) and spec.drawing.states[0] == "marble_xyz"
    assert spec.drawing.event_fields()["point_radius"] > 0


def test_a_ur10_worker_evaluates_a_rollout_through_the_registry():
    """Holding the start pose for 40 steps grasps nothing: a scored, failed roll-out."""
    t = np.linspace(0.0, 1.0, 40)
    trajs = np.broadcast_to(np.deg2rad(START_POSE_DEG), (2, 40, 6)).copy()
    worker = Worker("ur10", "w0")
    try:
        reply = decode(encode(worker.handle(rollout_request("pick_place", {}, trajs, t, np.array([0.04, 0.06])))))
        batch = batch_from_reply(reply)
        assert reply["worker"] == "w0" and len(batch) == 2 and not batch.success.any()
        assert batch.errors.shape == (2,) and batch.errors[0] > 0.1 and batch.errors[0] == batch.errors[1]
        assert batch.states["joint_angles"].shape == (2, 40, 6)
        for code, change in {"bad_request": {"task_params": np.array([0.5, 0.06])},
                             "unknown_task": {"task": "pour"}}.items():
            with pytest.raises(Exception) as info:
                worker.handle({**rollout_request("pick_place", {}, trajs, t, np.array([0.04, 0.06])), **change})
            assert wire_error(info.value).code == code, (code, info.value)
    finally:
        worker.close()


def test_a_pour_worker_evaluates_a_rollout_through_the_registry():
    """An upright cup pours nothing: the error is the whole target."""
    t = np.linspace(0.0, 1.0, 20)
    worker = Worker("pour", "w1")
    try:
        reply = worker.handle(rollout_request("pour", {}, np.zeros((1, 20, 1)), t, np.array([650.0, 200.0])))
        batch = batch_from_reply(decode(encode(reply)))
        assert batch.errors.tolist() == [200.0] and not batch.success[0]
        assert batch.rewards[0, -1] == -200.0 and np.all(batch.rewards[0, :-1] == 0)
        assert batch.states["marble_xyz"].shape[-2:] == (23, 3)
        with pytest.raises(Exception) as info:
            worker.handle(rollout_request("pour", {"tolerance": 5}, np.zeros((1, 20, 1)), t, np.array([650.0, 0.0])))
        assert wire_error(info.value).code == "bad_request"
    finally:
        worker.close()


def test_the_task_registry_knows_each_tasks_credit():
    """Remote evaluators carry the registry's credit; it must be what the task itself says."""
    from acnmp_core.tasks.push.task import PlanarPushTask
    from acnmp_core.tasks.pour.task import PourTask
    from acnmp_core.tasks.registry import task_credit
    from acnmp_core.tasks.ur10_pick_place.task import UR10PickPlaceTask

    for name, cls in (("push", PlanarPushTask), ("pour", PourTask), ("pick_place", UR10PickPlaceTask)):
        assert task_credit(name) == getattr(cls, "credit", "step"), name
    assert task_credit("viapoint") == "step"
    with pytest.raises(ValueError, match="juggle"):
        task_credit("juggle")


def test_remote_and_recorded_evaluators_carry_the_tasks_credit():
    """adapt() reads ``credit`` from its evaluator: across a deployment that is a RemoteEvaluator,
    possibly wrapped in a RecordedEvaluator (constructed here without a session: nothing is sent)."""
    from services.recording.recorded import RecordedEvaluator
    from services.worker.remote import RemoteEvaluator

    remote = RemoteEvaluator(None, "ns", "pour", "pour")
    assert remote.credit == "future"
    assert RemoteEvaluator(None, "ns", "ur10", "pick_place").credit == "step"
    assert RecordedEvaluator(remote, None, "job", "pour").credit == "future"
