"""The learner's server-side limits: a train or adapt request over a limit is refused with
``too_large`` naming the setting, from its settings alone; the paper's requests pass."""
from __future__ import annotations

import numpy as np
import pytest

from acnmp_core.adaptation.config import AdaptConfig
from acnmp_core.experiments.viapoint import make_setup
from acnmp_core.jobs.adapt import AdaptJob
from services.learner.limits import LearnerLimits, check_job
from services.learner.service import parse_train_request
from services.transport import WireError


@pytest.fixture(scope="module")
def setup():
    return make_setup()


def train_request(setup, **train):
    demos = setup.demos
    return {"v": 1, "times": np.stack([d.times for d in demos]), "values": np.stack([d.values for d in demos]),
            "train": {"steps": 3000, **train}}


def job(setup, assimilate_steps=1000, **config) -> AdaptJob:
    return AdaptJob(setup.target, "viapoint", "point2d", setup.task_config, AdaptConfig(**config),
                    assimilate_steps=assimilate_steps)


def refused(fn) -> str:
    with pytest.raises(WireError) as info:
        fn()
    assert info.value.code == "too_large", info.value
    return info.value.message


def test_a_paper_sized_train_request_passes_and_absurd_ones_are_too_large(setup):
    assert parse_train_request(train_request(setup)).train_cfg.steps == 3000
    assert "train.steps: 1000000000" in refused(lambda: parse_train_request(train_request(setup, steps=10**9)))
    assert "train.batch_size" in refused(lambda: parse_train_request(train_request(setup, batch_size=10**6)))
    assert "points per step" in refused(lambda: parse_train_request(train_request(setup, n_targets=10**7)))
    assert "points in all" in refused(lambda: parse_train_request(train_request(setup, steps=99_000, batch_size=1024)))
    assert "val_episodes" in refused(lambda: parse_train_request(train_request(setup, val_episodes=10**7)))
    huge = {**train_request(setup), "model": {"encoder_widths": [16000, 16000]}}
    assert "parameters" in refused(lambda: parse_train_request(huge))
    # a learner may be given other limits
    assert "at most 100 " in refused(lambda: parse_train_request(train_request(setup), LearnerLimits(max_train_steps=100)))


def test_a_default_job_passes_and_absurd_budgets_are_too_large(setup):
    limits = LearnerLimits()
    check_job(job(setup), limits)  # AdaptConfig's defaults: 200 roll-outs
    assert "config.max_rollouts" in refused(lambda: check_job(job(setup, max_rollouts=10**9), limits))
    assert "assimilate_steps" in refused(lambda: check_job(job(setup, assimilate_steps=10**9), limits))
    assert "roll-outs per batch" in refused(lambda: check_job(job(setup, noisy_per_iter=20_000), limits))
    assert "updates" in refused(lambda: check_job(job(setup, max_rollouts=10_000, noisy_per_iter=1,
                                                       max_reuse=1000), limits))
    assert "sl_batch_size" in refused(lambda: check_job(job(setup, sl_batch_size=10**6), limits))
