"""What of a dataset becomes the demonstrations (acnmp_core/datasets/selection.py): features and
slices as the trajectory, task parameters at a frame or per episode, episodes, success, the phase,
resampling; bad selections as one line naming the file, the feature and what was expected."""
from __future__ import annotations

import numpy as np
import pytest

from acnmp_core.datasets import DatasetEpisodes, DatasetError, Episode, Selection, select_demos
from acnmp_core.datasets.selection import FeatureRef, TaskParamRef, parse_feature


def _data(lengths=(5, 7, 6), nan_at=None) -> DatasetEpisodes:
    rng = np.random.default_rng(0)
    episodes = []
    for i, t in enumerate(lengths):
        state = rng.normal(size=(t, 3))
        if nan_at == i:
            state[2, 1] = np.nan
        episodes.append(Episode(i, {"state": state, "stamp": (0.5 + np.arange(t) * 0.1).reshape(-1, 1),
                                    "goal": np.tile([[1.0 + i, -i]], (t, 1))},
                                fields={"target": np.array([10.0 * i])}, labels={"tasks": "reach"},
                                success=i != 1))
    return DatasetEpisodes("/data/set", "lerobot", episodes, "stamp", names={"state": ("x", "y", "z")},
                           ranks={"camera": (3, 64, 64)}, files={"state": "/data/set/frames.parquet"},
                           catalog="/data/set/info.json")


def test_references_parse_as_on_the_command_line():
    assert parse_feature("observation.state[0:2]") == FeatureRef("observation.state", 0, 2)
    assert parse_feature("action[3]") == FeatureRef("action", 3, 4)
    assert parse_feature("goal[-1]@last", task_param=True) == TaskParamRef(FeatureRef("goal", -1, None), "last")
    assert parse_feature("acnmp/task_params", task_param=True) == TaskParamRef(FeatureRef("acnmp/task_params"))
    with pytest.raises(ValueError, match="not a feature reference"):
        parse_feature("state@first")  # @ only for task parameters


def test_features_slices_and_task_params_become_named_demonstrations():
    data = _data()
    demos = select_demos(data, Selection((FeatureRef("state", 0, 2), FeatureRef("goal", 1, 2)),
                                         (TaskParamRef(FeatureRef("goal"), "first"), TaskParamRef(FeatureRef("target")))))
    assert demos.values.shape == (3, 7, 3)
    assert demos.lengths.tolist() == [5, 7, 6]  # episodes as they are, padded
    np.testing.assert_array_equal(demos.values[1, :, :2], data.episodes[1].frames["state"][:, :2])
    np.testing.assert_array_equal(demos.task_params, [[1, 0, 0], [2, -1, 10], [3, -2, 20]])
    assert demos.value_names.tolist() == ["x", "y", "goal[1]"]
    assert demos.task_param_names.tolist() == ["goal[0]", "goal[1]", "target"]
    for i, t in enumerate((5, 7, 6)):  # each episode's time mapped to [0, 1]
        np.testing.assert_allclose(demos.times[i, :t], np.linspace(0, 1, t))


def test_episodes_success_time_and_resampling():
    data = _data()
    demos = select_demos(data, Selection((FeatureRef("state"),), episodes=(2, 0, 1), successful=True, phase="time",
                                         resample=11))
    assert demos.values.shape == (2, 11, 3) and demos.lengths is None
    np.testing.assert_allclose(demos.times[0], np.linspace(0, 0.5, 11))  # episode 2: 6 frames 0.1 s apart
    np.testing.assert_allclose(demos.values[1, [0, -1]], data.episodes[0].frames["state"][[0, -1]])


@pytest.mark.parametrize("selection, file, feature, expected", [
    (Selection((FeatureRef("stat"),)), "/data/set/info.json", "stat", "no such per-frame feature"),
    (Selection((FeatureRef("camera"),)), "/data/set/info.json", "camera", "expected a vector"),
    (Selection((FeatureRef("target"),)), "/data/set/info.json", "target", "per-episode field"),
    (Selection((FeatureRef("state", 5, 9),)), "/data/set/frames.parquet", "state", "selects no component"),
    (Selection((FeatureRef("state"),), (TaskParamRef(FeatureRef("goal")),)), "/data/set/info.json", "goal",
     "is per-frame (expected goal@first or goal@last)"),
    (Selection((FeatureRef("state"),), episodes=(7,)), "/data/set", None, "no episode 7"),
])
def test_a_bad_selection_names_file_feature_and_expectation(selection, file, feature, expected):
    with pytest.raises(DatasetError) as err:
        select_demos(_data(), selection)
    assert err.value.path == file and err.value.feature == feature and expected in str(err.value)
    assert "\n" not in str(err.value)


def test_nans_and_too_short_episodes_are_refused():
    with pytest.raises(DatasetError, match=r"feature 'state': episode 1 frame 2 holds NaN"):
        select_demos(_data(nan_at=1), Selection((FeatureRef("state"),)))
    with pytest.raises(DatasetError, match=r"episode 0 has 1 frame\(s\) \(expected at least 2"):
        select_demos(_data(lengths=(1, 4)), Selection((FeatureRef("state"),)))
