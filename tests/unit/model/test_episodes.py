"""EpisodeSampler: episodes as the sampling rule defines them, bit for bit, from its cached table."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from acnmp_core.data.demos import DemoSet, Demonstration
from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.model.episodes import EpisodeSampler
from acnmp_core.model.training import TrainConfig, make_sampler


def _ragged(seed: int = 3) -> DemoSet:
    """Four demonstrations of different lengths, 3 outputs, 2 task parameters."""
    rng = np.random.default_rng(seed)
    return DemoSet([Demonstration(np.linspace(0, 1, n), rng.normal(size=(n, 3)), rng.normal(size=2))
                    for n in (20, 35, 17, 50)])


def _reference(model: CNMP, demos: DemoSet, cfg: TrainConfig, b: int, gen: torch.Generator):
    """The sampling rule written out per episode, in float64 numpy, from the same random draws in
    the same order: demo, a random order of its points (the first max_obs are observations, the
    next n_targets targets, or with targets_include_obs the first n_targets), the number of
    observations, then the partial-observation masks."""
    n, d, m = len(demos), demos.n_outputs, cfg.max_obs
    shortest = min(len(x.times) for x in demos)
    n_tgt = max(1, min(cfg.n_targets, shortest if cfg.targets_include_obs else shortest - m))
    first_target = 0 if cfg.targets_include_obs else m
    tmax = max(len(x.times) for x in demos)
    demo_idx = torch.randint(0, n, (b,), generator=gen).numpy()
    keys = torch.rand(b, tmax, generator=gen, dtype=torch.float64).numpy()
    n_obs = torch.randint(cfg.min_obs, m + 1, (b,), generator=gen).numpy()
    dims = np.ones((b, m, d))
    if cfg.partial_obs_prob > 0 and d > 1:
        partial = torch.rand(b, m, 1, generator=gen).numpy() < cfg.partial_obs_prob
        rand = (torch.rand(b, m, d, generator=gen).numpy() < 0.5).astype(np.float64)
        first = torch.randint(0, d, (b, m), generator=gen).numpy()
        for i in range(b):
            for j in range(m):
                rand[i, j, first[i, j]] = 1.0
        dims = np.where(partial, rand, dims)

    def norm(x, normalizer):
        return (np.asarray(x, dtype=np.float64) - normalizer.shift.numpy()) / normalizer.scale.numpy()

    obs_x, tgt_x, tgt_y = [], [], []
    for i in range(b):
        demo = demos[demo_idx[i]]
        order = np.argsort(keys[i, : len(demo.times)], kind="stable")
        t = norm(demo.times[:, None], model.time_norm)
        v = norm(demo.values, model.value_norm)
        p = norm(demo.task_params, model.task_norm)
        o, g = order[:m], order[first_target: first_target + n_tgt]
        obs_x.append(np.hstack([t[o], np.tile(p, (m, 1)), v[o] * dims[i], dims[i]]))
        tgt_x.append(np.hstack([t[g], np.tile(p, (len(g), 1))]))
        tgt_y.append(v[g])
    mask = np.arange(m)[None, :] < n_obs[:, None]
    return [torch.from_numpy(np.stack(a).astype(np.float32)) for a in (obs_x, tgt_x, tgt_y)] + [torch.from_numpy(mask)]


def _check_against_reference(model, demos, cfg, seed: int) -> None:
    sampler = make_sampler(model, demos, cfg)
    for b in (1, 8, 33):
        gen = torch.Generator().manual_seed(seed + b)
        ep = sampler.sample(b, gen)
        obs_x, tgt_x, tgt_y, mask = _reference(model, demos, cfg, b, torch.Generator().manual_seed(seed + b))
        assert torch.equal(ep.obs_x, obs_x) and torch.equal(ep.tgt_x, tgt_x) and torch.equal(ep.tgt_y, tgt_y)
        assert torch.equal(ep.obs_mask, mask)
        assert ep.obs_x.dtype == ep.tgt_x.dtype == ep.tgt_y.dtype == torch.float32


def test_episodes_follow_the_sampling_rule_bit_for_bit(e1_demos):
    e1 = CNMP(CNMPConfig(n_outputs=2, prior="none"))
    e1.fit_normalization(e1_demos)
    ragged = _ragged()
    model = CNMP(CNMPConfig(n_outputs=3, n_task_params=2, prior="none"))
    model.fit_normalization(ragged)
    for cfg in (TrainConfig(), TrainConfig(min_obs=2, max_obs=9, n_targets=7, partial_obs_prob=0.7),
                TrainConfig(targets_include_obs=True),
                TrainConfig(min_obs=2, max_obs=9, n_targets=7, partial_obs_prob=0.7, targets_include_obs=True)):
        _check_against_reference(e1, e1_demos, cfg, seed=0)
        _check_against_reference(model, ragged, cfg, seed=1)  # padded: demos of different lengths


def test_a_sampler_over_a_changed_demo_set_samples_the_new_demonstrations():
    """The sampler's float32 table is built from the demonstrations it is made for: after a
    demonstration joins the set (assimilation), a new sampler draws from it, with its values."""
    demos = _ragged()
    model = CNMP(CNMPConfig(n_outputs=3, n_task_params=2, prior="none"))
    model.fit_normalization(demos)
    old = make_sampler(model, demos, TrainConfig())
    solution = Demonstration(np.linspace(0, 1, 40), np.full((40, 3), 7.0), np.array([0.5, -0.5]))
    grown = demos.added(solution)
    new = make_sampler(model, grown, TrainConfig())
    idx = torch.full((4,), len(demos))  # every episode from the new demonstration
    ep = new.sample(4, torch.Generator().manual_seed(0), idx)
    seven = model.value_norm.normalize(torch.full((1, 3), 7.0, dtype=torch.float64)).float()
    assert torch.equal(ep.tgt_y, seven.expand(4, ep.tgt_y.shape[1], 3))
    assert not torch.equal(old.sample(4, torch.Generator().manual_seed(0), idx % len(demos)).tgt_y, ep.tgt_y)
    _check_against_reference(model, grown, TrainConfig(), seed=2)


def test_with_targets_include_obs_every_observation_is_a_target():
    """CNP-style episodes: each observed point (time and full value) is also one of the targets, so
    the model is taught to pass through what it is conditioned on; the default never does that."""
    demos = _ragged()
    model = CNMP(CNMPConfig(n_outputs=3, n_task_params=2, prior="none"))
    model.fit_normalization(demos)
    for include in (True, False):
        ep = make_sampler(model, demos, TrainConfig(targets_include_obs=include, partial_obs_prob=0.0)).sample(
            64, torch.Generator().manual_seed(5))
        p = 2
        for i in range(64):
            obs = ep.obs_x[i, ep.obs_mask[i]]
            obs_points = torch.cat([obs[:, :1], obs[:, 1 + p:1 + p + 3]], dim=1)
            tgt_points = torch.cat([ep.tgt_x[i, :, :1], ep.tgt_y[i]], dim=1)
            found = [(tgt_points == o).all(dim=1).any() for o in obs_points]
            assert all(found) if include else not any(found)


def test_first_points_is_argsort_also_when_keys_tie():
    sampler = EpisodeSampler(_packed(), max_obs=3, n_targets=4)
    gen = torch.Generator().manual_seed(0)
    keys = torch.rand(64, 30, generator=gen, dtype=torch.float64)
    assert torch.equal(sampler._first_points(keys, 7), torch.argsort(keys, dim=1)[:, :7])
    tied = torch.floor(keys * 8) / 8  # many equal keys in every row
    assert torch.equal(sampler._first_points(tied, 7), torch.argsort(tied, dim=1)[:, :7])
    assert torch.equal(sampler._first_points(keys, 30), torch.argsort(keys, dim=1))  # k = every point


def _packed():
    demos = DemoSet.from_arrays(np.linspace(0, 1, 30), np.random.default_rng(0).normal(size=(2, 30, 1)))
    model = CNMP(CNMPConfig(n_outputs=1, prior="none"))
    model.fit_normalization(demos)
    return model.pack(demos)


def test_task_parameter_jitter_moves_each_episode_by_one_draw_of_the_std():
    """task_param_jitter: each episode's task parameters (normalised) move by one Gaussian draw,
    the same in its observations and its targets; the default draws nothing (the reference above)."""
    demos = _ragged()
    model = CNMP(CNMPConfig(n_outputs=3, n_task_params=2, prior="none"))
    model.fit_normalization(demos)
    idx = torch.zeros(4000, dtype=torch.long)  # every episode from demonstration 0
    ep = make_sampler(model, demos, TrainConfig(task_param_jitter=0.25)).sample(4000, torch.Generator().manual_seed(0), idx)
    tp_obs, tp_tgt = ep.obs_x[..., 1:3], ep.tgt_x[..., 1:3]
    assert torch.equal(tp_obs, tp_obs[:, :1].expand_as(tp_obs)) and torch.equal(tp_tgt, tp_obs[:, :1].expand_as(tp_tgt))
    clean = model.task_norm.normalize(torch.as_tensor(demos[0].task_params[None])).float()
    shift = (tp_obs[:, 0] - clean).numpy()
    np.testing.assert_allclose(shift.std(axis=0), [0.25, 0.25], rtol=0.05)
    np.testing.assert_allclose(shift.mean(axis=0), [0.0, 0.0], atol=0.02)
    for bad in (-0.1, float("nan"), float("inf"), True):
        with pytest.raises(ValueError, match="task_param_jitter"):
            TrainConfig(task_param_jitter=bad)
        with pytest.raises(ValueError, match="task_param_jitter"):
            EpisodeSampler(model.pack(demos), task_param_jitter=bad)


def test_mixup_blends_two_demonstrations_at_the_same_points():
    """mixup: an episode is lam * a + (1 - lam) * b of two demonstrations, task parameters and
    values alike, at the same times; so a relation every demonstration obeys linearly (here value =
    task parameter) holds in every blended episode, at task parameters between the demonstrations'."""
    t = np.linspace(0, 1, 30)
    demos = DemoSet([Demonstration(t, np.column_stack([np.full(30, p), t * p]), np.array([p])) for p in (1.0, 2.0, 5.0)])
    model = CNMP(CNMPConfig(n_outputs=2, n_task_params=1, prior="none"))
    model.fit_normalization(demos)
    ep = make_sampler(model, demos, TrainConfig(mixup=1.0, partial_obs_prob=0.0)).sample(2000, torch.Generator().manual_seed(0))
    p = model.task_norm.denormalize(ep.tgt_x[..., 1:2].double())
    y = model.value_norm.denormalize(ep.tgt_y.double())
    times = model.time_norm.denormalize(ep.tgt_x[..., :1].double())
    np.testing.assert_allclose(y[..., 0], p[..., 0], atol=1e-5)
    np.testing.assert_allclose(y[..., 1], (times * p)[..., 0], atol=1e-5)
    ptp = p[:, 0, 0].numpy()
    assert np.mean(~np.isin(np.round(ptp, 4), [1.0, 2.0, 5.0])) > 0.5  # most episodes lie between demonstrations
    assert 1.0 - 1e-5 <= ptp.min() and ptp.max() <= 5.0 + 1e-5
    ragged = _ragged()
    m2 = CNMP(CNMPConfig(n_outputs=3, n_task_params=2, prior="none"))
    m2.fit_normalization(ragged)
    with pytest.raises(ValueError, match="one time grid"):
        make_sampler(m2, ragged, TrainConfig(mixup=0.5))
    for bad in (-0.1, 1.5, float("nan"), True):
        with pytest.raises(ValueError, match="mixup"):
            TrainConfig(mixup=bad)
