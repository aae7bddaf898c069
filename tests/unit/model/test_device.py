"""``--device cpu|cuda|auto``: names resolve to what this machine has (a missing CUDA is one line),
training, adaptation and predicts run on the model's device with the CPU's numbers, checkpoints
load on any device, and the learner and the model service refuse a device that is not here before
they touch anything. Only the CPU exists on the test machines; the CUDA rows of
benchmarks/performance/bench_device.py appear wherever one does."""
from __future__ import annotations

import copy

import numpy as np
import pytest
import torch

from acnmp_core.model.checkpoint import load_checkpoint, save_checkpoint
from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.model.device import DEVICES, available_devices, resolve_device
from acnmp_core.model.training import TrainConfig, train
from clients.cli import main

NO_CUDA = not torch.cuda.is_available()
SMALL = CNMPConfig(n_outputs=2, encoder_widths=(32, 32), decoder_widths=(32, 32))


def test_names_resolve_to_the_devices_here_and_a_missing_one_is_a_one_line_error():
    assert resolve_device("cpu") == resolve_device(None) == torch.device("cpu")
    assert resolve_device("auto") == torch.device("cuda" if torch.cuda.is_available() else "cpu")
    assert available_devices()[0] == torch.device("cpu") and set(DEVICES) == {"cpu", "cuda", "auto"}
    with pytest.raises(ValueError, match="expected one of cpu, cuda, auto"):
        resolve_device("gpu")
    if NO_CUDA:
        with pytest.raises(ValueError, match="sees no CUDA device here") as info:
            resolve_device("cuda")
        assert "\n" not in str(info.value)


def test_training_on_a_named_device_gives_the_numbers_of_training_where_the_model_is(e1_demos):
    a, b = CNMP(SMALL, seed=0), CNMP(SMALL, seed=0)
    train(a, e1_demos, TrainConfig(steps=30), seed=0, progress=False)
    train(b, e1_demos, TrainConfig(steps=30), seed=0, progress=False, device="auto")
    assert b.device == resolve_device("auto")
    t = e1_demos[0].times
    pa, pb = a.predict(t[:2], e1_demos[0].values[:2], None, t), b.predict(t[:2], e1_demos[0].values[:2], None, t)
    assert isinstance(pb.mean, np.ndarray)
    if b.device.type == "cpu":
        assert np.array_equal(pa.mean, pb.mean) and np.array_equal(pa.std, pb.std)
    else:  # another device's kernels round differently
        np.testing.assert_allclose(pa.mean, pb.mean, atol=1e-4)


def test_a_checkpoint_loads_on_every_device_and_predicts_alike(tmp_path, small_model, e1_demos):
    path = save_checkpoint(copy.deepcopy(small_model).to_device("auto"), tmp_path / "m.pt")
    t, v = e1_demos[1].times, e1_demos[1].values
    want = small_model.predict(t[:3], v[:3], None, t)
    for device in available_devices():
        model, _ = load_checkpoint(path)
        got = model.to_device(device).predict(t[:3], v[:3], None, t)
        assert model.device == device
        np.testing.assert_allclose(got.mean, want.mean, atol=0 if device.type == "cpu" else 1e-4)
        batch = model.predict_queries([model.make_query(t[:3], v[:3], None, t)] * 2)
        np.testing.assert_allclose(batch[1].mean, want.mean, atol=1e-5)


def test_training_with_the_optimizer_of_a_model_elsewhere_is_refused(e1_demos):
    if NO_CUDA:
        pytest.skip("needs a second device: only the CPU here")
    model = CNMP(SMALL, seed=0)
    opt = torch.optim.Adam(model.parameters())
    with pytest.raises(ValueError, match="optimizer"):
        train(model, e1_demos, TrainConfig(steps=2), progress=False, optimizer=opt, device="cuda")


@pytest.mark.skipif(not NO_CUDA, reason="CUDA is present here")
@pytest.mark.parametrize("process", ["learner", "model"])
def test_a_service_asked_for_a_missing_device_stops_at_its_command_line(process, tmp_path, capsys):
    assert main(["serve", process, "--device", "cuda", "--namespace", "dev"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "sees no CUDA device here" in err and "--device" in err


def test_the_learner_core_trains_and_adapts_where_it_is_told(tmp_path):
    from acnmp_core.adaptation.config import AdaptConfig
    from acnmp_core.experiments.viapoint import make_setup
    from acnmp_core.jobs.adapt import AdaptJob
    from services.learner.core import LearnerCore, TrainSpec
    from services.worker.core import ExecutedBatch

    setup = make_setup()

    class Local:
        def evaluate(self, trajectories, times, task_params=None):
            return ExecutedBatch.of(setup.task.evaluate(trajectories, times, task_params), ["w0"] * len(trajectories))

    core = LearnerCore(tmp_path / "state", device="auto", evaluator_for=lambda job: Local()).start()
    try:
        state = core.train_skill("e1", TrainSpec(setup.demos, SMALL, TrainConfig(steps=20), seed=0))
        assert state.model.device == resolve_device("auto")
        record = core.submit("e1", AdaptJob(setup.target, "viapoint", "point2d", setup.task_config,
                                            AdaptConfig(max_rollouts=6), seed=0, commit=True, assimilate_steps=5))
        assert core.wait_idle(120)
        status = core.status(record.job)
    finally:
        core.close()
    assert status["state"] == "done", status["error"]
    assert core.skills["e1"].model.device == resolve_device("auto")
    if NO_CUDA:  # a device that is not here: refused before the state directory is locked
        with pytest.raises(ValueError, match="no CUDA device"):
            LearnerCore(tmp_path / "state", device="cuda", evaluator_for=lambda job: Local())
        LearnerCore(tmp_path / "state", evaluator_for=lambda job: Local()).close()
