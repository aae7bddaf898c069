"""The service shape of E4 without zenoh: the train_pair request and its job, weights with a
partner, the model service's transfer query, the learner running, cancelling and resuming a pair
job from its checkpoint, and the recording of both robots' latents and arms."""
from __future__ import annotations

import json

import numpy as np
import pytest
import rerun as rr

from acnmp_core.data.demos import DemoSet
from acnmp_core.jobs.transfer import PairTrainJob
from acnmp_core.model.checkpoint import model_to_arrays
from acnmp_core.transfer.pair import TransferConfig, TransferPair, latent_plane, train_pair
from services.learner.core import LearnerCore
from services.learner.jobs import JobRecord
from services.learner.limits import LearnerLimits
from services.learner.service import _weights, parse_pair_request
from services.model.handlers import ModelRegistry, SkillModel, handle_info, handle_transfer
from services.model.weights import decode_weights, parse_weights, weights_message
from services.recording.events import decode_event, latent_event, rollout_event
from services.recording.rrd_writer import RrdWriter
from services.transport import WireError, decode, encode

T = np.linspace(0.0, 1.0, 30)
CFG = TransferConfig(latent_weight=10.0, steps=30, batch_size=4, widths=(16, 16))


def _demos(n_dims: int) -> DemoSet:
    values = np.stack([np.stack([np.sin(T * k + j) for j in range(n_dims)], axis=1) for k in range(1, 5)])
    return DemoSet.from_arrays(T, values)


DEMOS_A, DEMOS_B = _demos(3), _demos(4)


def _job(**kw) -> PairTrainJob:
    return PairTrainJob(DEMOS_A, DEMOS_B, kw.pop("config", CFG), seed=3, robot_a="planar3", robot_b="planar4", **kw)


def _request(**changes) -> dict:
    """A train_pair request through the wire codec, with top-level ``changes``."""
    return decode(encode({"v": 1, **_job().to_dict(), **changes}))


@pytest.fixture(scope="module")
def pair() -> TransferPair:
    """The pair of :func:`_job`, trained in this process with the library."""
    p = TransferPair(3, 4, CFG, seed=3)
    train_pair(p, DEMOS_A, DEMOS_B, CFG, seed=3)
    return p


def test_a_train_pair_request_round_trips_through_the_wire_and_the_job_record():
    job = parse_pair_request(_request())
    assert job.demos_a.content_hash() == DEMOS_A.content_hash()
    assert job.demos_b.content_hash() == DEMOS_B.content_hash()
    assert (job.config, job.seed, job.robot_a, job.robot_b) == (CFG, 3, "planar3", "planar4")
    record = JobRecord.new("pp", job)
    back = JobRecord.from_dict(json.loads(json.dumps(record.to_dict())))  # what the learner's job file holds
    assert back.kind == "train_pair" and back.request.config == CFG
    assert back.request.demos_b.content_hash() == DEMOS_B.content_hash()
    status = back.status()
    assert (status["kind"], status["task"], status["robot"], status["steps"]) == ("train_pair", "train_pair",
                                                                                   "planar4", 30)


@pytest.mark.parametrize("changes, code, where", [
    ({"demos_b": None}, "bad_request", "demos_b"),
    ({"demos_a": {"times": T, "values": np.zeros((4, 30))}}, "bad_shape", "demos_a.values"),
    ({"demos_a": {"times": T[:10], "values": np.zeros((4, 30, 3))}}, "bad_shape", "demos_a.times"),
    ({"demos_b": {"times": T, "values": np.zeros((3, 30, 4))}}, "bad_request", "demos_b"),
    ({"demos_a": {"times": T[::-1].copy(), "values": np.zeros((4, 30, 3))}}, "bad_request", "demos_a"),
    ({"config": {"warp": 9}}, "bad_request", "warp"),
    ({"config": {"steps": -1}}, "bad_request", "steps"),
    ({"config": {"max_obs": 30}}, "bad_request", "max_obs"),
    ({"config": {"steps": 10**6}}, "too_large", "config.steps"),
    ({"config": {"widths": [4096] * 8}}, "too_large", "parameters"),
    ({"robot_b": "hexapod"}, "bad_request", "hexapod"),
    ({"seed": "three"}, "bad_request", "seed"),
])
def test_a_hostile_train_pair_request_gets_its_documented_code(changes, code, where):
    with pytest.raises(WireError) as err:
        parse_pair_request(_request(**changes), LearnerLimits())
    assert err.value.code == code and where in err.value.message


