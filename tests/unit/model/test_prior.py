"""The default model's linear path (acnmp_core/model/prior.py, CNMPConfig.prior="linear"): it
extrapolates a linear family of demonstrations exactly where the network alone does not, keeps a
non-linear family (the network carries it), passes through what it is conditioned on, chooses its
size from the demonstrations alone, and travels in checkpoints; a checkpoint written before it loads
as the paper's CNMP."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from acnmp_core.data.demos import DemoSet
from acnmp_core.model.checkpoint import load_checkpoint, save_checkpoint
from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.model.prior import LinearPrior, choose_n_basis
from acnmp_core.model.training import TrainConfig, train

SMALL = dict(encoder_widths=(32, 32), decoder_widths=(32, 32))
T = np.linspace(0.0, 1.0, 60)


def _shape(t):
    return np.exp(-((t - 0.3) ** 2) / 0.02) - 0.5 * np.exp(-((t - 0.7) ** 2) / 0.01)


def _linear_family(amps):
    """Demonstrations an amplitude times one shape, the amplitude their task parameter (E1's kind)."""
    return DemoSet.from_arrays(T, np.stack([a * _shape(T)[:, None] for a in amps]), np.asarray(amps)[:, None])


def _trained(demos, prior, steps=300, seed=0):
    model = CNMP(CNMPConfig(n_outputs=demos.n_outputs, n_task_params=demos.n_task_params, prior=prior, **SMALL),
                 seed=seed)
    train(model, demos, TrainConfig(steps=steps), seed=seed, progress=False)
    return model


@pytest.fixture(scope="module")
def linear_models():
    demos = _linear_family([0.2, 0.4, 0.6, 0.8, 1.0])
    return _trained(demos, "linear"), _trained(demos, "none")


def test_the_linear_path_extrapolates_a_linear_family_where_the_network_alone_does_not(linear_models):
    default, paper = linear_models
    for amp in (1.6, -0.4):  # beyond the demonstrations' 0.2 .. 1.0 on both sides
        truth = amp * _shape(T)[:, None]
        err = lambda m: float(np.abs(m.predict([0.0], truth[:1], [amp], T).mean - truth).max())  # noqa: E731
        assert err(default) < 0.03 * abs(amp), (amp, err(default))
        assert err(paper) > 5 * err(default), (amp, err(paper), err(default))
    assert default.config.prior_basis >= 6  # chosen on the demonstrations: enough for the shape


def test_a_non_linear_family_is_kept_by_the_network_beside_the_path():
    """Demonstrations not linear in their parameter (a frequency): the linear path alone misses
    them, the default model, whose network carries the rest, reproduces them nearly as well as the
    network alone."""
    freqs = np.linspace(0.5, 1.5, 8)
    demos = DemoSet.from_arrays(T, np.stack([np.sin(2 * np.pi * f * T)[:, None] for f in freqs]), freqs[:, None])
    default, paper = _trained(demos, "linear", steps=1000), _trained(demos, "none", steps=1000)

    def repro(model):  # the mean over the demonstrations of the RMS error, each from its task parameter
        return float(np.mean([np.sqrt(np.mean((model.predict([0.0], d.values[:1], d.task_params, T).mean - d.values) ** 2))
                              for d in demos]))

    path_only = CNMP(CNMPConfig(n_outputs=1, n_task_params=1, prior="linear", prior_basis=default.config.prior_basis,
                                **SMALL))
    path_only.fit_normalization(demos)
    with torch.no_grad():  # the network's output zeroed: the linear path alone
        for p in path_only.decoder.parameters():
            p.zero_()
    # measured here: the path alone 0.35, the default 0.13, the network alone 0.09
    assert repro(path_only) > 2 * repro(default), (repro(path_only), repro(default))
    assert repro(default) < 2 * repro(paper), (repro(default), repro(paper))


def test_the_conditioned_path_passes_through_its_points_and_is_the_regression_on_its_parameters():
    rng = np.random.default_rng(0)
    n, d, k = 7, 2, 6
    t = np.tile(np.linspace(0, 1, 40), (n, 1))
    c = rng.uniform(0, 1, (n, 2))
    values = np.stack([np.c_[ci[0] * np.sin(3 * t[0]) + ci[1], ci[1] * t[0] ** 2] for ci in c])
    prior = LinearPrior(d, 2, k).fit(t, values, c)
    # conditioned on task parameters only: the least-squares regression of the weights on them
    w, _ = prior.condition(np.zeros((1, 1)), np.zeros((1, 1, d)), np.zeros((1, 1, d)), np.zeros((1, 1), bool),
                           np.array([[0.3, 0.7]]))
    phi = prior.basis(t[0])
    weights = np.stack([np.linalg.lstsq(phi, v, rcond=None)[0].T.reshape(-1) for v in values])
    fit = np.linalg.lstsq(np.c_[np.ones(n), c], weights, rcond=None)[0]
    np.testing.assert_allclose(w.reshape(-1), np.r_[1.0, 0.3, 0.7] @ fit, atol=2e-3)
    # and on an observed point as well (one output of it): the path passes through it
    w, at_obs = prior.condition(np.array([[0.5]]), np.array([[[0.9, 0.0]]]), np.array([[[1.0, 0.0]]]),
                                np.ones((1, 1), bool), np.array([[0.3, 0.7]]))
    assert at_obs[0, 0, 0] == pytest.approx(0.9, abs=0.01)
    np.testing.assert_allclose(prior.path(np.array([[0.5]]), w)[0, 0], at_obs[0, 0])


def test_the_basis_count_is_chosen_by_leaving_demonstrations_out():
    demos = _linear_family([0.2, 0.4, 0.6, 0.8, 1.0])
    values = np.stack([x.values for x in demos])
    n, errors = choose_n_basis(np.tile(T, (5, 1)), values / values.std(), np.linspace(0, 1, 5)[:, None],
                               candidates=(2, 4, 8, 12))
    assert n == min(errors, key=errors.get) and errors[n] < 0.3 * errors[2] and n >= 8
    assert choose_n_basis(np.tile(T, (2, 1)), values[:2], np.zeros((2, 1)), candidates=(6, 4)) == (4, {})


def test_the_path_travels_in_a_checkpoint_and_an_old_checkpoint_is_the_papers_cnmp(linear_models, tmp_path):
    default, paper = linear_models
    save_checkpoint(default, tmp_path / "m.pt")
    loaded, _ = load_checkpoint(tmp_path / "m.pt")
    q = default.make_query([0.0], [[0.0]], [1.3], T)
    np.testing.assert_array_equal(loaded.predict_query(q).mean, default.predict_query(q).mean)
    assert loaded.config.prior == "linear" and loaded.config.prior_basis == default.config.prior_basis
    # a checkpoint of the paper's CNMP written before the linear path existed: no prior keys
    payload = torch.load(tmp_path / "m.pt", weights_only=True)
    save_checkpoint(paper, tmp_path / "p.pt")
    old = torch.load(tmp_path / "p.pt", weights_only=True)
    old["config"] = {k: v for k, v in old["config"].items() if not k.startswith("prior")}
    torch.save(old, tmp_path / "old.pt")
    loaded_old, _ = load_checkpoint(tmp_path / "old.pt")
    assert loaded_old.config.prior == "none" and loaded_old.prior is None
    np.testing.assert_array_equal(loaded_old.predict_query(q).mean, paper.predict_query(q).mean)
    assert set(payload["state_dict"]) - set(old["state_dict"]) == {"prior.centers", "prior.mu", "prior.cov",
                                                                    "prior.noise", "prior.fitted"}


def test_batched_predictions_equal_single_ones_with_the_path(linear_models):
    default, _ = linear_models
    queries = [default.make_query([0.0], [[0.0]], [a], T[::n]) for a, n in ((1.3, 1), (0.5, 3), (-0.2, 2))]
    for batch, single in zip(default.predict_queries(queries), [default.predict_query(q) for q in queries]):
        np.testing.assert_allclose(batch.mean, single.mean, atol=1e-5)


def test_a_bad_prior_setting_is_refused_in_one_line():
    with pytest.raises(ValueError, match="prior: expected one of auto, none, linear"):
        CNMPConfig(n_outputs=1, prior="quadratic")
    with pytest.raises(ValueError, match="prior_basis"):
        CNMPConfig(n_outputs=1, prior_basis=1)
