"""The default model chooses itself from the demonstrations (acnmp_core/model/selection.py): the
linear trend beyond the range where they are linear in their condition, the network alone where
they are not (a bump moving in time), the network alone with too few to choose; the choice travels
in the checkpoint; inside the range the trend changes nothing."""
from __future__ import annotations

import numpy as np
import pytest

from acnmp_core.data.demos import DemoSet
from acnmp_core.model.checkpoint import load_checkpoint, save_checkpoint
from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.model.selection import MIN_DEMOS, PriorChoice, edge_folds
from acnmp_core.model.training import TrainConfig, train
from acnmp_core.tasks.families import BUMP

SMALL = dict(encoder_widths=(64, 64), decoder_widths=(64, 64))
T = np.linspace(0.0, 1.0, 60)


def _shape(t):
    return np.exp(-((t - 0.3) ** 2) / 0.02) - 0.5 * np.exp(-((t - 0.7) ** 2) / 0.01)


def _trained(demos, prior, steps, seed=0):
    model = CNMP(CNMPConfig(n_outputs=demos.n_outputs, n_task_params=demos.n_task_params, prior=prior, **SMALL),
                 seed=seed)
    train(model, demos, TrainConfig(steps=steps), seed=seed, progress=False)
    return model


def test_edge_folds_hold_out_each_parameter_s_ends_and_a_grid_s_whole_face():
    grid = np.array([(x, y) for x in (0.0, 1.0, 2.0) for y in (0.0, 1.0)])
    folds = edge_folds(grid, np.zeros((6, 5, 1)))
    assert folds == [(4, 5), (0, 1), (1, 3, 5), (0, 2, 4)]
    # without task parameters: the two ends of the demonstrations' main mode of variation
    amps = np.array([0.2, -0.6, 0.4, 0.6, -0.2])
    assert sorted(edge_folds(np.zeros((5, 0)), amps[:, None, None] * _shape(T)[None, :, None])) == [(1,), (3,)]


def test_a_linear_family_picks_the_trend_and_extrapolates_it(tmp_path):
    demos = DemoSet.from_arrays(T, np.stack([a * _shape(T)[:, None] for a in (0.2, 0.4, 0.6, 0.8, 1.0)]),
                                np.array([[0.2], [0.4], [0.6], [0.8], [1.0]]))
    model = CNMP(CNMPConfig(n_outputs=1, n_task_params=1), seed=0)  # the default size: it fits the edge closely
    train(model, demos, TrainConfig(steps=2000), seed=0, progress=False)
    choice = model.config.prior_choice
    assert model.config.prior == choice.chosen == "trend" and choice.errors["trend"] < choice.errors["none"]
    assert choice.folds == ((4,), (0,)) and "linear trend" in choice.reason
    for amp in (1.6, -0.4):  # beyond the demonstrations on both sides
        truth = amp * _shape(T)[:, None]
        assert np.abs(model.predict([0.0], truth[:1], [amp], T).mean - truth).max() < 0.03 * abs(amp)
    save_checkpoint(model, tmp_path / "m.pt")
    loaded, _ = load_checkpoint(tmp_path / "m.pt")
    assert loaded.config.prior_choice == choice and loaded.config.prior == "trend"


def test_a_bump_moving_in_time_picks_the_network_and_is_the_paper_s_cnmp_within_1_2x():
    demos = DemoSet.from_arrays(*BUMP.demonstrations())
    default, paper = _trained(demos, "auto", steps=1500), _trained(demos, "none", steps=1500)
    choice = default.config.prior_choice
    assert default.config.prior == "none" and choice.errors["none"] < choice.errors["trend"] / 3, choice

    def error(model, c):
        truth = BUMP.path(T, np.array([c]))
        return float(np.sqrt(np.mean((model.predict([0.0], truth[:1], [c], T).mean - truth) ** 2)))

    for c in (0.78, 0.3):  # extrapolated, interpolated
        assert error(default, c) <= 1.2 * error(paper, c)


def test_too_few_demonstrations_fall_back_to_the_paper_s_network_in_one_line():
    demos = DemoSet.from_arrays(T, np.stack([a * _shape(T)[:, None] for a in (0.2, 0.6, 1.0)]))
    model = _trained(demos, "auto", steps=50)
    choice = model.config.prior_choice
    assert len(demos) < MIN_DEMOS and model.config.prior == "none" and model.prior is None
    assert "too few" in choice.reason and "\n" not in choice.reason and choice.errors == {}
    assert PriorChoice.from_dict(choice.to_dict()) == choice


def test_a_model_whose_prior_is_still_auto_is_not_fitted_without_training():
    with pytest.raises(ValueError, match='"auto" is chosen when the model is trained'):
        CNMP(CNMPConfig(n_outputs=1)).fit_normalization(DemoSet.from_arrays(T, _shape(T)[None, :, None]))


def test_training_auto_trains_exactly_the_model_of_the_prior_it_chose():
    """The choice draws on no random state the training uses: the chosen model is the one training
    that prior with the same seed gives (the comparison shares it between the default and that prior)."""
    demos = DemoSet.from_arrays(*BUMP.demonstrations())
    auto, chosen = _trained(demos, "auto", steps=200, seed=3), None
    chosen = _trained(demos, auto.config.prior, steps=200, seed=3)
    q = auto.make_query([0.0], [[0.0]], [0.7], T)
    np.testing.assert_array_equal(auto.predict_query(q).mean, chosen.predict_query(q).mean)


def test_inside_the_range_the_trend_is_the_paper_s_network_to_the_bit():
    demos = DemoSet.from_arrays(T, np.stack([a * _shape(T)[:, None] for a in (0.2, 0.4, 0.6, 0.8, 1.0)]),
                                np.array([[0.2], [0.4], [0.6], [0.8], [1.0]]))
    trend, paper = _trained(demos, "trend", steps=100), _trained(demos, "none", steps=100)
    inside = trend.make_query([0.0], [[0.0]], [0.7], T)
    np.testing.assert_array_equal(trend.predict_query(inside).mean, paper.predict_query(inside).mean)
    beyond = trend.make_query([0.0], [[0.0]], [1.5], T)
    assert not np.allclose(trend.predict_query(beyond).mean, paper.predict_query(beyond).mean)