def test_non_finite_and_empty_train_pair_requests_are_refused():
    bad = _job().to_dict()
    bad["demos_a"]["values"] = bad["demos_a"]["values"].copy()
    bad["demos_a"]["values"][0, 0, 0] = np.nan  # the wire refuses NaN already; the parser too
    with pytest.raises(WireError) as err:
        parse_pair_request(bad)
    assert err.value.code == "non_finite"
    with pytest.raises(WireError) as err:
        parse_pair_request(None)
    assert err.value.code == "malformed"


def _served(pair: TransferPair, skill: str = "pp") -> ModelRegistry:
    """A registry serving ``pair`` as the model service loads it: from a weights message."""
    w = decode_weights(encode(weights_message(skill, 2, pair.model_a, partner=pair.model_b)))
    registry = ModelRegistry()
    registry.offer(SkillModel(w.skill, w.version, w.model, partner=w.partner))
    return registry


def test_the_transfer_query_equals_the_librarys_transfer_on_the_same_weights(pair):
    obs_t, obs_v = T[[0, 10, 20, 29]], DEMOS_A[1].values[[0, 10, 20, 29]]
    reply = decode(encode(handle_transfer(_served(pair), "pp", {"v": 1, "obs_times": obs_t, "obs_values": obs_v,
                                                                "query_times": T})))
    ref = pair.transfer(obs_t, obs_v, T)
    assert reply["mean"].shape == (30, 4) and reply["version"] == 2
    np.testing.assert_array_equal(reply["mean"], ref.mean)
    np.testing.assert_array_equal(reply["std"], ref.std)
    np.testing.assert_array_equal(reply["latent"], ref.latent)
    info = handle_info(_served(pair), "pp")
    assert info["n_outputs"] == 3 and info["partner"]["n_outputs"] == 4


@pytest.mark.parametrize("request_, code", [
    ({"obs_times": [0.0], "obs_values": [[0.0, 0.0, 0.0, 0.0]], "n_steps": 10}, "bad_shape"),  # robot B's D
    ({"obs_times": [0.0], "obs_values": [[0.0, 0.0, 0.0]], "n_steps": 10**6}, "too_large"),
    ({"obs_times": [0.0], "obs_values": [[0.0, 0.0, 0.0]], "n_steps": 10, "n_samples": 10**5}, "too_large"),
    ({"obs_times": [5.0], "obs_values": [[0.0, 0.0, 0.0]], "n_steps": 10}, "bad_request"),  # outside the time range
    ({"obs_times": [0.0], "obs_values": [[0.0, 0.0, 0.0]]}, "bad_request"),
    ({"batch": [{"obs_times": [0.0], "obs_values": [[0.0, 0.0, 0.0]], "n_steps": 10}]}, "bad_request"),
])
def test_a_bad_transfer_query_gets_the_predict_paths_code(pair, request_, code):
    with pytest.raises(WireError) as err:
        handle_transfer(_served(pair), "pp", {"v": 1, **request_})
    assert err.value.code == code


