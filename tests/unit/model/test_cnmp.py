"""The CNMP's conditioning API: it passes near its observations, validates input, never mutates."""
import copy

import numpy as np
import pytest
import torch

from acnmp_core.data.demos import DemoSet
from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.model.training import TrainConfig, evaluate_nll, train


def test_conditioned_mean_passes_near_observations_on_training_data(e1_model, e1_demos):
    extent = e1_demos.extent()
    for demo in e1_demos:
        idx = np.array([10, 50, 90])
        pred = e1_model.predict(demo.times[idx], demo.values[idx], None, demo.times)
        err = np.linalg.norm(pred.mean[idx] - demo.values[idx], axis=1)
        assert err.max() < 0.05 * extent
        # and the whole demonstration is reproduced from three of its points
        assert np.sqrt(np.mean((pred.mean - demo.values) ** 2)) < 0.05 * extent


def test_predict_returns_shapes_and_does_not_mutate(e1_model):
    before = copy.deepcopy(e1_model.state_dict())
    pred = e1_model.predict([0.0], [[0.0, 0.0]], n_steps=50)
    assert pred.mean.shape == (50, 2) and pred.std.shape == (50, 2)
    assert pred.latent.shape == (e1_model.config.latent_dim,)
    assert np.all(pred.std > 0)
    for k, v in e1_model.state_dict().items():
        assert torch.equal(v, before[k])


def test_partial_observation_uses_only_given_dimensions(e1_model, e1_demos):
    demo = e1_demos[2]
    i = 25
    full = e1_model.predict([demo.times[i]], demo.values[i:i + 1], None, demo.times)
    junk = demo.values[i:i + 1].copy()
    junk[0, 0] = 123.0  # masked out: must not matter
    part = e1_model.predict([demo.times[i]], junk, None, demo.times, obs_dims_mask=[[False, True]])
    assert np.all(np.isfinite(part.mean))
    assert abs(part.mean[i, 1] - demo.values[i, 1]) < 0.1 * e1_demos.extent()
    assert full.mean.shape == part.mean.shape


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(obs_times=[0.1, 0.2], obs_values=[[0.0, 0.0]], n_steps=5), "obs_values"),
        (dict(obs_times=[0.1], obs_values=[[np.nan, 0.0]], n_steps=5), "obs_values"),
        (dict(obs_times=[np.inf], obs_values=[[0.0, 0.0]], n_steps=5), "obs_times"),
        (dict(obs_times=[], obs_values=np.zeros((0, 2)), n_steps=5), "obs_times"),
        (dict(obs_times=[5.0], obs_values=[[0.0, 0.0]], n_steps=5), "obs_times"),
        (dict(obs_times=[0.1], obs_values=[[0.0, 0.0]], task_params=[1.0], n_steps=5), "task_params"),
        (dict(obs_times=[0.1], obs_values=[[0.0, 0.0, 0.0]], n_steps=5), "obs_values"),
        (dict(obs_times=[0.1], obs_values=[[0.0, 0.0]], query_times=[-3.0, 0.5]), "query_times"),
        (dict(obs_times=[0.1], obs_values=[[0.0, 0.0]]), "query_times"),
        (dict(obs_times=[0.1], obs_values=[[0.0, 0.0]], obs_dims_mask=[[False, False]], n_steps=5), "obs_dims_mask"),
        # both ways of giving the times: one would be ignored silently (issue 36, row 7)
        (dict(obs_times=[0.1], obs_values=[[0.0, 0.0]], query_times=np.linspace(0, 1, 50), n_steps=10),
         "query_times and n_steps"),
    ],
)
def test_bad_input_raises_value_error_naming_the_argument(e1_model, kwargs, match):
    with pytest.raises(ValueError, match=match):
        e1_model.predict(**kwargs)


def test_task_parameter_count_is_checked():
    t = np.linspace(0, 1, 20)
    demos = DemoSet.from_arrays(t, np.stack([np.stack([t * a], 1) for a in (1.0, 2.0)]), [[1.0], [2.0]])
    model = CNMP(CNMPConfig(n_outputs=1, n_task_params=1, encoder_widths=(16,), decoder_widths=(16,)))
    train(model, demos, TrainConfig(steps=5, max_obs=3), progress=False)
    with pytest.raises(ValueError, match="task_params"):
        model.predict([0.0], [[0.0]], None, n_steps=5)
    with pytest.raises(ValueError, match="task_params"):
        model.predict([0.0], [[0.0]], [1.0, 2.0], n_steps=5)
    assert model.predict([0.0], [[0.0]], [1.5], n_steps=5).mean.shape == (5, 1)


