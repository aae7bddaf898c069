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
