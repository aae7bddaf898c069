"""A whole local deployment under hostile input, as written from docs/PROTOCOL.md alone: every
answer carries a documented error code (never ``internal`` for a bad request), and every process
keeps serving afterwards."""
from __future__ import annotations

import time

import msgpack
import numpy as np
import pytest

from acnmp_core.experiments.viapoint import make_setup
from services.launcher import LocalDeployment
from services.transport import ERROR_CODES, WireError, call, encode
from services.transport.wire import error_from_payload

NS = "hostile"
SMALL = {"encoder_widths": [32, 32], "decoder_widths": [32, 32]}
OBS = {"obs_times": np.array([0.0, 1.0]), "obs_values": np.array([[0.0, 0.0], [1.0, 0.0]])}


@pytest.fixture(scope="module")
def deployment(tmp_path_factory):
    """learner + model + one point2d worker + recorder, with skill ``e1`` trained and served."""
    tmp = tmp_path_factory.mktemp("hostile")
    setup = make_setup()
    with LocalDeployment(NS, workers=1, record=tmp / "run.rrd", state_dir=tmp / "state") as dep:
        train = {"times": np.stack([d.times for d in setup.demos]),
                 "values": np.stack([d.values for d in setup.demos]), "model": SMALL, "train": {"steps": 50}}
        assert call(dep.session, dep.keys.train("e1"), train, timeout=60)["version"] == 0
        served(dep)
        yield dep


def served(dep, timeout: float = 30.0) -> dict:
    """A good predict once the model service serves ``e1`` (polled, with a liveness deadline)."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            return call(dep.session, dep.keys.predict("e1"), {**OBS, "n_steps": 20}, timeout=10)
        except WireError as exc:
            if exc.code not in ("unknown_skill", "unavailable") or time.monotonic() > deadline:
                raise
            time.sleep(0.1)


def error_of(dep, key: str, payload, timeout: float = 10.0) -> WireError:
    """The WireError a query on ``key`` ends in (fails the test if it succeeds)."""
    body = encode({"v": 1, **payload}, allow_non_finite=True) if isinstance(payload, dict) else payload
    with pytest.raises(WireError) as info:
        call(dep.session, key, body, timeout=timeout)
    return info.value


@pytest.mark.parametrize("payload", [None, b"", b"\xc1", msgpack.packb({"v": 1}), msgpack.packb({"v": 7})])
def test_a_get_on_everything_gets_documented_codes_and_no_internal_error(deployment, payload):
    replies = list(deployment.session.get("acnmp/**", payload=payload, timeout=10))
    assert len(replies) >= 7  # predict, info, train, adapt, status, weights/latest, rollout (+ recorder)
    for reply in replies:
        if reply.ok is None:
            err = error_from_payload(reply.err.payload.to_bytes())
            assert err.code in ERROR_CODES and err.code != "internal", (payload, err)
    assert served(deployment)["mean"].shape == (20, 2)


def test_an_empty_payload_is_malformed_wherever_a_request_is_needed(deployment):
    keys = deployment.keys
    for key in (keys.predict("e1"), keys.train("e1"), keys.adapt("e1"), keys.worker_rollout("point2d", "point2d-0")):
        for payload in (None, b""):
            err = error_of(deployment, key, payload)
            assert err.code == "malformed" and "empty payload" in err.message, (key, err)


def test_absurd_array_shapes_are_too_large_not_internal(deployment):
    empty_huge = {"dtype": "float64", "shape": [0, 2**63 - 1], "data": b""}
    body = msgpack.packb({"v": 1, "obs_times": [0.0], "obs_values": empty_huge, "n_steps": 5}, use_bin_type=True)
    keys = deployment.keys
    for key in (keys.predict("e1"), keys.train("e1"), keys.worker_rollout("point2d", "point2d-0")):
        assert error_of(deployment, key, body).code == "too_large", key
    assert served(deployment)["mean"].shape == (20, 2)


def test_a_batch_whose_total_cost_is_over_the_bounds_is_refused_before_computing(deployment):
    # the request: 64 items each within the per-item bounds, 6 MB on the wire
    heavy = {"obs_times": np.linspace(0, 1, 4096), "obs_values": np.zeros((4096, 2)), "n_steps": 20_000,
             "n_samples": 100}
    err = error_of(deployment, deployment.keys.predict("e1"), {"batch": [heavy] * 64}, timeout=30)
    assert err.code == "too_large" and "at most" in err.message, err
    assert served(deployment)["mean"].shape == (20, 2)


def test_train_and_adapt_requests_over_the_learners_limits_are_too_large(deployment):
    setup = make_setup()
    keys = deployment.keys
    train = {"times": np.stack([d.times for d in setup.demos]), "values": np.stack([d.values for d in setup.demos]),
             "model": SMALL, "train": {"steps": 10**9}}
    err = error_of(deployment, keys.train("e1"), train)
    assert err.code == "too_large" and "train.steps" in err.message, err
    tg = setup.target
    adapt = {"target": {"obs_times": tg.obs_times, "obs_values": tg.obs_values, "query_times": tg.query_times},
             "task": "viapoint", "task_config": setup.task_config, "config": {"max_rollouts": 10**9}}
    err = error_of(deployment, keys.adapt("e1"), adapt)
    assert err.code == "too_large" and "max_rollouts" in err.message, err
    # the learner was not occupied: it still answers at once, with the version it had
    replies = list(deployment.session.get(keys.weights_latest("e1"), timeout=10))
    assert len(replies) == 1 and replies[0].ok is not None
