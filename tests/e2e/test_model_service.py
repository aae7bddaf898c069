"""The model service over zenoh on loopback: bad input gets the right error code, predictions equal
the in-process ones exactly, weights hot-swap under load, weights come from the learner or a file."""
from __future__ import annotations

import threading
import time

import msgpack
import numpy as np
import pytest

from acnmp_core.model.checkpoint import save_checkpoint
from acnmp_core.model.cnmp import CNMP
from clients.client import ACNMPClient, ClientError
from services.model.service import ModelConfig, ModelService
from services.model.batching import DEFAULT_BATCH_MAX
from services.model.handlers import MAX_BATCH, MAX_QUERY_STEPS, SkillModel
from services.model.weights import encode_weights
from services.transport import (Keyspace, SessionOptions, WireError, call, declare_rpc, encode, free_port,
                                loopback_endpoint, open_session)
from services.transport.keys import skill_from_key

NS = "mtest"
KEYS = Keyspace(NS)


@pytest.fixture
def mesh():
    """(anchor endpoint, service session, client) on a fresh loopback port; all closed after."""
    ep = loopback_endpoint(free_port())
    with open_session("peer", [ep]) as service_session, \
            ACNMPClient(NS, connect=[ep], timeout=5.0) as client:
        yield ep, service_session, client


def wait_for(fn, timeout: float = 10.0):
    """Call ``fn`` until it stops raising ClientError unavailable/unknown_skill; return its value."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            return fn()
        except ClientError as exc:
            if exc.code not in ("unavailable", "timeout", "unknown_skill") or time.monotonic() > deadline:
                raise
            time.sleep(0.05)


def publish(session, skill: str, version: int, model: CNMP) -> None:
    session.put(KEYS.weights(skill), encode_weights(skill, version, model, data_hash="h", n_demos=6))


def perturbed(model: CNMP, scale: float, seed: int) -> CNMP:
    """A copy of ``model`` with its decoder's last bias shifted: a visibly different version."""
    from acnmp_core.model.checkpoint import model_from_arrays, model_to_arrays

    cfg, state = model_to_arrays(model)
    key = [k for k in state if k.startswith("decoder.") and k.endswith("bias")][-1]
    state[key] = state[key] + np.float32(scale) * np.random.default_rng(seed).standard_normal(state[key].shape).astype(np.float32)
    return model_from_arrays(cfg, state)


OBS = {"obs_times": np.array([0.0, 1.0]), "obs_values": np.array([[0.0, 0.0], [1.0, 0.0]])}


def test_bad_requests_get_the_right_code_and_the_service_keeps_serving(mesh, small_model):
    _, server, client = mesh
    with ModelService(server, NS, fetch_latest=False) as service:
        service.load(SkillModel("reach", 1, small_model))
        key = KEYS.predict("reach")
        good = {**OBS, "n_steps": 20}
        assert wait_for(lambda: client.request(key, good))["mean"].shape == (20, 2)
        raw = msgpack.packb
        cases = [
            (b"\xc1\x00", "malformed"),
            (raw({"v": 2, **{k: v.tolist() for k, v in OBS.items()}, "n_steps": 5}), "bad_version"),
            (raw({"obs_times": [0.0], "obs_values": [[0.0, 0.0]], "n_steps": 5}), "bad_version"),
            ({**good, "obs_values": np.zeros((2, 3))}, "bad_shape"),
            ({**good, "obs_times": np.zeros((2, 1))}, "bad_shape"),
            ({**good, "task_params": np.zeros(2)}, "bad_shape"),
            ({**good, "obs_dims_mask": np.zeros((2, 2), dtype=bool)}, "bad_request"),
            ({"obs_times": [0.0]}, "bad_request"),
            ({**good, "n_steps": "many"}, "bad_request"),
            ({**good, "obs_times": np.array([0.0, 7.0])}, "bad_request"),  # outside the trained time range
            ({**good, "obs_values": np.array([[0.0, np.nan], [1.0, 0.0]])}, "non_finite"),
            (raw({"v": 1, "obs_times": [0.0, float("inf")], "obs_values": [[0, 0], [1, 0]], "n_steps": 5}), "non_finite"),
            ({**good, "n_steps": 10**9}, "too_large"),
            ({**OBS, "query_times": np.zeros(MAX_QUERY_STEPS + 1)}, "too_large"),
            ({**good, "n_samples": 10**6}, "too_large"),
            ({"batch": [good] * (MAX_BATCH + 1)}, "too_large"),
            ({"batch": [good, {**good, "obs_values": np.zeros((2, 5))}]}, "bad_shape"),
        ]
        for payload, code in cases:
            body = payload if isinstance(payload, bytes) else encode({"v": 1, **payload}, allow_non_finite=True)
            with pytest.raises(ClientError) as info:
                call(client.session, key, body, timeout=5.0)
            assert info.value.code == code, (payload if isinstance(payload, bytes) else sorted(payload), info.value)
            assert info.value.message
        # a skill with no model: a prompt unknown_skill, from the catch-all queryable
        for op in (client.info, lambda s: client.predict(s, [0.0], [[0.0, 0.0]], n_steps=5)):
            with pytest.raises(ClientError) as info:
                op("no_such_skill")
            assert info.value.code == "unknown_skill" and "no_such_skill" in info.value.message
        # ... and it still answers good queries
        assert client.request(key, good)["mean"].shape == (20, 2)


