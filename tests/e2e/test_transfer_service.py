"""E4's service shape on a real deployment (learner, model service and recorder as child processes,
zenoh on loopback): a small pair trained as a learner job, the model service's transfer query equal
to the library's TransferPair.transfer on the same weights (and on a pair trained in this process
with the same seed), ``acnmp query transfer``, and both robots' latents in the recording."""
from __future__ import annotations

import json

import numpy as np

from acnmp_core.data.demos import DemoSet
from acnmp_core.jobs.transfer import PairTrainJob
from acnmp_core.transfer.pair import TransferConfig, TransferPair, train_pair
from clients.cli import main
from clients.client import ACNMPClient
from services.launcher import LocalDeployment
from services.recording.replay import summarize

NS = "e4svc"
T = np.linspace(0.0, 1.0, 30)
CFG = TransferConfig(latent_weight=10.0, steps=40, batch_size=4, widths=(16, 16))


def _demos(n_dims: int) -> DemoSet:
    values = np.stack([np.stack([np.sin(T * k + j) for j in range(n_dims)], axis=1) for k in range(1, 5)])
    return DemoSet.from_arrays(T, values)


def test_a_pair_trained_by_the_learner_answers_transfer_queries_like_the_library(tmp_path, capsys, verify_rrd):
    demos_a, demos_b = _demos(3), _demos(4)
    rrd = tmp_path / "e4svc.rrd"
    obs_t, obs_v = T[[0, 15, 29]], demos_a[2].values[[0, 15, 29]]
    with LocalDeployment(NS, workers=0, record=rrd, state_dir=tmp_path / "state") as dep, \
            ACNMPClient(NS, session=dep.session, timeout=30) as client:
        job = client.train_pair("pp", PairTrainJob(demos_a, demos_b, CFG, seed=3, robot_a="planar3",
                                                   robot_b="planar4"))
        status = client.wait_job(job, timeout=120, progress=False)
        assert (status["state"], status["kind"], status["iteration"], status["committed_version"]) == \
            ("done", "train_pair", 40, 0), status
        weights = client.weights("pp")
        served = TransferPair.from_models(weights.model, weights.partner)
        got = client.transfer("pp", obs_t, obs_v, T)  # the model service may still be loading: retried
        ref = served.transfer(obs_t, obs_v, T)
        assert got.mean.shape == (30, 4) and got.version == 0
        np.testing.assert_array_equal(got.mean, ref.mean)
        np.testing.assert_array_equal(got.std, ref.std)
        np.testing.assert_array_equal(got.latent, ref.latent)
        mine = TransferPair(3, 4, CFG, seed=3)  # the learner ran the library's train_pair with these seeds
        train_pair(mine, demos_a, demos_b, CFG, seed=3)
        np.testing.assert_array_equal(got.mean, mine.transfer(obs_t, obs_v, T).mean)

        base = ["query", "transfer", "-s", "pp", "-n", NS, "--connect", dep.anchor]
        obs = [arg for t, v in zip(obs_t, obs_v) for arg in ("--obs", f"{t}:" + ",".join(map(str, v)))]
        assert main([*base, *obs, "--times", ",".join(map(str, T)), "--json"]) == 0
        reply = json.loads(capsys.readouterr().out)
        np.testing.assert_allclose(np.array(reply["mean"]), ref.mean, rtol=0, atol=1e-12)  # --obs is text
        assert main([*base, "--obs", "0:0,0,0,0", "--steps", "10"]) == 1  # robot B's D: one line, its code
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "bad_shape" in err[0] and "obs_values" in err[0]
        assert main([*base, "--obs", "zero"]) == 2
        assert "TIME:V1" in capsys.readouterr().err
    verify_rrd(rrd)
    summary = summarize(rrd)
    assert summary["skills"]["pp"]["latents"] == 8  # 4 demonstrations of each robot
    assert summary["jobs"][job]["last_progress"]["state"] == "done"
