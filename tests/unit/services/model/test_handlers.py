"""The model service's zenoh-free parts: the weights message and the hot-swap registry."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from services.model.handlers import ModelRegistry, SkillModel, handle_predict
from services.model.weights import decode_weights, encode_weights, weights_message
from services.transport import WireError, encode

OBS = {"obs_times": np.array([0.0, 1.0]), "obs_values": np.array([[0.0, 0.0], [1.0, 0.0]])}


def test_weights_message_round_trip_and_rejects_bad_ones(small_model):
    w = decode_weights(encode_weights("reach", 3, small_model, data_hash="abc", n_demos=6))
    assert (w.skill, w.version, w.data_hash, w.n_demos) == ("reach", 3, "abc", 6)
    a = small_model.predict(OBS["obs_times"], OBS["obs_values"], n_steps=50)
    b = w.model.predict(OBS["obs_times"], OBS["obs_values"], n_steps=50)
    np.testing.assert_array_equal(a.mean, b.mean)
    msg = weights_message("reach", 3, small_model)
    bad_shape = {**msg, "state": {**msg["state"], "encoder.0.bias": np.zeros(7, np.float32)}}
    missing = {**msg, "state": {k: v for k, v in msg["state"].items() if k != "fitted"}}
    for bad, code in [(bad_shape, "bad_shape"), (missing, "bad_request"),
                      ({**msg, "config": {**msg["config"], "bogus": 1}}, "bad_request"),
                      ({**msg, "skill": "a/b"}, "bad_request"), ({**msg, "version": -1}, "bad_request")]:
        with pytest.raises(WireError) as info:
            decode_weights(encode(bad))
        assert info.value.code == code, info.value


def test_registry_in_process_keeps_the_entry_a_query_started_with(small_model):
    reg = ModelRegistry()
    reg.offer(SkillModel("reach", 1, small_model))
    entry = reg.get("reach")
    assert reg.offer(SkillModel("reach", 2, copy.deepcopy(small_model)))
    assert not reg.offer(SkillModel("reach", 2, small_model))
    assert entry.version == 1 and reg.get("reach").version == 2
    assert handle_predict(reg, "reach", {**OBS, "n_steps": 5})["version"] == 2


def test_a_predict_without_payload_is_malformed(small_model):
    reg = ModelRegistry()
    reg.offer(SkillModel("reach", 1, small_model))
    with pytest.raises(WireError) as info:
        handle_predict(reg, "reach", None)
    assert info.value.code == "malformed"


def test_a_weights_config_is_sized_before_anything_is_allocated(small_model, monkeypatch):
    import services.model.weights as weights

    msg = weights_message("reach", 3, small_model)
    huge = {**msg, "config": {**msg["config"], "encoder_widths": [16000, 16000]}}  # ~0.26 G parameters

    def never(*_a, **_k):
        raise AssertionError("the model was built before its size was checked")

    monkeypatch.setattr(weights, "model_from_arrays", never)
    with pytest.raises(WireError) as info:
        decode_weights(encode(huge))
    assert info.value.code == "too_large" and "parameters" in info.value.message
    assert len(encode(huge)) < 64_000  # the small message the issue describes, not a big one


def _served(model) -> ModelRegistry:
    reg = ModelRegistry()
    reg.offer(SkillModel("reach", 1, model))
    return reg


def test_a_batch_is_costed_as_a_whole_before_any_forward_pass(small_model, monkeypatch):
    model = copy.deepcopy(small_model)

    def never(*_a, **_k):
        raise AssertionError("computed before the request's cost was checked")

    monkeypatch.setattr(model, "predict_query", never)
    reg = _served(model)
    # the request: 64 items, each within every per-item bound (N=4096, T=20000, S*T*D=4M)
    heavy = {"obs_times": np.linspace(0, 1, 4096), "obs_values": np.zeros((4096, 2)), "n_steps": 20_000,
             "n_samples": 100}
    light = {**OBS, "n_steps": 20_000}
    for request, what in [({"batch": [heavy] * 64}, "points"), ({"batch": [light] * 5}, "points"),
                          ({"batch": [{**OBS, "n_steps": 10_000, "n_samples": 200}] * 2}, "sampled values")]:
        with pytest.raises(WireError) as info:
            handle_predict(reg, "reach", request)
        assert info.value.code == "too_large" and what in info.value.message, info.value


def test_the_reply_size_estimate_bounds_the_encoded_reply(small_model):
    from services.model.handlers import REPLY_OVERHEAD, parse_predict, run_predict

    entry = _served(small_model).get("reach")
    cfg = small_model.config
    for request in [{**OBS, "n_steps": 2}, {**OBS, "n_steps": 500, "n_samples": 7, "seed": 1},
                    {"obs_times": [0.5], "obs_values": [[0.1, 0.2]], "query_times": np.linspace(0, 1, 33)}]:
        item = parse_predict(entry, request)
        estimate = 8 * item.reply_values(cfg.n_outputs, cfg.latent_dim) + REPLY_OVERHEAD
        actual = len(encode(run_predict(entry, item)))
        assert actual <= estimate <= actual + REPLY_OVERHEAD, (request.keys(), actual, estimate)


def _submit(batcher, reg, skill, request, deadline=None):
    """What the model service's predict queryable does: queue the request with its preparation."""
    from services.model.handlers import prepare_predict

    return batcher.submit(lambda: prepare_predict(reg, skill, request), deadline)


