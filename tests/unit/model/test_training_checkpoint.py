"""Determinism under a seed, validation-based best checkpoint, and safe checkpoint round trips."""
import numpy as np
import pytest
import torch

from acnmp_core.data.demos import DemoSet
from acnmp_core.model.checkpoint import load_checkpoint, model_from_arrays, model_to_arrays, save_checkpoint
from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.model.training import TrainConfig, train

SMALL = dict(encoder_widths=(32, 32), decoder_widths=(32, 32))


def _train(demos, seed):
    model = CNMP(CNMPConfig(n_outputs=2, **SMALL), seed=seed)
    res = train(model, demos, TrainConfig(steps=150, val_every=50), seed=seed, progress=False)
    return model, res


def test_same_seed_same_numbers(e1_demos):
    m1, r1 = _train(e1_demos, 7)
    m2, r2 = _train(e1_demos, 7)
    assert r1.train_loss == r2.train_loss
    p1 = m1.predict([0.3], [[0.3, 0.2]], n_steps=20).mean
    p2 = m2.predict([0.3], [[0.3, 0.2]], n_steps=20).mean
    np.testing.assert_array_equal(p1, p2)
    _, r3 = _train(e1_demos, 8)
    assert r3.train_loss != r1.train_loss


def test_best_validation_checkpoint_is_kept(e1_demos):
    _, res = _train(e1_demos, 1)
    assert res.best_val == min(v for _, v in res.val)
    assert res.best_step in [s for s, _ in res.val]


def test_validation_split_holds_out_demonstrations(e1_demos, monkeypatch):
    """The demonstrations validation is measured on are never sampled for training."""
    import acnmp_core.model.training as training

    samplers = []  # (demos, sampler) in creation order: the training sampler, then validation's
    real = training.make_sampler

    def spy(model, demos, cfg):
        samplers.append((demos, real(model, demos, cfg)))
        return samplers[-1][1]

    monkeypatch.setattr(training, "make_sampler", spy)
    model = CNMP(CNMPConfig(n_outputs=2, prior="none", **SMALL))
    res = train(model, e1_demos, TrainConfig(steps=20, val_every=10, val_fraction=0.34), progress=False)
    (train_set, _), (val_set, _) = samplers

    def hashes(demos) -> set[str]:
        return {DemoSet([d]).content_hash() for d in demos}

    assert len(train_set) == 4 and len(val_set) == 2  # floor(0.34 * 6) held out
    assert hashes(train_set).isdisjoint(hashes(val_set))
    assert hashes(train_set) | hashes(val_set) == hashes(e1_demos)
    assert [step for step, _ in res.val] == [0, 10, 20]
    # the same seed holds out the same demonstrations; without val_fraction nothing is held out
    again = training.split_demos(e1_demos, 0.34, torch.Generator().manual_seed(0))
    assert hashes(again[1]) == hashes(val_set)
    assert training.split_demos(e1_demos, 0.0, torch.Generator().manual_seed(0))[1] is None


def test_checkpoint_round_trip_gives_identical_predictions(e1_model, e1_demos, tmp_path):
    path = save_checkpoint(e1_model, tmp_path / "m.pt", data_hash=e1_demos.content_hash(), meta={"skill": "e1"})
    loaded, info = load_checkpoint(path)
    assert info["data_hash"] == e1_demos.content_hash() and info["meta"]["skill"] == "e1"
    q = dict(obs_times=[0.2, 0.7], obs_values=[[0.2, 0.3], [0.7, 0.3]], n_steps=30)
    np.testing.assert_array_equal(e1_model.predict(**q).mean, loaded.predict(**q).mean)
    np.testing.assert_array_equal(e1_model.predict(**q).std, loaded.predict(**q).std)


def test_checkpoint_loading_is_weights_only(tmp_path):
    class Evil:
        def __reduce__(self):
            return (print, ("pwned",))

    bad = tmp_path / "evil.pt"
    torch.save({"format": 1, "x": Evil()}, bad)
    with pytest.raises(ValueError, match="not a readable checkpoint"):
        load_checkpoint(bad)
    with pytest.raises(ValueError, match="no checkpoint"):
        load_checkpoint(tmp_path / "missing.pt")


def test_arrays_round_trip(e1_model):
    config, arrays = model_to_arrays(e1_model)
    clone = model_from_arrays(config, arrays)
    q = dict(obs_times=[0.5], obs_values=[[0.5, 0.1]], n_steps=10)
    np.testing.assert_array_equal(e1_model.predict(**q).mean, clone.predict(**q).mean)
    arrays.pop(next(iter(arrays)))
    with pytest.raises(ValueError, match="arrays"):
        model_from_arrays(config, arrays)


def test_data_hash_changes_with_data(e1_demos):
    from acnmp_core.data.demos import Demonstration

    extra = e1_demos.added(Demonstration(e1_demos[0].times, e1_demos[0].values + 0.01))
    assert extra.content_hash() != e1_demos.content_hash()
    assert len(e1_demos) == 6  # added() leaves the original alone
