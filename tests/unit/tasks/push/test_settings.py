"""E2's two task settings and the authors' dense tracking reward, on the PyBullet arm."""
import numpy as np
import pytest

from acnmp_core.experiments.push import make_setup, make_task, reference_path, reward_for, task_config
from acnmp_core.tasks.push.settings import AUTHORS, PAPER, SETTING_NAMES, push_setting


@pytest.fixture(scope="module")
def authors_demo_path(tmp_path_factory):
    return str(tmp_path_factory.mktemp("demos") / "authors.npz")


@pytest.fixture(scope="module")
def authors(authors_demo_path):
    return make_setup(authors_demo_path, setting=AUTHORS)


def test_setting_is_chosen_by_name():
    assert SETTING_NAMES[0] == "paper" and push_setting("paper") is PAPER and push_setting("authors") is AUTHORS
    with pytest.raises(ValueError, match="paper, authors"):
        push_setting("Paper")


def test_authors_targets_keep_their_directions_and_order_of_distances():
    t = AUTHORS.targets() - np.asarray(AUTHORS.start_xy)
    ang = np.degrees(np.arctan2(t[:, 1], t[:, 0]))
    dist = np.linalg.norm(t, axis=1)
    # Training -109..132 deg, extrapolation 151 deg (plus the 1 deg fit), outside the training range.
    assert ang[:9].min() == pytest.approx(-108.1, abs=0.05) and ang[:9].max() == pytest.approx(132.6, abs=0.05)
    assert ang[9] == pytest.approx(151.9, abs=0.05) and dist[9] > dist[:9].max()
    # The paper setting's targets are as before.
    p = PAPER.targets() - np.asarray(PAPER.start_xy)
    assert np.linalg.norm(p[9]) == pytest.approx(0.18) and np.degrees(np.arctan2(p[9, 1], p[9, 0])) == pytest.approx(140)


def test_expert_reaches_every_authors_target(authors):
    paths = np.stack([reference_path(authors, c) for c in ("interpolation", "extrapolation")])
    ends = paths[:, -1]
    targets = np.stack([authors.targets["interpolation"], authors.targets["extrapolation"]])
    assert np.all(np.linalg.norm(ends - targets, axis=1) < 0.01)
    assert np.allclose(paths[:, 0], AUTHORS.start_xy, atol=1e-3)


def test_tracking_reward_is_minus_squared_distance_to_the_heldout_path(authors):
    assert reward_for(AUTHORS, "acnmp") == "tracking" and reward_for(AUTHORS, "promp_similar") == "final"
    assert reward_for(PAPER, "acnmp") == "distance"
    case = "extrapolation"
    ref = reference_path(authors, case)
    held_out = authors.demo_arrays.with_role(case).values
    other = authors.demo_arrays.with_role("train").values[:1]
    with make_task(authors, "acnmp", case) as task:
        batch = task.evaluate(np.concatenate([held_out, other]), authors.times, authors.targets[case])
    # The held-out demonstration itself tracks its path exactly (the simulator is reset bit-exactly).
    np.testing.assert_array_equal(batch.rewards[0], np.zeros(len(authors.times)))
    obj = batch.states["object_xy"][1]
    np.testing.assert_allclose(batch.rewards[1], -np.sum((obj - ref) ** 2, axis=1))
    assert batch.rewards[1].sum() < 0
    # Success is the same criterion as in the paper setting: the final distance to the target.
    assert batch.success[0] and not batch.success[1]
    np.testing.assert_allclose(batch.errors, np.linalg.norm(batch.states["object_xy"][:, -1] - authors.targets[case],
                                                            axis=1))


def test_tracking_needs_its_reference_and_workers_run_the_paper_setting_only(authors):
    from acnmp_core.tasks.push.task import PlanarPushTask

    with pytest.raises(ValueError, match="reference_path"):
        PlanarPushTask(reward="tracking")
    with pytest.raises(ValueError, match="paper setting only"):
        task_config(authors, "acnmp")


def test_baselines_run_every_method_on_one_budget(authors, authors_demo_path):
    from acnmp_core.experiments.push_baselines import METHODS, run_push_baselines

    assert METHODS == ("acnmp", "promp_scratch", "promp_similar", "promp_mixture", "promp_tuned")
    r = run_push_baselines([0], setting=AUTHORS, budget=8, train_steps=50, cases=("extrapolation",),
                           demo_path=authors_demo_path)
    assert r["setting"] == "authors" and r["budget"] == 8
    for m in METHODS:
        s = r["methods"][m]["extrapolation"]
        assert set(s) >= {"rollouts_median", "success_rate", "final_error_median"}
    for run in r["runs"]:
        # Every executed trajectory counts, the mean's too, and no method exceeds the common budget.
        assert 1 <= run["rollouts"] <= 8 and run["curve"][-1][0] <= run["rollouts"]
    # The effect-based starts differ from the scratch start (which holds the home posture: the
    # cylinder stays where it is, at the full distance to the target).
    first = {run["method"]: run["lfd_error"] for run in r["runs"]}
    start_dist = float(np.linalg.norm(AUTHORS.targets()[9] - np.asarray(AUTHORS.start_xy)))
    assert first["promp_scratch"] == pytest.approx(start_dist, abs=2e-3)
    assert first["promp_similar"] < start_dist and first["promp_mixture"] < start_dist


def test_cli_refuses_workers_in_the_authors_setting_in_one_line(capsys):
    from clients.cli import main

    assert main(["experiment", "push", "--setting", "authors", "--distributed", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "paper setting only" in err and len(err.strip().splitlines()) == 1
