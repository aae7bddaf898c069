"""The demonstration file format: round trip, no pickle, clear errors."""
import numpy as np
import pytest

from acnmp_core.data.demo_io import FORMAT_VERSION, DemoArrays, load_demos, save_demos


def _demo_arrays(**kw):
    n, t, d = 3, 20, 2
    rng = np.random.default_rng(0)
    args = dict(
        times=np.tile(np.linspace(0, 1, t), (n, 1)),
        values=rng.normal(size=(n, t, d)),
        task_params=rng.normal(size=(n, 2)),
        task_param_names=np.array(["target_x", "target_y"]),
        value_names=np.array(["joint1", "joint2"]),
        roles=np.array(["train", "train", "extrapolation"]),
    )
    args.update(kw)
    return DemoArrays(**args)


def test_roundtrip_and_plain_numpy_load(tmp_path):
    d = _demo_arrays(lengths=np.array([20, 15, 10]))
    path = save_demos(tmp_path / "sub" / "demos.npz", d)
    assert path.exists() and not list(path.parent.glob("*.tmp"))
    back = load_demos(path)
    for key in ("times", "values", "task_params", "task_param_names", "value_names", "roles", "lengths"):
        np.testing.assert_array_equal(getattr(back, key), getattr(d, key))
    with np.load(path, allow_pickle=False) as raw:  # readable without this module, and without pickle
        assert int(raw["format_version"]) == FORMAT_VERSION
        assert raw["values"].shape == (3, 20, 2)
        assert raw["roles"].dtype.kind == "U"
    t1, v1, p1 = back.demo(1)
    assert t1.shape == (15,) and v1.shape == (15, 2) and p1.shape == (2,)


def test_optional_keys_absent(tmp_path):
    d = DemoArrays(np.tile(np.linspace(0, 1, 5), (2, 1)), np.zeros((2, 5, 1)), np.zeros((2, 0)))
    back = load_demos(save_demos(tmp_path / "d.npz", d))
    assert back.roles is None and back.value_names is None and back.lengths is None
    assert back.task_params.shape == (2, 0)


def test_select_and_roles():
    d = _demo_arrays()
    assert len(d.with_role("train")) == 2
    np.testing.assert_array_equal(d.select([2]).values[0], d.values[2])
    with pytest.raises(ValueError, match="role"):
        _demo_arrays(roles=None).with_role("train")


def test_to_demo_set():
    ds = _demo_arrays(lengths=np.array([20, 15, 10])).to_demo_set()
    assert len(ds) == 3 and ds[2].times.shape == (10,) and ds.n_task_params == 2


def test_bad_arrays_raise_value_error():
    with pytest.raises(ValueError, match="times"):
        _demo_arrays(times=np.zeros((3, 19)))
    with pytest.raises(ValueError, match="times"):
        _demo_arrays(times=np.tile(np.linspace(1, 0, 20), (3, 1)))
    with pytest.raises(ValueError, match="values"):
        _demo_arrays(values=np.full((3, 20, 2), np.nan))
    with pytest.raises(ValueError, match="task_params"):
        _demo_arrays(task_params=np.zeros((2, 2)))
    with pytest.raises(ValueError, match="value_names"):
        _demo_arrays(value_names=np.array(["a"]))
    with pytest.raises(ValueError, match="roles"):
        _demo_arrays(roles=np.array([1, 2, 3]))
    with pytest.raises(ValueError, match="lengths"):
        _demo_arrays(lengths=np.array([20, 21, 5]))


def test_bad_files_raise_value_error(tmp_path):
    with pytest.raises(ValueError, match="path"):
        load_demos(tmp_path / "missing.npz")
    np.savez(tmp_path / "partial.npz", times=np.zeros((1, 3)))
    with pytest.raises(ValueError, match="values"):
        load_demos(tmp_path / "partial.npz")
    d = _demo_arrays()
    np.savez(tmp_path / "v9.npz", format_version=9, times=d.times, values=d.values, task_params=d.task_params)
    with pytest.raises(ValueError, match="format_version"):
        load_demos(tmp_path / "v9.npz")
    # object arrays need pickle: refused by the loader
    np.savez(tmp_path / "obj.npz", times=d.times, values=d.values, task_params=d.task_params,
             roles=np.array(["a", None, "b"], dtype=object))
    with pytest.raises(ValueError):
        load_demos(tmp_path / "obj.npz")