def test_prediction_over_zenoh_equals_in_process_exactly(mesh, small_model):
    _, server, client = mesh
    with ModelService(server, NS, fetch_latest=False) as service:
        service.load(SkillModel("reach", 4, small_model, data_hash="h", n_demos=6))
        ref = small_model.predict(OBS["obs_times"], OBS["obs_values"], n_steps=200)
        got = wait_for(lambda: client.predict("reach", OBS["obs_times"], OBS["obs_values"], n_steps=200))
        assert (got.skill, got.version) == ("reach", 4)
        for name in ("times", "mean", "std", "latent"):
            np.testing.assert_array_equal(getattr(got, name), getattr(ref, name), err_msg=name)
        # partial observation (only x at t=0.5), explicit query times, seeded samples, a batch
        mask = np.array([[True, False]])
        qt = np.linspace(0.1, 0.9, 7)
        ref2 = small_model.predict([0.5], [[0.3, 0.0]], query_times=qt, obs_dims_mask=mask)
        got2 = client.predict("reach", [0.5], [[0.3, 0.0]], query_times=qt, obs_dims_mask=mask, n_samples=3, seed=7)
        np.testing.assert_array_equal(got2.mean, ref2.mean)
        again = client.predict("reach", [0.5], [[0.3, 0.0]], query_times=qt, obs_dims_mask=mask, n_samples=3, seed=7)
        assert got2.samples.shape == (3, 7, 2)
        np.testing.assert_array_equal(got2.samples, again.samples)
        from clients.client import predict_request

        batch = client.predict_batch("reach", [predict_request(OBS["obs_times"], OBS["obs_values"], n_steps=200),
                                               predict_request([0.5], [[0.3, 0.0]], query_times=qt, obs_dims_mask=mask)])
        np.testing.assert_array_equal(batch[0].mean, ref.mean)
        np.testing.assert_array_equal(batch[1].mean, ref2.mean)
        info = client.info("reach")
        assert info["version"] == 4 and info["n_outputs"] == 2 and info["n_demos"] == 6
        assert info["time_range"] == [0.0, 1.0] and info["latent_dim"] == 32
        assert info["output_names"] == ["y0", "y1"] and info["data_hash"] == "h"
        assert client.skills() == ["reach"]


def test_hot_swap_under_load_never_fails_a_query_and_versions_only_increase(mesh, small_model):
    ep, server, client = mesh
    versions = {v: perturbed(small_model, 0.5 * v, v) for v in range(1, 6)}
    expected = {v: m.predict(OBS["obs_times"], OBS["obs_values"], n_steps=50).mean for v, m in versions.items()}
    with ModelService(server, NS, fetch_latest=False) as service, open_session("peer", None, [ep]) as learner:
        publish(learner, "reach", 1, versions[1])
        wait_for(lambda: client.predict("reach", OBS["obs_times"], OBS["obs_values"], n_steps=50))
        seen, errors, stop = [], [], threading.Event()

        def hammer():
            with ACNMPClient(NS, connect=[ep], timeout=5.0) as own:
                while not stop.is_set():
                    try:
                        p = own.predict("reach", OBS["obs_times"], OBS["obs_values"], n_steps=50)
                        seen.append(p.version)
                        # the answer is exactly that version's model: no half-swapped state
                        if not np.array_equal(p.mean, expected[p.version]):
                            errors.append(f"v{p.version}: mean differs")
                    except Exception as exc:  # any failure is what this test is about
                        errors.append(repr(exc))

        thread = threading.Thread(target=hammer)
        thread.start()
        try:
            for v in range(2, 6):
                time.sleep(0.25)
                publish(learner, "reach", v, versions[v])
            # a stale version arriving late must not roll the model back
            time.sleep(0.25)
            publish(learner, "reach", 2, versions[2])
            deadline = time.monotonic() + 10
            while (not seen or seen[-1] != 5) and time.monotonic() < deadline:
                time.sleep(0.05)
            time.sleep(0.2)
        finally:
            stop.set()
            thread.join(timeout=15)
        assert not errors, errors[:5]
        assert len(seen) > 10 and seen[-1] == 5
        assert all(a <= b for a, b in zip(seen, seen[1:])), "versions went backwards"
        assert service.swaps == 5 and service.registry.get("reach").version == 5


