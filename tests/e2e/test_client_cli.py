"""``acnmp query info|predict|skills`` against a live model service (a thread with its own session)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from acnmp_core.model.checkpoint import save_checkpoint
from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.model.training import TrainConfig, train
from clients.cli import main
from services.model.service import ModelConfig
from services.transport import SessionOptions, free_port, loopback_endpoint

NS = "clitest"


@pytest.fixture(scope="module")
def live_service(e1_demos, tmp_path_factory, serving):
    """A model service serving skill 'reach' from a checkpoint; yields (endpoint, model)."""
    model = CNMP(CNMPConfig(n_outputs=2, encoder_widths=(32, 32), decoder_widths=(32, 32),
                            output_names=("x", "y")), seed=1)
    train(model, e1_demos, TrainConfig(steps=50), seed=1, progress=False)
    path = save_checkpoint(model.eval(), tmp_path_factory.mktemp("ckpt") / "reach.pt",
                           data_hash="cafe", meta={"version": 3, "n_demos": len(e1_demos)})
    ep = loopback_endpoint(free_port())
    with serving(ModelConfig(SessionOptions(NS, listen=[ep]), checkpoints=[str(path)])):
        yield ep, model


def cli(capsys, *argv) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_query_info_and_skills(live_service, capsys):
    ep, _ = live_service
    code, out, _ = cli(capsys, "query", "info", "--skill", "reach", "-n", NS, "--connect", ep)
    assert code == 0
    assert "skill reach version 3" in out and "x, y" in out and "6 demos" in out and "cafe" in out
    # the model E1's demonstrations chose, and why, in the skill's own words
    assert f"model: {live_service[1].config.prior_choice.reason}" in out and "held-out error" in out
    code, out, _ = cli(capsys, "query", "info", "--skill", "reach", "-n", NS, "--connect", ep, "--json")
    info = json.loads(out)
    assert code == 0 and info["version"] == 3 and info["output_names"] == ["x", "y"]
    assert info["config"]["prior"] == info["config"]["prior_choice"]["chosen"] in ("trend", "none")
    code, out, _ = cli(capsys, "query", "skills", "-n", NS, "--connect", ep, "--json")
    assert code == 0 and json.loads(out) == ["reach"]


def test_query_predict_matches_the_model(live_service, capsys):
    ep, model = live_service
    code, out, _ = cli(capsys, "query", "predict", "--skill", "reach", "-n", NS, "--connect", ep,
                       "--obs", "0:0,0", "--obs", "1:1,0", "--steps", "200", "--json")
    assert code == 0
    reply = json.loads(out)
    ref = model.predict([0.0, 1.0], [[0.0, 0.0], [1.0, 0.0]], n_steps=200)
    np.testing.assert_array_equal(np.array(reply["mean"]), ref.mean)  # JSON floats round-trip exactly
    assert reply["version"] == 3 and len(reply["times"]) == 200
    # masked dimension, explicit times, samples; human-readable output
    code, out, _ = cli(capsys, "query", "predict", "-s", "reach", "-n", NS, "--connect", ep,
                       "--obs-json", "[[0.5, [0.3, null]]]", "--times", "0,0.5,1", "--samples", "2")
    assert code == 0 and "3 steps x 2 dims" in out and "2 samples" in out and "t=0.5" in out


def test_query_errors_are_reported_with_their_code(live_service, capsys):
    ep, _ = live_service
    code, _, err = cli(capsys, "query", "predict", "-s", "reach", "-n", NS, "--connect", ep, "--obs", "0:0,0,0")
    assert code == 1 and "bad_shape" in err and "obs_values" in err
    code, _, err = cli(capsys, "query", "info", "-s", "nothing", "-n", NS, "--connect", ep)
    assert code == 1 and "unknown_skill" in err
    code, _, err = cli(capsys, "query", "predict", "-s", "reach", "-n", NS, "--connect", ep, "--obs", "zero")
    assert code == 2 and "TIME:V1" in err


def test_no_reachable_model_service_is_told_apart_from_no_skill(live_service, capsys):
    ep, _ = live_service
    dead = loopback_endpoint(free_port())  # nothing listens there
    code, _, err = cli(capsys, "query", "info", "-n", NS, "--connect", dead)
    assert code == 1 and "unavailable: no model service is reachable" in err
    code, out, _ = cli(capsys, "query", "skills", "-n", NS, "--connect", dead)
    assert code == 0 and "no model service is reachable" in out
    # the live service is found, and its one skill is the default
    code, out, _ = cli(capsys, "query", "info", "-n", NS, "--connect", ep)
    assert code == 0 and "skill reach version 3" in out
