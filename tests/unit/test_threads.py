"""The library's torch thread default (issue 36, row 4): training runs at one thread whatever the
caller's torch setting, restores that setting, and ACNMP_TORCH_THREADS / set_training_threads change it."""
from __future__ import annotations

import pytest
import torch

from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.model.optim_step import FusedAdam
from acnmp_core.model.training import TrainConfig, train
from acnmp_core.threads import set_training_threads, training_threads


def _threads_seen_by_training(monkeypatch, e1_demos) -> int:
    seen = []
    real = FusedAdam.step

    def step(self, *args, **kwargs):
        seen.append(torch.get_num_threads())
        return real(self, *args, **kwargs)

    monkeypatch.setattr(FusedAdam, "step", step)
    train(CNMP(CNMPConfig(n_outputs=2, encoder_widths=(8,), decoder_widths=(8,))), e1_demos, TrainConfig(steps=3),
          progress=False)
    assert len(set(seen)) == 1
    return seen[0]


def test_training_uses_one_thread_and_gives_the_callers_setting_back(monkeypatch, e1_demos):
    monkeypatch.delenv("ACNMP_TORCH_THREADS", raising=False)
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        assert _threads_seen_by_training(monkeypatch, e1_demos) == 1
        assert torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(before)


def test_the_environment_and_the_setter_choose_another_count(monkeypatch, e1_demos):
    monkeypatch.setenv("ACNMP_TORCH_THREADS", "2")
    assert training_threads() == 2 and _threads_seen_by_training(monkeypatch, e1_demos) == 2
    set_training_threads(1)
    try:
        assert training_threads() == 1  # the setter wins over the environment
    finally:
        set_training_threads(None)
    monkeypatch.setenv("ACNMP_TORCH_THREADS", "many")
    with pytest.raises(ValueError, match="ACNMP_TORCH_THREADS: expected an integer >= 1, got 'many'"):
        training_threads()
    with pytest.raises(ValueError, match="threads"):
        set_training_threads(0)
