"""Adaptive ProMP + episodic RL on a tiny analytic task (no simulator)."""
import numpy as np
import pytest

from acnmp_core.baselines.promp import ProMP
from acnmp_core.baselines.promp_rl import AdaptiveProMP, PrompRLConfig, adapt_promp, promp_rl
from acnmp_core.rollout import RolloutBatch, RolloutEvaluator

T = np.linspace(0.0, 1.0, 50)
T_VIA = 30  # index of the step the trajectory must pass


class ViaPointTask:
    """2-D trajectories must pass the point ``task_params`` (2,) at step T_VIA.

    Reward: minus the distance there, given at the last step; success within ``tol``.
    """

    def __init__(self, tol=0.05):
        self.tol = tol
        self.calls = 0

    def evaluate(self, trajectories, times, task_params=None):
        self.calls += 1
        trajectories = np.asarray(trajectories)
        assert trajectories.ndim == 3 and trajectories.shape[1] == len(times)
        err = np.linalg.norm(trajectories[:, T_VIA] - task_params, axis=1)
        rewards = np.zeros(trajectories.shape[:2])
        rewards[:, -1] = -err
        return RolloutBatch(rewards=rewards, success=err <= self.tol, states={"y": trajectories})


def _demos():
    """Demos y = (a sin(pi t), a t); the via-point at T_VIA is the task parameter."""
    amps = np.linspace(0.5, 1.5, 6)
    values = np.stack([np.stack([a * np.sin(np.pi * T), a * T], axis=1) for a in amps])
    return np.tile(T, (6, 1)), values, values[:, T_VIA].copy()


def test_evaluator_satisfies_protocol():
    assert isinstance(ViaPointTask(), RolloutEvaluator)


@pytest.mark.parametrize("method", ["reps", "rwr"])
def test_rl_reaches_extrapolated_via_point(method):
    times, values, params = _demos()
    target = params[-1] * 1.6  # outside the demos' range: the nearest skill misses it
    task = ViaPointTask()
    cfg = PrompRLConfig(method=method, n_samples=12, max_rollouts=1500, seed=3, min_std=0.02)
    res = adapt_promp(times, values, params, task, T, target, cfg, n_basis=10)
    assert res.learning_curve[0] < -0.3  # the initial skill fails
    assert res.success
    assert res.final_return > res.learning_curve[0]
    assert res.n_rollouts <= cfg.max_rollouts
    assert res.learning_curve.shape == res.rollouts_at.shape == (res.n_iterations + 1,)
    assert res.rollouts_at[-1] == res.n_rollouts
    assert res.trajectory.shape == (50, 2)
    assert np.linalg.norm(res.trajectory[T_VIA] - target) <= 0.05
    assert res.final_states["y"].shape == (50, 2)


def test_deterministic_under_seed():
    times, values, params = _demos()
    target = params[-1] * 1.4
    cfg = PrompRLConfig(n_samples=8, max_rollouts=300, seed=11)
    a = adapt_promp(times, values, params, ViaPointTask(), T, target, cfg, n_basis=8)
    b = adapt_promp(times, values, params, ViaPointTask(), T, target, cfg, n_basis=8)
    assert a.n_rollouts == b.n_rollouts
    np.testing.assert_array_equal(a.learning_curve, b.learning_curve)
    np.testing.assert_array_equal(a.trajectory, b.trajectory)


def test_budget_exhausted_stops_without_success():
    times, values, params = _demos()
    task = ViaPointTask(tol=-1.0)  # impossible
    cfg = PrompRLConfig(n_samples=10, max_rollouts=45, seed=0)
    res = adapt_promp(times, values, params, task, T, params[2], cfg, n_basis=8)
    assert not res.success
    assert res.n_rollouts <= 45
    assert res.n_rollouts >= 45 - cfg.n_samples


def test_success_at_start_uses_one_rollout():
    times, values, params = _demos()
    res = adapt_promp(times, values, params, ViaPointTask(), T, params[2], PrompRLConfig(), n_basis=10)
    assert res.success and res.n_rollouts == 1 and res.n_iterations == 0


def test_initialisation_nearest_and_conditional():
    times, values, params = _demos()
    lib = AdaptiveProMP(times, values, params, n_basis=10)
    assert lib.nearest(params[4] + 0.01) == 4
    near = lib.initial_promp(params[4] + 0.01, init="nearest")
    np.testing.assert_allclose(near.weight_mean, lib.demo_weights[4])
    # The demos are linear in the task parameter, so conditioning interpolates a held-out one.
    mid = (values[2] + values[3]) / 2
    cond = lib.initial_promp(mid[T_VIA], init="conditional")
    np.testing.assert_allclose(cond.mean_trajectory(T), mid, atol=0.01)


def test_bad_config_and_inputs():
    with pytest.raises(ValueError, match="method"):
        PrompRLConfig(method="ppo")
    with pytest.raises(ValueError, match="n_samples"):
        PrompRLConfig(n_samples=1)
    with pytest.raises(ValueError, match="cov_rate"):
        PrompRLConfig(cov_rate=2.0)
    times, values, params = _demos()
    with pytest.raises(ValueError, match="task_params"):
        AdaptiveProMP(times, values, params[:3])
    lib = AdaptiveProMP(times, values, params, n_basis=6)
    with pytest.raises(ValueError, match="task_params"):
        lib.initial_promp([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="times"):
        promp_rl(ProMP(2, 6), ViaPointTask(), np.zeros((2, 2)), params[0])
