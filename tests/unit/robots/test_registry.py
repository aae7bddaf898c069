"""The robot registry: one entry per robot kind, read by workers, learner, launcher, recorder, CLI."""
from __future__ import annotations

import numpy as np
import pytest

from acnmp_core.errors import InputError, UnknownRobotError, UnknownTaskError
from acnmp_core.robots.registry import (PlanarChainDrawing, RobotBody, RobotSpec, register_robot, robot,
                                        robot_kinds)
from acnmp_core.rollout import RolloutEvaluator


def test_the_project_robots_are_registered_with_their_tasks():
    assert robot_kinds()[:3] == ("point2d", "planar3", "planar4")
    assert set(robot("point2d").tasks) == {"viapoint", "wall"}
    assert dict(robot("planar4").tasks["push"]) == {"n_joints": 4}


@pytest.mark.parametrize("kind, n", [("planar3", 3), ("planar4", 4)])
def test_planar_arms_describe_joints_drawing_and_simulator(kind, n):
    spec = robot(kind)
    assert [j.name for j in spec.joints] == [f"joint{i}" for i in range(n)]
    assert all(j.lower < 0 < j.upper for j in spec.joints)
    assert isinstance(spec.drawing, PlanarChainDrawing) and len(spec.drawing.link_lengths) == n
    fields = spec.drawing.event_fields()
    assert fields["link_lengths"].shape == (n,) and fields["object_radius"] > 0
    with spec.make_evaluator("push") as task:  # fixed n_joints reaches the task
        assert isinstance(task, RolloutEvaluator) and task.n_joints == n
    sim = spec.make_simulator()
    try:
        assert sim.n_joints == n
    finally:
        sim.close()


def test_point_robot_has_no_body():
    spec = robot("point2d")
    assert spec.joints == () and spec.drawing is None
    with pytest.raises(InputError, match="no simulator"):
        spec.make_simulator()


def test_task_config_merges_fixed_parameters_and_refuses_contradictions():
    spec = robot("planar3")
    assert spec.task_config("push", {"tolerance": 0.05}) == {"tolerance": 0.05, "n_joints": 3}
    assert spec.task_config("push", {"n_joints": 3}) == {"n_joints": 3}
    with pytest.raises(InputError, match="n_joints"):
        spec.task_config("push", {"n_joints": 4})
    with pytest.raises(UnknownTaskError, match="planar3"):
        spec.task_config("viapoint")
    with pytest.raises(InputError, match="plain values"):
        spec.task_config("push", {"tolerance": np.zeros(2)})


def test_unknown_kinds_and_bad_entries_are_refused():
    with pytest.raises(UnknownRobotError, match="point2d"):
        robot("ur11")
    with pytest.raises(UnknownTaskError):
        register_robot(RobotSpec("juggler", "juggles", tasks={"juggle": {}}))
    with pytest.raises(InputError, match="already"):
        register_robot(RobotSpec("point2d", "again", tasks={"viapoint": {}}))


def test_a_new_robot_is_one_entry(monkeypatch):
    """What adding a robot takes: an entry naming its tasks and a body function; every reader
    (kinds, task checks, drawing) sees it at once."""
    import acnmp_core.robots.registry as registry

    monkeypatch.setattr(registry, "_ROBOTS", dict(registry._ROBOTS))
    monkeypatch.setattr(registry, "_SOURCES", dict(registry._SOURCES))
    drawing = PlanarChainDrawing((0.2, 0.2))
    register_robot(RobotSpec("planar2", "2-DoF arm", tasks={"push": {"n_joints": 2}},
                             body=lambda: RobotBody(drawing=drawing)))
    assert "planar2" in robot_kinds()
    assert robot("planar2").task_config("push") == {"n_joints": 2}
    assert robot("planar2").drawing is drawing


def test_a_missing_task_parameter_is_named_with_what_the_task_takes():
    """Was: "bad parameters for task 'viapoint': 't_v'" from a job submitted without --task-config."""
    import pytest

    from acnmp_core.tasks.registry import make_task

    with pytest.raises(ValueError, match=r"task 'viapoint' needs the parameter 't_v' \(params: t_v \(float or K"):
        make_task("viapoint", {})