def test_restricted_service_fetches_latest_weights_and_serves_only_its_skills(mesh, small_model):
    ep, server, client = mesh
    with open_session("peer", None, [ep]) as learner:
        answered = []

        def latest(_req, query):
            skill = skill_from_key(str(query.key_expr))
            answered.append(skill)
            if skill != "reach":
                raise WireError("unknown_skill", skill)
            return encode_weights("reach", 7, small_model, n_demos=6)

        with declare_rpc(learner, KEYS.weights_latest("*"), latest):
            with ModelService(server, NS, skills=["reach", "pour"]) as service:
                info = wait_for(lambda: client.info("reach"))
                assert info["version"] == 7 and info["source"] == "learner"
                with pytest.raises(ClientError) as exc:
                    client.info("pour")
                assert exc.value.code == "unknown_skill" and "no model yet" in exc.value.message
                # weights of a skill this service does not serve, then newer weights of one it does,
                # from the same session: once the newer "reach" is served, "other" has had its chance
                publish(learner, "other", 1, small_model)
                publish(learner, "reach", 8, small_model)
                assert wait_for(lambda: _version_at_least(client, "reach", 8)) == 8
                assert service.registry.skills() == ["reach"]
                with pytest.raises(ClientError) as exc:
                    client.info("other")
                assert exc.value.code == "unknown_skill" and "served: reach" in exc.value.message
        assert "reach" in answered and "pour" in answered


def _version_at_least(client: ACNMPClient, skill: str, version: int) -> int:
    """The served version of ``skill`` once it is >= ``version`` (ClientError ``unavailable`` before,
    so :func:`wait_for` keeps asking)."""
    served = client.info(skill)["version"]
    if served < version:
        raise ClientError("unavailable", f"{skill} still at v{served}")
    return served


def test_service_config_serves_a_checkpoint_and_stops_cleanly(tmp_path, small_model, serving):
    path = save_checkpoint(small_model, tmp_path / "reach.pt", data_hash="d", meta={"version": 2, "n_demos": 6})
    ep = loopback_endpoint(free_port())
    with serving(ModelConfig(SessionOptions(NS, listen=[ep]), checkpoints=[f"reach={path}"])) as line:
        assert "skills: reach" in line  # the checkpoint is served before the service says it is live
        with ACNMPClient(NS, connect=[ep], timeout=5.0) as client:
            info = wait_for(lambda: client.info("reach"))
            assert info["version"] == 2 and info["source"].startswith("checkpoint:") and info["data_hash"] == "d"
            p = client.predict("reach", OBS["obs_times"], OBS["obs_values"], n_steps=30)
            np.testing.assert_array_equal(p.mean, small_model.predict(OBS["obs_times"], OBS["obs_values"], n_steps=30).mean)


def test_weights_whose_config_is_too_large_are_rejected_before_building(mesh, small_model):
    ep, server, client = mesh
    from services.model.weights import weights_message

    with ModelService(server, NS, fetch_latest=False) as service, open_session("peer", None, [ep]) as learner:
        publish(learner, "reach", 1, small_model)
        assert wait_for(lambda: client.info("reach"))["version"] == 1
        msg = weights_message("reach", 2, small_model)
        msg["config"]["encoder_widths"] = [16000, 16000]  # ~0.26 G parameters, a few KB message
        learner.put(KEYS.weights("reach"), encode(msg))
        deadline = time.monotonic() + 10
        while service.rejected < 1:
            assert time.monotonic() < deadline, "the weights were never rejected"
            time.sleep(0.05)
        assert client.info("reach")["version"] == 1


