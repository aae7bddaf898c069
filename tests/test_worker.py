"""Workers as real processes: bad input gets an error code and the worker keeps serving; a batch
spread over two workers completes on the survivor when one is kill -9'd mid-batch, in order and
with every roll-out executed once."""
from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from acnmp_core.experiments.viapoint import make_setup
from services import keys
from services.launcher import LocalDeployment
from services.remote_evaluator import RemoteEvaluator
from services.session import query
from services.wire import WireError


@pytest.fixture(scope="module")
def setup():
    return make_setup()


def _request(setup, trajs, **over):
    req = {"v": 1, "task": "viapoint", "task_config": setup.task_config, "trajectories": trajs,
           "times": setup.target.query_times, "task_params": None}
    req.update(over)
    return req


def test_worker_rejects_bad_input_and_keeps_serving(tmp_path, setup):
    with LocalDeployment("wbad", workers=1, model=False, learner=False, state_dir=tmp_path) as dep:
        key = keys.worker_rollout_key("wbad", "point2d", "point2d-0")
        t = setup.target.query_times
        good = np.random.default_rng(0).normal(size=(3, len(t), 2))
        cases = {
            "malformed": b"\xc1 not msgpack",
            "bad_version": {"v": 7, "task": "viapoint"},
            "unknown_task": _request(setup, good, task="push"),
            "bad_shape": _request(setup, good, times=t[:-1]),
            "non_finite": None,  # filled below: NaN in the trajectories
            "bad_request": _request(setup, good, task_config={"t_v": 0.5}),  # missing point/tolerance
        }
        nan = good.copy()
        nan[0, 3, 1] = np.nan
        for code, payload in cases.items():
            if code == "non_finite":
                from services.wire import encode

                payload = encode(_request(setup, nan), allow_non_finite=True)
            with pytest.raises(WireError) as info:
                query(dep.session, key, payload, timeout=10)
            assert info.value.code == code, (code, info.value)
        # a 2-D trajectory for a 3-D via-point: the task's own validation, reported as bad_request
        with pytest.raises(WireError) as info:
            query(dep.session, key, _request(setup, good[..., :1]), timeout=10)
        assert info.value.code == "bad_request"
        # ... and the worker still serves, with the same numbers as in-process evaluation
        reply = query(dep.session, key, _request(setup, good), timeout=10)
        ref = setup.task.evaluate(good, t)
        np.testing.assert_allclose(reply["rewards"], ref.rewards)
        np.testing.assert_array_equal(reply["success"], ref.success)
        assert reply["worker"] == "point2d-0"
        assert dep.children["worker-point2d-0"].proc.poll() is None


def test_batch_survives_a_worker_killed_mid_batch(tmp_path, setup):
    t = setup.target.query_times
    trajs = np.random.default_rng(1).normal(scale=0.3, size=(8, len(t), 2))
    with LocalDeployment("wkill", workers=2, model=False, learner=False, worker_delay=0.4,
                         state_dir=tmp_path) as dep:
        ev = RemoteEvaluator(dep.session, "wkill", "point2d", "viapoint", setup.task_config, timeout=30)
        assert ev.workers() == ["point2d-0", "point2d-1"]
        out = {}
        thread = threading.Thread(target=lambda: out.update(batch=ev.evaluate(trajs, t)))
        thread.start()
        time.sleep(0.6)  # both chunks of 4 roll-outs (1.6 s each) are in flight
        dep.kill("worker-point2d-0")
        thread.join(timeout=30)
        assert not thread.is_alive()
    batch = out["batch"]
    ref = setup.task.evaluate(trajs, t)
    assert len(batch) == 8
    np.testing.assert_allclose(batch.rewards, ref.rewards)  # in order: roll-out i is trajectory i
    np.testing.assert_allclose(batch.states["path"], trajs)
    # the killed worker's chunk ran on the survivor; nothing ran twice into the result
    assert ev.last_workers == ["point2d-1"] * 8


def test_remote_evaluator_rejects_a_bad_request_without_retrying(tmp_path, setup):
    with LocalDeployment("wval", workers=1, model=False, learner=False, state_dir=tmp_path) as dep:
        ev = RemoteEvaluator(dep.session, "wval", "point2d", "push", {})
        with pytest.raises(ValueError, match="unknown_task"):
            ev.evaluate(np.zeros((2, 5, 2)), np.linspace(0, 1, 5))
        nobody = RemoteEvaluator(dep.session, "wval", "planar3", "push", {}, discover_timeout=0.5)
        with pytest.raises(RuntimeError, match="no live planar3 worker"):
            nobody.evaluate(np.zeros((2, 5, 3)), np.linspace(0, 1, 5))


def test_serve_dispatches_to_the_process_modules():
    from clients.cli import build_parser

    args = build_parser().parse_args(["serve", "worker", "--robot", "planar4", "--id", "arm1", "--delay", "0.1"])
    assert (args.robot, args.id, args.delay) == ("planar4", "arm1", 0.1)
    args = build_parser().parse_args(["serve", "learner", "--state-dir", "x", "--namespace", "lab"])
    assert (args.state_dir, args.namespace) == ("x", "lab")
