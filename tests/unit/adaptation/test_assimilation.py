"""snap_to_observations: an assimilated solution passes through the observations it was found for."""
import numpy as np
import pytest

from acnmp_core.adaptation.assimilation import snap_to_observations
from acnmp_core.adaptation.config import AdaptTarget
from acnmp_core.data.demos import Demonstration

T = np.linspace(0.0, 1.0, 101)
PATH = np.stack([10 * T, 5 + np.sin(3 * T)], axis=1)


def _target(times, values, mask=None):
    return AdaptTarget(np.asarray(times, float), np.asarray(values, float), np.zeros(4), T, mask)


def test_snapped_path_passes_through_start_and_goal_and_keeps_its_shape():
    target = _target([0.0, 1.0], [[0.1, 4.9], [9.8, 5.3]])
    out = snap_to_observations(Demonstration(T, PATH, np.arange(4.0)), target)
    np.testing.assert_allclose(out.values[0], [0.1, 4.9], atol=1e-12)
    np.testing.assert_allclose(out.values[-1], [9.8, 5.3], atol=1e-12)
    # the correction is linear in time between the two points: the second difference is unchanged
    np.testing.assert_allclose(np.diff(out.values, 2, axis=0), np.diff(PATH, 2, axis=0), atol=1e-12)
    np.testing.assert_array_equal(out.task_params, np.arange(4.0))
    np.testing.assert_array_equal(out.times, T)


def test_a_path_through_its_observations_is_unchanged():
    target = _target([0.0, 0.25, 1.0], PATH[[0, 25, 100]])
    out = snap_to_observations(Demonstration(T, PATH), target)
    np.testing.assert_allclose(out.values, PATH, atol=1e-12)


def test_masked_dimensions_and_repeated_times():
    # y observed twice at t = 0.5 (offsets averaged), x never: x stays, y moves by a constant
    target = _target([0.5, 0.5], [[99.0, PATH[50, 1] + 0.2], [-99.0, PATH[50, 1]]],
                     mask=np.array([[False, True], [False, True]]))
    out = snap_to_observations(Demonstration(T, PATH), target)
    np.testing.assert_allclose(out.values[:, 0], PATH[:, 0])
    np.testing.assert_allclose(out.values[:, 1], PATH[:, 1] + 0.1)


def test_observations_of_the_wrong_width_are_refused():
    with pytest.raises(ValueError, match="obs_values"):
        snap_to_observations(Demonstration(T, PATH), _target([0.0], [[1.0, 2.0, 3.0]]))


@pytest.mark.slow
def test_wall_run_counts_executed_snaps_and_by_default_every_generated_path_ends_on_the_goal():
    from acnmp_core.adaptation.config import AdaptConfig
    from acnmp_core.experiments.wall import run_wall

    # a small budget keeps the adaptations that fail short
    kw = dict(envs=2, seed=0, n_initial=12, n_test=20, eval_every=2, train_steps=300, assimilate_steps=10,
              adapt_config=AdaptConfig(max_rollouts=40))
    snapped = run_wall(**kw, methods=("acnmp",), snap_outputs=False)  # the paper's variant: paths as generated
    a = snapped["methods"]["acnmp"]
    assert a["test_goal_error_mean"] > 1e-3 and snapped["config"]["snap_outputs"] is False
    solved = a["adaptations"] - a["adaptations_failed"]
    assert solved > 0 and a["snaps_tried"] == solved and 0 <= a["snaps_kept"] <= solved
    assert snapped["config"]["snap_solutions"] is True

    from acnmp_core.baselines.promp_rl import PrompRLConfig
    from acnmp_core.experiments.wall import PROMP_DEFAULTS

    out = run_wall(**kw, promp_config=PrompRLConfig(**{**PROMP_DEFAULTS, "max_rollouts": 40}))
    for m in ("acnmp", "promp_rl"):
        assert out["methods"][m]["test_goal_error_mean"] < 1e-9
    assert out["config"]["snap_outputs"] is True


def test_snap_wall_paths_moves_each_path_onto_its_own_start_and_goal():
    from acnmp_core.experiments.wall import snap_wall_paths
    from acnmp_core.tasks.wall import task as W

    paths = np.stack([PATH, PATH + 0.3])
    c = np.array([[5.0, 5.0, 9.0, 2.0], [5.0, 5.0, 8.0, 7.0]])
    out = snap_wall_paths(paths, T, c)
    for b in range(2):
        np.testing.assert_allclose(out[b, 0], W.START, atol=1e-12)
        np.testing.assert_allclose(out[b, -1], c[b, 2:4], atol=1e-12)
    one = snap_wall_paths(paths, T, c[0])  # one row of task parameters for every path
    np.testing.assert_allclose(one[:, -1], [[9.0, 2.0], [9.0, 2.0]], atol=1e-12)