def test_a_transfer_query_on_a_skill_that_is_not_paired_or_not_served(pair):
    registry = ModelRegistry()
    registry.offer(SkillModel("solo", 0, pair.model_a))
    req = {"v": 1, "obs_times": [0.0], "obs_values": [[0.0, 0.0, 0.0]], "n_steps": 10}
    for skill, code in (("solo", "bad_request"), ("nothing", "unknown_skill")):
        with pytest.raises(WireError) as err:
            handle_transfer(registry, skill, req)
        assert err.value.code == code


def test_weights_whose_partner_does_not_fit_are_refused(pair):
    msg = decode(encode(weights_message("pp", 0, pair.model_a, partner=pair.model_b)))
    other = TransferPair(3, 4, TransferConfig(widths=(16, 8)), seed=0)  # latents of 8, not 16
    train_pair(other, DEMOS_A, DEMOS_B, TransferConfig(widths=(16, 8), steps=1, batch_size=2), seed=0)
    config, arrays = model_to_arrays(other.model_b)
    bad_latent = dict(msg, partner={"config": config, "state": arrays})
    state = dict(msg["partner"]["state"])
    first = next(iter(state))
    state[first] = np.zeros((1, 1), dtype=np.float32)
    bad_state = dict(msg, partner={"config": msg["partner"]["config"], "state": state})
    for bad, code in ((bad_latent, "bad_request"), (bad_state, "bad_shape"),
                      (dict(msg, partner={"config": msg["partner"]["config"]}), "bad_request")):
        with pytest.raises(WireError) as err:
            parse_weights(bad)
        assert err.value.code == code and "partner" in err.value.message


def _core(tmp_path, events=None) -> LearnerCore:
    return LearnerCore(tmp_path, evaluator_for=None, publish=(events.append if events is not None else lambda e: None))


def test_the_learner_trains_a_pair_job_commits_it_and_reloads_it_from_its_checkpoint(tmp_path, pair):
    events: list[dict] = []
    core = _core(tmp_path, events).start()
    try:
        job = core.submit_pair("pp", _job())
        assert core.wait_idle(60)
        status = core.status(job.job)
        assert (status["state"], status["iteration"], status["committed_version"]) == ("done", 30, 0)
        assert status["result"]["version"] == 0 and status["result"]["steps"] == 30
    finally:
        core.close()
    reloaded = _core(tmp_path)  # a restarted learner: the pair comes back from its checkpoint
    try:
        state = reloaded.skill("pp")
        w = decode_weights(_weights(state))  # what the learner puts for the model service
        got = TransferPair.from_models(w.model, w.partner).transfer(T[:3], DEMOS_A[0].values[:3], T)
        ref = pair.transfer(T[:3], DEMOS_A[0].values[:3], T)  # the learner used the library: the same pair
        np.testing.assert_array_equal(got.mean, ref.mean)
        assert state.partner_demos.content_hash() == DEMOS_B.content_hash()
        assert reloaded.jobs[job.job].state == "done"
    finally:
        reloaded.close()
    progress = [e for e in events if e["kind"] == "job_progress"]
    assert [e["iteration"] for e in progress[:3]] == [1, 2, 3] and progress[-1]["state"] == "done"
    latents = {e["label"]: e for e in events if e["kind"] == "latent"}
    assert sorted(latents) == [f"{side}-demo{i}" for side in "ab" for i in range(4)]
    assert latents["a-demo0"]["robot"] == "planar3" and latents["b-demo3"]["robot"] == "planar4"
    assert all(e["map_xy"].shape == (2,) for e in latents.values())