def test_concurrent_predicts_are_batched_and_each_gets_its_own_answer(mesh, small_model):
    ep, server, client = mesh
    n = 6
    # a long collection window: the batcher waits until all six have arrived (or 30 s)
    with ModelService(server, NS, fetch_latest=False, workers=2, batch_max=n, batch_window=30.0) as service:
        service.load(SkillModel("reach", 1, small_model))
        wait_for(lambda: client.info("reach"))
        starts = [(np.array([0.1 * (i + 1)]), np.array([[0.05 * i, 0.0]]), 20 + 10 * i) for i in range(n)]
        start, got, errors = threading.Barrier(n), [None] * n, []

        def one(i):
            t, v, steps = starts[i]
            try:
                with ACNMPClient(NS, connect=[ep], timeout=60.0) as own:
                    wait_for(lambda: own.info("reach"))
                    start.wait()
                    got[i] = own.predict("reach", t, v, n_steps=steps, n_samples=2, seed=i)
            except Exception as exc:  # reported below
                errors.append(repr(exc))

        threads = [threading.Thread(target=one, args=(i,)) for i in range(n)]
        for th in threads:
            th.start()
        for th in threads:
            th.join(timeout=90)
        assert not errors, errors
        assert service.batcher.largest > 1 and service.batcher.computed >= n
    for (t, v, steps), reply in zip(starts, got):
        ref = small_model.predict(t, v, n_steps=steps)
        assert reply.mean.shape == (steps, 2) and reply.samples.shape == (2, steps, 2)
        np.testing.assert_allclose(reply.mean, ref.mean, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(reply.std, ref.std, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("batch_max", [DEFAULT_BATCH_MAX, 1], ids=["batching", "no-batching"])
def test_two_model_processes_share_a_clients_predicts_and_a_gone_one_falls_back(mesh, small_model, monkeypatch,
                                                                               batch_max):
    """Issue 37: on the skill's key every model process computes every predict; a client that sees
    two processes serving the skill sends each predict to one of them, so each is computed once. A
    process the client still lists but that is gone is skipped through the skill's key."""
    from services.transport import wait_for_liveliness_gone

    ep, server, client = mesh
    with open_session("peer", connect=[ep]) as other, \
            ModelService(server, NS, fetch_latest=False, batch_max=batch_max) as a, \
            ModelService(other, NS, fetch_latest=False, batch_max=batch_max) as b:
        for service in (a, b):
            service.load(SkillModel("reach", 1, small_model))
        client.model_processes("reach", at_least=2)  # its subscriber sees both
        ref = small_model.predict(OBS["obs_times"], OBS["obs_values"], n_steps=50)
        got = [wait_for(lambda: client.predict("reach", OBS["obs_times"], OBS["obs_values"], n_steps=50))
               for _ in range(8)]
        assert sorted(client.model_processes("reach")) == sorted([a.zid, b.zid])
        for p in got:
            np.testing.assert_array_equal(p.mean, ref.mean)
        # every predict computed once, by one of the two, and both took some
        assert a.predicts_answered + b.predicts_answered == 8 and a.predicts_answered and b.predicts_answered
        # b goes; the client still lists it (as it would until the token's lease ends): every predict
        # sent to b ends 'unavailable' at once and is asked again on the skill's key, which a answers
        b_zid, before = b.zid, a.predicts_answered
        b.close()
        wait_for_liveliness_gone(client.session, KEYS.model_process_token("reach", b_zid))
        with client._processes_changed:
            # the client's own subscriber must have taken b out first, or it could do so after b is
            # put back here and the predicts would all go to the skill's key
            assert client._processes_changed.wait_for(lambda: b_zid not in client._processes["reach"], 10)
            client._processes["reach"].add(b_zid)
        import clients.client

        sent, real_call = [], clients.client.call
        monkeypatch.setattr(clients.client, "call", lambda s, key, *args, **kw: sent.append(key) or real_call(
            s, key, *args, **kw))
        for _ in range(4):
            np.testing.assert_array_equal(client.predict("reach", OBS["obs_times"], OBS["obs_values"],
                                                         n_steps=50).mean, ref.mean)
        assert a.predicts_answered == before + 4
        assert sorted(sent) == sorted([KEYS.predict_at("reach", a.zid)] * 2 + [KEYS.predict_at("reach", b_zid)] * 2)


def test_a_service_whose_session_lacks_zenohs_filter_still_refuses_an_oversized_predict_unread(small_model):
    """A session opened from a config file without the per-key filter (services/transport/payload_limits.py)
    gets the oversized query; the service answers ``too_large`` from its length, without decoding it."""
    import json

    import zenoh

    from services.transport.payload_limits import request_limit
    from services.transport.wire import error_from_payload

    ep = loopback_endpoint(free_port())

    def bare(**endpoints) -> zenoh.Config:  # zenoh's defaults: no low_pass_filter
        cfg = zenoh.Config()
        cfg.insert_json5("scouting/multicast/enabled", "false")
        for key, value in endpoints.items():
            cfg.insert_json5(f"{key}/endpoints", json.dumps(value))
        return cfg

    with open_session(config=bare(listen=[ep])) as server, open_session(config=bare(connect=[ep])) as raw:
        with ModelService(server, NS, fetch_latest=False) as service:
            service.load(SkillModel("reach", 1, small_model))
            key = KEYS.predict("reach")
            body = b"\x00" * (request_limit(key) + 1)  # not even msgpack: it is never read
            deadline = time.monotonic() + 10
            while True:
                replies = list(raw.get(key, payload=body, timeout=30))
                if replies or time.monotonic() > deadline:
                    break
                time.sleep(0.05)  # the raw session may not know the queryable yet
            (reply,) = replies
            err = error_from_payload(reply.err.payload.to_bytes())
            assert err.code == "too_large" and f"at most {request_limit(key)} bytes" in err.message, err

