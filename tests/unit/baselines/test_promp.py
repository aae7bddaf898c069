"""ProMP invariants: fitting, conditioning (textbook invariants), sampling, input checks."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from acnmp_core.baselines.promp import ProMP


def _demos(n=6, seed=0):
    """Demos y = [a sin(pi t), a t] with different lengths and time grids (times in seconds, 0..2)."""
    rng = np.random.default_rng(seed)
    times, values = [], []
    for i in range(n):
        t = np.sort(rng.uniform(0.0, 2.0, 40 + 7 * i))
        t[0], t[-1] = 0.0, 2.0
        a = 1.0 + 0.2 * i
        times.append(t)
        values.append(np.stack([a * np.sin(np.pi * t / 2), a * t / 2], axis=1))
    return times, values


@pytest.fixture(scope="module")
def promp():
    times, values = _demos()
    return ProMP.from_demos(times, values, n_basis=12)


def test_basis_is_normalised():
    pm = ProMP(2, 8)
    phi = pm.basis(np.linspace(-0.5, 1.5, 50))
    assert phi.shape == (50, 8)
    np.testing.assert_allclose(phi.sum(axis=1), 1.0)


def test_fit_recovers_demo_mean_on_raw_times(promp):
    t = np.linspace(0.0, 2.0, 30)
    assert promp.time_range == (0.0, 2.0)
    a_mean = np.mean([1.0 + 0.2 * i for i in range(6)])
    want = np.stack([a_mean * np.sin(np.pi * t / 2), a_mean * t / 2], axis=1)
    np.testing.assert_allclose(promp.mean_trajectory(t), want, atol=0.02)
    assert promp.var_trajectory(t).shape == (30, 2)
    assert promp.cov_trajectory(t).shape == (30, 2, 2)


def test_normalize_duration_maps_each_demo_to_phase():
    t1, t2 = np.linspace(0, 1, 50), np.linspace(3, 5, 80)
    y1 = np.sin(np.pi * t1)[:, None]
    y2 = np.sin(np.pi * (t2 - 3) / 2)[:, None]
    pm = ProMP.from_demos([t1, t2], [y1, y2], n_basis=10, normalize_duration=True)
    z = np.linspace(0, 1, 20)
    np.testing.assert_allclose(pm.mean_trajectory(z)[:, 0], np.sin(np.pi * z), atol=0.02)


def test_conditioned_mean_passes_via_point_and_variance_vanishes(promp):
    t_via = np.array([1.3])
    y_via = np.array([[2.5, -0.4]])  # outside the demonstrations' range on purpose
    before_mean = promp.weight_mean.copy()
    cond = promp.condition(t_via, y_via)
    np.testing.assert_allclose(cond.mean_trajectory(t_via), y_via, atol=1e-5)
    assert np.all(cond.var_trajectory(t_via) < 1e-8)
    assert np.all(promp.var_trajectory(t_via) > 1e-4)  # it was not already certain there
    # conditioning returns a new object and leaves the original untouched
    assert cond is not promp
    np.testing.assert_array_equal(promp.weight_mean, before_mean)
    # variance elsewhere does not grow
    t = np.linspace(0, 2, 40)
    assert np.all(cond.var_trajectory(t) <= promp.var_trajectory(t) + 1e-9)


def test_condition_with_noise_and_mask(promp):
    t_via = np.array([0.5, 1.5])
    y_via = np.array([[1.0, 0.3], [1.2, 0.9]])
    noisy = promp.condition(t_via, y_via, std=0.1)
    assert np.all(noisy.var_trajectory(t_via) < 0.1**2 + 1e-12)
    assert np.all(noisy.var_trajectory(t_via) > 1e-6)
    mask = np.array([[True, False], [True, False]])
    part = promp.condition(t_via, y_via, mask=mask)
    np.testing.assert_allclose(part.mean_trajectory(t_via)[:, 0], y_via[:, 0], atol=1e-5)
    # masked-out entries are ignored: any value there gives the same conditioned ProMP
    other = promp.condition(t_via, y_via + np.array([0.0, 5.0]), mask=mask)
    np.testing.assert_allclose(other.weight_mean, part.weight_mean)


@settings(max_examples=25, deadline=None)
@given(t=st.floats(0.0, 2.0), y0=st.floats(-3, 3), y1=st.floats(-3, 3))
def test_conditioning_property(promp, t, y0, y1):
    cond = promp.condition([t], [[y0, y1]])
    np.testing.assert_allclose(cond.mean_trajectory([t])[0], [y0, y1], atol=1e-4)


def test_sampling_reproducible_with_seed(promp):
    t = np.linspace(0, 2, 25)
    a = promp.sample_trajectories(t, 4, rng=np.random.default_rng(7))
    b = promp.sample_trajectories(t, 4, rng=np.random.default_rng(7))
    c = promp.sample_trajectories(t, 4, rng=8)
    assert a.shape == (4, 25, 2)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)
    many = promp.sample_trajectories(t, 4000, rng=1)
    np.testing.assert_allclose(many.mean(axis=0), promp.mean_trajectory(t), atol=0.05)
    np.testing.assert_allclose(many.var(axis=0), promp.var_trajectory(t), rtol=0.15, atol=1e-4)


def test_samples_of_conditioned_promp_hit_the_via_point(promp):
    cond = promp.condition([1.0], [[1.5, 0.5]])
    s = cond.sample_trajectories([1.0], 50, rng=0)
    np.testing.assert_allclose(s[:, 0], np.broadcast_to([1.5, 0.5], (50, 2)), atol=1e-4)


def test_weights_roundtrip(promp):
    t = np.linspace(0, 2, 60)
    y = promp.mean_trajectory(t)
    w = promp.weights_from_trajectory(t, y, ridge=1e-10)
    np.testing.assert_allclose(promp.trajectories_from_weights(w, t), y, atol=1e-6)
    wb = np.stack([w, w])
    assert promp.trajectories_from_weights(wb, t).shape == (2, 60, 2)


def test_bad_input_raises_value_error(promp):
    times, values = _demos(2)
    bad = [v.copy() for v in values]
    bad[1][3, 0] = np.nan
    with pytest.raises(ValueError, match=r"values\[1\]"):
        ProMP.from_demos(times, bad)
    with pytest.raises(ValueError, match=r"values\[0\]"):
        ProMP.from_demos(times, [values[0][:-1], values[1]])
    with pytest.raises(ValueError, match="times"):
        ProMP.from_demos([times[0][::-1], times[1]], values)
    with pytest.raises(ValueError, match="output dims"):
        ProMP.from_demos(times, [values[0], values[1][:, :1]])
    with pytest.raises(ValueError, match="n_basis"):
        ProMP(2, 1)
    with pytest.raises(ValueError, match="values"):
        promp.condition([0.5], [[1.0, 2.0, 3.0]])
    with pytest.raises(ValueError, match="values"):
        promp.condition([0.5], [[np.nan, 2.0]])
    with pytest.raises(ValueError, match="std"):
        promp.condition([0.5], [[1.0, 2.0]], std=-1.0)
    with pytest.raises(ValueError, match="times"):
        promp.mean_trajectory([[0.1, 0.2]])
    with pytest.raises(ValueError, match="weight_cov"):
        ProMP(2, 5, weight_cov=np.eye(3))
    with pytest.raises(ValueError, match="rng"):
        promp.sample_weights(2, rng="seed")