def test_an_interrupted_pair_job_resumes_on_restart_and_gives_the_same_pair(tmp_path, pair):
    cores: list[LearnerCore] = []

    def stop_at_first_progress(event: dict) -> None:  # SIGTERM while the job trains
        if event["kind"] == "job_progress" and event["state"] == "running":
            cores[0].stopping.set()

    cores.append(LearnerCore(tmp_path, evaluator_for=None, publish=stop_at_first_progress))
    job = cores[0].submit_pair("pp", _job())
    cores[0].start().close()
    assert JobRecord.from_dict(json.loads((tmp_path / "jobs" / f"{job.job}.json").read_text())).state == "interrupted"
    assert "pp" not in cores[0].skill_states()
    resumed = _core(tmp_path).start()
    try:
        assert resumed.wait_idle(60)
        status = resumed.status(job.job)
        assert (status["state"], status["attempt"]) == ("done", 1)
        got = resumed.skill("pp")  # trained again from its beginning with its seed: the same pair
        for mine, ref in ((got.model, pair.model_a), (got.partner, pair.model_b)):
            for (name, a), b in zip(mine.state_dict().items(), ref.state_dict().values()):
                np.testing.assert_array_equal(a.numpy(), b.numpy(), err_msg=name)
    finally:
        resumed.close()


def test_a_pair_job_is_cancelled_while_queued_and_while_running(tmp_path):
    core = _core(tmp_path)
    long_cfg = TransferConfig(**{**CFG.to_dict(), "steps": 5000, "widths": (16, 16)})
    running = core.submit_pair("long", _job(config=long_cfg))
    queued = core.submit_pair("pp", _job())
    assert core.cancel(queued.job)["state"] == "cancelled"
    core.start()
    try:
        while core.status(running.job)["iteration"] == 0:  # the progress of its first 5 %
            core.wait_idle(0.05)
        assert core.cancel(running.job)["cancel_requested"]
        assert core.wait_idle(60)
        assert core.status(running.job)["state"] == "cancelled" and "long" not in core.skill_states()
        assert core.status(queued.job)["state"] == "cancelled" and "pp" not in core.skill_states()
    finally:
        core.close()


def test_the_recording_draws_both_arms_and_the_latent_map(tmp_path, verify_rrd):
    latents = np.random.default_rng(0).standard_normal((4, 8))
    plane = latent_plane(latents)
    events = [latent_event("pp", 0, z, label=f"{side}-demo{i % 2}", robot=robot, map_xy=xy)
              for i, (z, xy, side, robot) in enumerate(zip(latents, plane, "aabb",
                                                            ("planar3", "planar3", "planar4", "planar4")))]
    q_b, q_a = np.zeros((5, 4)), np.full((5, 3), 0.2)
    ev = rollout_event("transfer-0", 0, q_b, np.linspace(0, 1, 5), np.zeros(5), space="joint")
    ev.update(drawing="planar_chain", joint_angles=q_b, link_lengths=np.array([0.25, 0.22, 0.15, 0.1]),
              reference_joint_angles=q_a, reference_link_lengths=np.array([0.3, 0.3, 0.12]))
    path = tmp_path / "e4.rrd"
    with RrdWriter(path) as w:
        for e in [*events, ev]:
            w.log_event(decode_event(encode(e)))
    verify_rrd(path)
    reader = rr.chunk.RrdReader(path)
    entities = {c.entity_path for c in reader.stream(store=reader.recordings()[0])}
    assert {"/latent_map/pp/a-demo0", "/latent_map/pp/b-demo1", "/arm/transfer-0/links",
            "/arm/transfer-0/reference"} <= entities
    with pytest.raises(WireError):  # a map position is two numbers
        decode_event(encode({**events[0], "map_xy": np.zeros(3)}))


def test_query_transfer_takes_the_predict_options_but_no_task_parameters(capsys):
    from clients.cli import main

    with pytest.raises(SystemExit) as exit_:
        main(["query", "transfer", "--help"])
    out = capsys.readouterr().out
    assert exit_.value.code == 0 and "robot A" in out
    for text in ("--obs", "--obs-json", "--steps", "--times", "--samples", "--json", "--skill"):
        assert text in out
    assert "--task-params P1" not in out  # (the shared examples below the options mention predict's)
    assert main(["query", "transfer", "--task-params", "1"]) == 2  # argparse: one line naming the option
    assert "--task-params" in capsys.readouterr().err.splitlines()[-1]
