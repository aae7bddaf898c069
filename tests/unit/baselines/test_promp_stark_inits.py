"""Stark et al. 2019's initialisations of the ProMP search distribution, and the weighted-ML update
(on the tiny analytic via-point task of test_promp_rl, no simulator)."""
import numpy as np
import pytest

from acnmp_core.baselines.promp_rl import AdaptiveProMP, PrompRLConfig, adapt_promp

# tests/unit is on sys.path (pytest's default prepend import mode): reuse the analytic task.
from tests.unit.baselines.test_promp_rl import T, T_VIA, ViaPointTask, _demos


def _library(effects):
    times, values, params = _demos()
    return AdaptiveProMP(times, values, params, effects=effects, n_basis=10), values, params


def test_similar_starts_from_the_skill_with_the_nearest_effect_not_the_nearest_task_parameters():
    times, values, params = _demos()
    # What demo 0 achieved is demo 5's task parameters: the effect, not the label, must decide.
    effects = params.copy()
    effects[0], effects[5] = params[5], params[0]
    lib, _, _ = _library(effects)
    target = params[5] + 0.01
    assert lib.nearest(target) == 5
    similar = lib.initial_promp(target, init="similar")
    np.testing.assert_allclose(similar.weight_mean, lib.demo_weights[0])
    np.testing.assert_allclose(lib.initial_promp(target, init="nearest").weight_mean, lib.demo_weights[5])


def test_mixture_weights_skills_by_effect_similarity():
    times, values, params = _demos()
    lib, _, _ = _library(params.copy())
    # At a demo's own effect only that skill counts (its similarity is 1, the bandwidth ~0).
    at_demo = lib.initial_promp(params[2], init="mixture")
    np.testing.assert_allclose(at_demo.weight_mean, lib.demo_weights[2], atol=1e-9)
    # Between two effects the mean lies between their skills, nearer the nearer one, and the
    # covariance holds the skills' spread (broader than one skill's).
    target = 0.7 * params[2] + 0.3 * params[3]
    s = lib.effect_similarities(target)
    assert np.argmax(s) == 2 and s[2] == pytest.approx(np.exp(-0.5)) and 0 < s[3] < s[2]
    mix = lib.initial_promp(target, init="mixture")
    d2 = np.linalg.norm(mix.weight_mean - lib.demo_weights[2])
    d3 = np.linalg.norm(mix.weight_mean - lib.demo_weights[3])
    assert 0 < d2 < d3
    assert np.trace(mix.weight_cov) > np.trace(lib.initial_promp(target, init="similar").weight_cov)


def test_effect_inits_need_effects():
    times, values, params = _demos()
    lib = AdaptiveProMP(times, values, params, n_basis=10)
    with pytest.raises(ValueError, match="effects"):
        lib.initial_promp(params[0], init="mixture")


def test_scratch_holds_the_start_posture_with_a_broad_isotropic_prior():
    lib, values, params = _library(None)
    p = lib.initial_promp(params[0], init="scratch", scratch_std=0.4)
    mean = p.mean_trajectory(T)
    np.testing.assert_allclose(mean, np.tile(values[0, 0], (len(T), 1)), atol=1e-3)
    np.testing.assert_allclose(p.weight_cov, 0.16 * np.eye(p.n_weights))


@pytest.mark.parametrize("init", ["similar", "mixture", "scratch"])
def test_reps_with_weighted_ml_reaches_the_extrapolated_point(init):
    times, values, params = _demos()
    target = params[-1] * 1.3
    # The task's units are ~1 (the demos' amplitudes 0.5-1.5): the scratch prior must be as broad.
    cfg = PrompRLConfig(n_samples=20, cov_update="wml", init=init, max_rollouts=2000, min_std=0.02, seed=1,
                        scratch_std=1.0)
    res = adapt_promp(times, values, params, ViaPointTask(), T, target, cfg, n_basis=10, demo_effects=params)
    assert res.success and res.n_rollouts <= cfg.max_rollouts
    assert np.linalg.norm(res.trajectory[T_VIA] - target) <= 0.05


def test_config_refuses_unknown_init_and_update():
    with pytest.raises(ValueError, match="init"):
        PrompRLConfig(init="random")
    with pytest.raises(ValueError, match="cov_update"):
        PrompRLConfig(cov_update="adam")
