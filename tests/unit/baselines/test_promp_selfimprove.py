"""The baseline after Ewerton et al. 2019: PRO's relevance-weighted update improves an objective,
moves only the weights an objective depends on, is reproducible per seed; the GP interpolates the
library; the E3 learner runs in the self-improvement loop."""
from __future__ import annotations

import numpy as np
import pytest

from acnmp_core.baselines.promp import ProMP
from acnmp_core.baselines.promp_selfimprove import GPWeights, SelfImproveConfig, fit_gp, pro, pro_update, relevance
from acnmp_core.experiments import wall as E
from acnmp_core.rollout import RolloutBatch

TARGET = np.array([1.0, -2.0, 0.5])


class _Quadratic:
    """A toy evaluator: 1-D trajectories of 3 basis weights; reward per step minus the squared
    distance to the trajectory of ``TARGET``; success when the weights are within 0.05 of it."""

    def __init__(self, promp: ProMP) -> None:
        self.promp = promp

    def evaluate(self, trajectories, times, task_params=None) -> RolloutBatch:
        goal = self.promp.trajectories_from_weights(TARGET[None], times)
        err = (trajectories - goal)[..., 0] ** 2
        return RolloutBatch(rewards=-err, success=np.sqrt(err.mean(axis=1)) < 0.05, errors=np.sqrt(err.mean(axis=1)))


def _toy():
    promp = ProMP(1, 3, weight_mean=np.zeros(3), weight_cov=np.eye(3))
    return promp, _Quadratic(promp), np.linspace(0, 1, 50)


def test_pro_improves_a_toy_objective_and_is_reproducible():
    promp, ev, t = _toy()
    cfg = SelfImproveConfig(n_samples=20, max_rollouts=3000, min_std=0.01, seed=4)
    res = pro(promp, ev, t, None, cfg)
    assert res.success
    assert res.learning_curve[-1] > res.learning_curve[0]
    assert res.error_curve[0] > 0.3 and res.error_curve[-1] < 0.05
    again = pro(promp, ev, t, None, cfg)
    np.testing.assert_array_equal(res.learning_curve, again.learning_curve)
    other = pro(promp, ev, t, None, SelfImproveConfig(n_samples=20, max_rollouts=3000, seed=5))
    assert not np.array_equal(other.learning_curve, res.learning_curve)


def test_relevance_and_update_move_only_relevant_weights():
    rng = np.random.default_rng(0)
    w = rng.normal(size=(200, 3))
    # Objective 0 depends on weight 0 only, objective 1 on weight 2 only; weight 1 matters to none.
    r = np.stack([-(w[:, 0] - 1) ** 2, -(w[:, 2] + 1) ** 2], axis=1)
    f = relevance(w, r)
    assert f.shape == (2, 3)
    assert f[0, 0] == 1.0 and f[1, 2] == 1.0
    assert f[0, 1] < 0.3 and f[1, 1] < 0.3
    mean, cov = pro_update(np.eye(3), w, r, beta=10.0, min_std=0.01)
    assert mean[0] > 0.3 and mean[2] < -0.3  # towards each objective's optimum
    assert abs(mean[1]) < 0.2  # the irrelevant weight stays near the samples' centre
    assert np.all(np.linalg.eigvalsh(cov) > 0)


def test_gp_interpolates_the_library_and_picks_hyperparameters():
    rng = np.random.default_rng(1)
    x = rng.uniform(0, 1, size=(40, 2))
    y = np.stack([np.sin(3 * x[:, 0]), x[:, 1] ** 2], axis=1)
    ls, nz = fit_gp(x, y)
    gp = GPWeights(x, y, lengthscale=ls, noise=nz)
    x_new = rng.uniform(0.1, 0.9, size=(20, 2))
    want = np.stack([np.sin(3 * x_new[:, 0]), x_new[:, 1] ** 2], axis=1)
    assert np.abs(gp.predict(x_new) - want).max() < 0.1
    with pytest.raises(ValueError, match="weights"):
        GPWeights(x, y[:3])


def test_ewerton_learner_in_the_loop():
    r = E.run_wall(6, 0, n_initial=12, n_test=20, eval_every=6, methods=("ewerton",),
                   ewerton_config=SelfImproveConfig(max_rollouts=60))
    s = r["methods"]["ewerton"]
    assert s["trajectories_total"] == sum(r["rollouts_per_env"]["ewerton"])
    assert s["trajectories_paper_style"] == 6 * s["trajectories_per_env_max"]
    assert r["config"]["ewerton"]["lengthscale"] is None  # chosen by fit_gp inside the learner