def test_batched_predicts_answer_each_its_own_request_in_one_forward_pass(small_model):
    from services.model.batching import PredictBatcher

    reg = ModelRegistry()
    reg.offer(SkillModel("reach", 1, small_model))
    requests = [{**OBS, "n_steps": 50}, {"obs_times": [0.5], "obs_values": [[0.3, 0.1]], "n_steps": 7},
                {**OBS, "query_times": np.linspace(0.2, 0.8, 30), "n_samples": 3, "seed": 5},
                {"obs_times": [0.1, 0.4, 0.9], "obs_values": np.ones((3, 2)), "n_steps": 200}]
    # a long window: the batcher thread waits until it has all four, so they run as one pass
    with PredictBatcher(max_items=len(requests), window=60.0) as batcher:
        futures = [_submit(batcher, reg, "reach", r) for r in requests]
        got = [f.result(timeout=60) for f in futures]
    assert (batcher.passes, batcher.computed, batcher.largest) == (1, 4, 4)
    for request, reply in zip(requests, got):
        ref = handle_predict(reg, "reach", request)
        assert set(reply) == set(ref) and reply["version"] == 1
        for key in ("times", "mean", "std", "latent") + (("samples",) if "n_samples" in request else ()):
            assert reply[key].shape == ref[key].shape, key
            np.testing.assert_allclose(reply[key], ref[key], rtol=1e-5, atol=1e-5, err_msg=key)


def test_the_batcher_drops_expired_predicts_and_never_mixes_models(small_model):
    import time

    from services.model.batching import PredictBatcher
    from services.transport.rpc import Expired

    reg = ModelRegistry()
    reg.offer(SkillModel("a", 1, small_model))
    reg.offer(SkillModel("b", 1, copy.deepcopy(small_model)))
    batcher = PredictBatcher(max_items=8, window=0.0)
    try:
        late = _submit(batcher, reg, "a", {**OBS, "n_steps": 5}, deadline=time.monotonic() - 1.0)
        assert isinstance(late.exception(timeout=30), Expired)
        pending = [_submit(batcher, reg, s, {**OBS, "n_steps": 5}) for s in "abab"]
        replies = [f.result(timeout=30) for f in pending]
        # a bad request fails its own future only, with its code; an explicit batch needs no pass
        bad = _submit(batcher, reg, "a", {**OBS, "n_steps": 10**6})
        good = _submit(batcher, reg, "a", {**OBS, "n_steps": 5})
        both = _submit(batcher, reg, "a", {"batch": [{**OBS, "n_steps": 5}] * 2})
        assert bad.exception(timeout=30).code == "too_large"
        assert good.result(timeout=30)["skill"] == "a" and len(both.result(timeout=30)["results"]) == 2
    finally:
        batcher.close()
    assert [r["skill"] for r in replies] == list("abab") and batcher.expired == 1
    assert batcher.computed == 5 and batcher.passes >= 3  # a pass holds one model only
    with pytest.raises(WireError) as info:
        _submit(batcher, reg, "a", {**OBS, "n_steps": 5})
    assert info.value.code == "unavailable"  # closed


def test_a_light_predict_taken_with_heavy_ones_is_computed_first(small_model):
    import threading

    from services.model.batching import PredictBatcher

    reg = ModelRegistry()
    reg.offer(SkillModel("a", 1, small_model))
    heavy = {"obs_times": np.linspace(0, 1, 1000), "obs_values": np.zeros((1000, 2)), "n_steps": 2000}
    order, lock = [], threading.Lock()

    def done(name):
        def note(_future):
            with lock:
                order.append(name)
        return note

    # the window holds the thread until all four are queued: they are taken in one round
    with PredictBatcher(max_items=4, window=60.0) as batcher:
        futures = []
        for name, request in [("heavy1", heavy), ("heavy2", heavy), ("light", {**OBS, "n_steps": 5}),
                              ("heavy3", heavy)]:
            futures.append(_submit(batcher, reg, "a", request))
            futures[-1].add_done_callback(done(name))
        for f in futures:
            f.result(timeout=60)
    assert order[0] == "light" and batcher.passes == 4  # each heavy one alone (over the pass's points)


def test_two_batcher_threads_answer_every_predict_with_its_own_model(small_model):
    from services.model.batching import PredictBatcher

    reg = ModelRegistry()
    reg.offer(SkillModel("a", 1, small_model))
    reg.offer(SkillModel("b", 2, copy.deepcopy(small_model)))
    requests = [("ab"[i % 2], {"obs_times": [0.1 * (i % 9)], "obs_values": [[0.05 * i, 0.0]], "n_steps": 3 + i})
                for i in range(24)]
    with PredictBatcher(max_items=5, threads=2) as batcher:
        futures = [_submit(batcher, reg, skill, request) for skill, request in requests]
        replies = [f.result(timeout=60) for f in futures]
    assert batcher.computed == len(requests)
    for (skill, request), reply in zip(requests, replies):
        ref = handle_predict(reg, skill, request)
        assert (reply["skill"], reply["version"]) == (skill, ref["version"])
        np.testing.assert_allclose(reply["mean"], ref["mean"], rtol=1e-5, atol=1e-5)
