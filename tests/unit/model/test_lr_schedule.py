"""The learning-rate decay of training and assimilation, and an assimilation that continues an optimiser."""
import copy

import numpy as np
import pytest
import torch

from acnmp_core.adaptation.assimilation import AssimilationConfig, assimilate
from acnmp_core.data.demos import Demonstration
from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.model.training import TrainConfig, cosine_lr, train


def test_cosine_lr_runs_from_lr_to_lr_final_and_only_falls():
    rates = [cosine_lr(1e-3, 1e-5, s, 100) for s in range(1, 101)]
    assert rates[0] == pytest.approx(1e-3) and rates[-1] == pytest.approx(1e-5)
    assert all(a >= b for a, b in zip(rates, rates[1:]))
    assert cosine_lr(1e-3, None, 50, 100) == 1e-3  # no decay asked


@pytest.mark.parametrize("bad", [2e-3, 0.0, -1e-5, True, "1e-5"])
def test_a_final_rate_outside_0_lr_is_refused(bad):
    with pytest.raises(ValueError, match="lr_final"):
        TrainConfig(lr=1e-3, lr_final=bad)
    with pytest.raises(ValueError, match="lr_final"):
        AssimilationConfig(lr=1e-3, lr_final=bad)


def test_training_with_a_decay_ends_at_the_final_rate_and_differs_from_constant(e1_demos):
    opt_models = []
    for lr_final in (None, 1e-5):
        model = CNMP(CNMPConfig(n_outputs=2), seed=0)
        opt = torch.optim.Adam(model.parameters(), lr=1e-3, fused=True)
        train(model, e1_demos, TrainConfig(steps=40, val_every=1000, lr_final=lr_final), seed=0, progress=False,
              optimizer=opt)
        opt_models.append((opt, model))
    assert opt_models[0][0].param_groups[0]["lr"] == 1e-3
    assert opt_models[1][0].param_groups[0]["lr"] == pytest.approx(1e-5)
    a, b = (torch.cat([p.detach().flatten() for p in m.parameters()]) for _, m in opt_models)
    assert not torch.equal(a, b)


def test_assimilation_continues_a_given_optimiser(e1_model, e1_demos):
    model = copy.deepcopy(e1_model)
    opt = torch.optim.Adam(model.parameters(), lr=1e-3, fused=True)
    train(model, e1_demos, TrainConfig(steps=5, val_every=1000), seed=0, progress=False, optimizer=opt,
          fit_normalization=False)
    steps_before = float(next(iter(opt.state.values()))["step"])
    d = e1_demos[0]
    solution = Demonstration(np.asarray(d.times), np.asarray(d.values) + 0.01)
    _, losses = assimilate(model, e1_demos, solution, AssimilationConfig(steps=7, lr=3e-4, lr_final=3e-5),
                           optimizer=opt)
    assert len(losses) == 7
    assert float(next(iter(opt.state.values()))["step"]) == steps_before + 7  # the moments carried on
    assert opt.param_groups[0]["lr"] == pytest.approx(3e-5)
