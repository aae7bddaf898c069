"""The typed adaptation path: AdaptJob, its target and result codecs, and the learner's JobRecord."""
from __future__ import annotations

import json

import numpy as np
import pytest

from acnmp_core.adaptation.config import AdaptConfig, AdaptResult, AdaptTarget, IterationLog
from acnmp_core.errors import InputError, NonFiniteError, ShapeError, TooLargeError, UnknownRobotError, UnknownTaskError
from acnmp_core.jobs.adapt import AdaptJob, result_from_dict, result_to_dict, target_from_dict
from services.learner.jobs import JobRecord
from services.transport import decode, encode

TARGET = AdaptTarget(np.array([0.25]), np.array([[0.25, 0.6]]), None, np.linspace(0.0, 1.0, 11))


def job(**over) -> AdaptJob:
    kw = dict(target=TARGET, task="viapoint", robot="point2d",
              task_config={"t_v": 0.25, "point": [0.25, 0.6], "tolerance": 0.02},
              config=AdaptConfig(max_rollouts=20, mode="rl_only"), seed=4, commit=True, assimilate_steps=7)
    return AdaptJob(**{**kw, **over})


def test_a_job_survives_the_wire_and_a_json_record_unchanged():
    j = job()
    over_wire = AdaptJob.from_dict(decode(encode({"v": 1, **j.to_dict()})))
    record = JobRecord.new("e1", j)
    from_disk = JobRecord.from_dict(json.loads(json.dumps(record.to_dict()))).request
    for other in (over_wire, from_disk):
        assert other.config == j.config and other.task_config == j.task_config
        assert (other.task, other.robot, other.seed, other.commit, other.assimilate_steps) == ("viapoint", "point2d",
                                                                                                4, True, 7)
        for name in ("obs_times", "obs_values", "query_times"):
            np.testing.assert_array_equal(getattr(other.target, name), getattr(j.target, name))
        assert other.target.task_params is None


def test_the_config_travels_whole_through_to_dict_and_a_subset_takes_the_defaults():
    d = job().to_dict()
    assert d["config"] == AdaptConfig(max_rollouts=20, mode="rl_only").to_dict()
    minimal = AdaptJob.from_dict({"target": d["target"], "task": "viapoint", "task_config": d["task_config"],
                                  "config": {"max_rollouts": 20}, "newer_client_field": 1})
    assert minimal.config == AdaptConfig(max_rollouts=20) and minimal.robot == "point2d" and minimal.seed == 0


def test_the_robot_fixes_its_task_parameters():
    t = AdaptTarget(np.zeros(1), np.zeros((1, 3)), np.array([0.4, 0.1]), np.linspace(0, 1, 5))
    assert AdaptJob(t, "push", "planar3").task_config == {"n_joints": 3}
    with pytest.raises(InputError, match="n_joints"):
        AdaptJob(t, "push", "planar3", {"n_joints": 4})


@pytest.mark.parametrize("change, error", [
    ({"task": "juggle"}, UnknownTaskError),
    ({"robot": "planar3"}, UnknownTaskError),  # planar3 does not run viapoint
    ({"robot": "ur11"}, UnknownRobotError),
    ({"seed": True}, InputError),
    ({"commit": 1}, InputError),
    ({"assimilate_steps": 0}, InputError),
    ({"config": {"warp_speed": 9}}, InputError),
    ({"config": {"max_rollouts": 0}}, InputError),
    ({"target": {"obs_times": [0.1], "obs_values": [[0.1, 0.2], [0.3, 0.4]], "query_times": [0.0, 1.0]}},
     ShapeError),
    ({"target": {"obs_times": [np.nan], "obs_values": [[0.1, 0.2]], "query_times": [0.0, 1.0]}}, NonFiniteError),
    ({"target": {"obs_times": [0.1], "obs_values": [[0.1, 0.2]], "query_times": np.zeros(100_001)}},
     TooLargeError),
    ({"target": {"obs_times": [0.1]}}, InputError),
])
def test_bad_jobs_raise_the_typed_error_naming_the_field(change, error):
    d = {**job().to_dict(), **change}
    with pytest.raises(error):
        AdaptJob.from_dict(d)


def test_results_keep_every_iteration_field_and_old_records_still_load():
    log = IterationLog(0, 3, -0.5, False, [-0.6, -0.4], [0.1, 0.1])
    res = AdaptResult(True, 3, np.ones((4, 2)), np.linspace(0, 1, 4), [log])
    back = result_from_dict(json.loads(json.dumps(result_to_dict(res), default=lambda a: a.tolist())))
    assert back.history == [log] and back.success and back.rollouts == 3
    np.testing.assert_array_equal(back.trajectory, res.trajectory)
    # a job record written before the full iteration log was kept: four fields per iteration
    legacy = {"success": True, "rollouts": 3, "trajectory": [[1.0, 1.0]] * 4, "times": [0, 0.3, 0.6, 1.0],
              "history": [{"iteration": 0, "rollouts": 3, "mean_return": -0.5, "mean_success": False}]}
    assert result_from_dict(legacy).history[0].noisy_returns == []


def test_a_job_record_reports_its_status():
    record = JobRecord.new("e1", job())
    assert record.job.startswith("e1-") and record.state == "queued"
    status = record.status()
    assert (status["task"], status["robot"], status["commit"], status["result"]) == ("viapoint", "point2d", True, None)
    record.result = AdaptResult(False, 2, np.zeros((11, 2)), TARGET.query_times, [])
    assert set(record.status()["result"]) == {"success", "rollouts", "trajectory", "times", "history"}
    with pytest.raises(ValueError):
        target_from_dict([1, 2])
