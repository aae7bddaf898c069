"""Shared fixtures: one small trained E1 model per test session (training costs seconds)."""
from __future__ import annotations

import os

import pytest
import torch

os.environ.setdefault("RERUN_ANALYTICS", "0")
torch.set_num_threads(1)


@pytest.fixture(scope="session")
def e1_demos():
    from acnmp_core.tasks.viapoint import obstacle_demos

    return obstacle_demos()


@pytest.fixture(scope="session")
def e1_model(e1_demos):
    """A CNMP trained on the E1 demonstrations (3000 steps, seed 0). Tests must deep-copy before
    changing it."""
    from acnmp_core.cnmp import CNMP, CNMPConfig
    from acnmp_core.training import TrainConfig, train

    model = CNMP(CNMPConfig(n_outputs=2), seed=0)
    train(model, e1_demos, TrainConfig(steps=3000), seed=0, progress=False)
    return model