def test_untrained_model_refuses_to_predict():
    with pytest.raises(ValueError, match="train"):
        CNMP(CNMPConfig(n_outputs=1)).predict([0.0], [[0.0]], n_steps=3)


def test_config_validation():
    with pytest.raises(ValueError, match="n_outputs"):
        CNMPConfig(n_outputs=0)
    with pytest.raises(ValueError, match="output_names"):
        CNMPConfig(n_outputs=2, output_names=("a",))


def test_training_lowers_the_nll(e1_demos):
    model = CNMP(CNMPConfig(n_outputs=2, prior="none"), seed=3)
    model.fit_normalization(e1_demos)
    before = evaluate_nll(model, e1_demos)
    train(model, e1_demos, TrainConfig(steps=600), seed=3, progress=False)
    assert evaluate_nll(model, e1_demos) < before - 0.5


def test_demos_of_different_lengths_and_time_grids_train():
    from acnmp_core.data.demos import Demonstration

    demos = DemoSet([
        Demonstration(np.linspace(0, 1, 40), np.sin(np.linspace(0, 1, 40))[:, None] * a)
        for a in (0.5, 1.0)
    ] + [Demonstration(np.sort(np.random.default_rng(0).uniform(0, 2, 70)), np.ones((70, 1)))])
    model = CNMP(CNMPConfig(n_outputs=1, encoder_widths=(32, 32), decoder_widths=(32, 32)))
    train(model, demos, TrainConfig(steps=600), progress=False)
    assert model.time_range() == (0.0, pytest.approx(demos.all_times().max()))
    # every demonstration was learnt on its own grid: three of its points give back the whole of it,
    # the two sine amplitudes apart and the constant one up to t = 2 (untrained: RMSE ~0.5 and more)
    for d in demos:
        idx = np.linspace(0, len(d.times) - 1, 3).round().astype(int)
        pred = model.predict(d.times[idx], d.values[idx], None, d.times)
        assert np.sqrt(np.mean((pred.mean - d.values) ** 2)) < 0.08, d.times[-1]


@pytest.mark.parametrize("cfg", [dict(n_outputs=2), dict(n_outputs=3, n_task_params=4, encoder_widths=(7,)),
                                 dict(n_outputs=1, encoder_widths=(5, 9, 3), decoder_widths=(11, 2))])
def test_n_parameters_is_computed_from_the_config_without_building(cfg):
    config = CNMPConfig(**cfg)
    assert config.n_parameters == sum(p.numel() for p in CNMP(config).parameters())
    # a config that would allocate ~1 GB is counted, not built
    assert CNMPConfig(n_outputs=2, encoder_widths=(16000, 16000)).n_parameters > 256_000_000


def test_queries_of_different_sizes_in_one_forward_pass_equal_each_alone(e1_model):
    # the model service's dynamic batching relies on this: a predict's answer does not depend on
    # what it is batched with beyond float32 rounding (the matrix kernels of a few rows sum in
    # another order than those of many: on this machine, queries of 2-3 observations or 2 query
    # times differ in the last bits), and a query alone in a pass is bit for bit its unbatched answer
    rng = np.random.default_rng(0)
    lo, hi = e1_model.time_range()
    queries = []
    for _ in range(12):
        n, t = int(rng.integers(1, 40)), int(rng.integers(1, 300))
        queries.append(e1_model.make_query(rng.uniform(lo, hi, n), rng.normal(size=(n, 2)),
                                           query_times=np.sort(rng.uniform(lo, hi, t))))
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # as in the model service
    try:
        together = e1_model.predict_queries(queries)
        alone = [e1_model.predict_query(q) for q in queries]
        singly = [e1_model.predict_queries([q])[0] for q in queries]
    finally:
        torch.set_num_threads(threads)
    assert len(together) == len(queries) and e1_model.predict_queries([]) == []
    scale = e1_model.value_norm.denormalize_std(torch.ones(2, dtype=torch.float64)).numpy()
    for a, b, c in zip(alone, together, singly):
        np.testing.assert_array_equal(a.times, b.times)
        for name in ("mean", "std", "latent"):
            x, y, z = getattr(a, name), getattr(b, name), getattr(c, name)
            assert x.shape == y.shape
            np.testing.assert_array_equal(x, z, err_msg=name)
            atol = 1e-5 * (scale.max() if name != "latent" else 1.0)
            np.testing.assert_allclose(y, x, rtol=1e-5, atol=atol, err_msg=name)
