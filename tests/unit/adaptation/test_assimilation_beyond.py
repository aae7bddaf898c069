"""A solution assimilated beyond the demonstrations' range stays learnt (issue 71): the skill answers
its condition within the task's tolerance afterwards and the demonstrations at the edge keep their
error within 2x (the default's two models); the range the network sees widens to the solution's,
and the linear path takes it into its statistics."""
from __future__ import annotations

import numpy as np
import pytest

from acnmp_core.adaptation.assimilation import assimilate
from acnmp_core.adaptation.config import AdaptTarget, AssimilationConfig
from acnmp_core.data.demos import DemoSet, Demonstration
from acnmp_core.model.checkpoint import load_checkpoint, save_checkpoint
from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.model.training import TrainConfig, train

T = np.linspace(0.0, 1.0, 60)
SMALL = dict(encoder_widths=(64, 64), decoder_widths=(64, 64))
TOLERANCE = 0.02  # the task's, raw units (RMS)


def _shape(t):
    return np.exp(-((t - 0.3) ** 2) / 0.02) - 0.5 * np.exp(-((t - 0.7) ** 2) / 0.01)


CS = np.linspace(0.0, 0.6, 7)
DEMOS = DemoSet.from_arrays(T, np.stack([(0.5 + c) * _shape(T)[:, None] for c in CS]), CS[:, None])
# what an adaptation found at c = 0.9: not the family's linear extrapolation (a bump more)
SOLUTION = (1.4 * _shape(T) + 0.15 * np.exp(-((T - 0.5) ** 2) / 0.005))[:, None]


def _error(model, c, truth):
    return float(np.sqrt(np.mean((model.predict([0.0], truth[:1], [c], T).mean - truth) ** 2)))


@pytest.mark.parametrize("prior", ["trend", "none"])
def test_a_solution_beyond_the_range_is_answered_there_and_the_edge_keeps_its_error(prior, tmp_path):
    model = CNMP(CNMPConfig(n_outputs=1, n_task_params=1, prior=prior), seed=0)  # the default size
    train(model, DEMOS, TrainConfig(steps=2000), seed=0, progress=False)
    edge = DEMOS[-1].values
    miss, edge_before = _error(model, 0.9, SOLUTION), _error(model, 0.6, edge)
    assert miss > 2 * TOLERANCE  # the skill did not answer it before
    target = AdaptTarget(np.array([0.0]), SOLUTION[:1], np.array([0.9]), T)
    new, _ = assimilate(model, DEMOS, Demonstration(T, SOLUTION, np.array([0.9])), AssimilationConfig(),
                        conditions=target, seed=0)
    assert len(new) == len(DEMOS) + 1
    assert _error(model, 0.9, SOLUTION) < TOLERANCE
    assert _error(model, 0.6, edge) <= 2 * max(edge_before, 1e-3)
    save_checkpoint(model, tmp_path / "m.pt")
    loaded, _ = load_checkpoint(tmp_path / "m.pt")
    assert _error(loaded, 0.9, SOLUTION) == pytest.approx(_error(model, 0.9, SOLUTION), abs=1e-9)


def test_the_range_the_network_sees_widens_to_a_solution_and_the_path_takes_it_in():
    model = CNMP(CNMPConfig(n_outputs=1, n_task_params=1, prior="trend", **SMALL), seed=0)
    model.fit_normalization(DEMOS)
    mu_before = model.prior.mu.clone()
    model.follow_demos(DEMOS.added(Demonstration(T, SOLUTION, np.array([0.9]))))
    assert float(model.value_norm.high[0]) == pytest.approx(SOLUTION.max())
    assert float(model.task_norm.high[0]) == pytest.approx(0.9)
    # the network sees c = 0.9 as it is (normalised 1.5), no longer the old edge's 1.0
    q = model.make_query([0.0], SOLUTION[:1], [0.9], T)
    assert float(model.network_obs(q.obs_x)[0, 0, 1]) == pytest.approx(1.5)
    assert not np.allclose(model.prior.mu.numpy(), mu_before.numpy())  # the solution joined its statistics


def test_without_task_parameters_a_solution_joins_the_path_s_statistics():
    demos = DemoSet.from_arrays(T, np.stack([a * _shape(T)[:, None] for a in (0.2, 0.4, 0.6, -0.2, -0.4, -0.6)]))
    model = CNMP(CNMPConfig(n_outputs=1, prior="trend", **SMALL), seed=0)
    model.fit_normalization(demos)
    cov_before = model.prior.cov.clone()
    model.follow_demos(demos.added(Demonstration(T, 0.9 * _shape(T)[:, None], np.zeros(0))))
    assert float(model.value_norm.high[0]) == pytest.approx(0.9 * _shape(T).max())
    assert float(model.prior.cov.numpy().trace()) > float(cov_before.numpy().trace())  # a wider spread now
