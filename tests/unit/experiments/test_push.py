"""E2 in small: one seed, reduced training and budgets. ACNMP pushes the cylinder to the held-out
interpolation target with no adaptation; the result dict (and so --json) has the documented keys."""
from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from acnmp_core.adaptation.config import AdaptConfig
from acnmp_core.baselines.promp_rl import PrompRLConfig
from acnmp_core.experiments.push import CASES, METHODS, curve_band, make_setup, make_target, run_push
from acnmp_core.experiments.plots import plot_push

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def demo_path(tmp_path_factory):
    return str(tmp_path_factory.mktemp("push") / "push_demos_3dof.npz")


@pytest.fixture(scope="module")
def result(demo_path):
    return run_push([0], train_steps=2000, demo_path=demo_path,
                    adapt_config=AdaptConfig(max_rollouts=7),
                    promp_config=PrompRLConfig(n_samples=4, max_rollouts=11))


def test_setup_conditions_on_target_and_start(demo_path):
    setup = make_setup(demo_path)
    assert len(setup.demos) == 9 and setup.demos.n_task_params == 2 and setup.demos.n_outputs == 3
    for case in CASES:
        t = make_target(setup, case)
        np.testing.assert_array_equal(t.task_params, setup.targets[case])
        assert t.obs_times.tolist() == [0.0]
        np.testing.assert_array_equal(t.obs_values[0], setup.q0)
        assert t.query_times.shape == (300,)
    # every demonstration starts from the same configuration, the one conditioned on
    for d in setup.demos:
        np.testing.assert_allclose(d.values[0], setup.q0)


@pytest.mark.slow
def test_acnmp_interpolates_without_adaptation(result):
    s = result["methods"]["acnmp"]["interpolation"]
    assert s["success_rate"] == 1.0
    assert s["rollouts_median"] == 1  # the LfD roll-out alone
    assert s["final_error_median"] <= result["tolerance"]
    run = next(r for r in result["runs"] if r["method"] == "acnmp" and r["case"] == "interpolation")
    assert not run["adapted"]


@pytest.mark.slow
def test_result_has_documented_keys(result, tmp_path):
    r = json.loads(json.dumps(result))  # JSON-ready
    assert r["experiment"] == "push" and r["seeds"] == 1 and r["wall_time_s"] > 0
    for m in METHODS:
        for c in CASES:
            s = r["methods"][m][c]
            assert {"rollouts_median", "success_rate", "final_error_median"} <= set(s)
            assert 0.0 <= s["success_rate"] <= 1.0
    assert set(r["rollout_ratio_promp_over_acnmp"]) == set(CASES)
    # each method is scored on the reward it optimises: ACNMP per step, the episodic ProMP at the end
    assert r["config"]["rewards"] == {"acnmp": "distance", "promp_rl": "final"}
    # budgets are respected (ACNMP's first roll-out is the LfD one)
    for run in r["runs"]:
        assert run["rollouts"] <= (7 if run["method"] == "acnmp" else 11)
        assert run["curve"][-1][0] == run["rollouts"]


def test_push_figure_shows_each_case_and_method(saved_figures, tmp_path):
    """The Fig. 5(b)-like plot: one panel per case, a median curve per method that ends where its
    runs end, the tolerance line; checked on the figure, not the PNG."""
    runs = [{"method": m, "case": c, "curve": [[1, 0.3], [n, e]], "rollouts": n}
            for m, n, e in (("acnmp", 5, 0.02), ("promp_rl", 9, 0.04)) for c in CASES]
    result = {"runs": runs, "tolerance": 0.03, "seeds": 1,
              "methods": {m: {c: {"rollouts_median": n, "success_rate": 1.0} for c in CASES}
                          for m, n in (("acnmp", 5), ("promp_rl", 9))}}
    path = plot_push(result, tmp_path / "fig.png")
    assert path.exists() and [p for _, p in saved_figures] == [path]
    fig = saved_figures[0][0]
    assert len(fig.axes) == len(CASES)
    for ax, case in zip(fig.axes, CASES):
        assert case in ax.get_title() and ax.get_xlabel() == "roll-outs"
        legend = [t.get_text() for t in ax.get_legend().get_texts()]
        assert any(t.startswith("ACNMP: median 5 roll-outs") for t in legend)
        assert any(t.startswith("ProMP + RL (REPS): median 9 roll-outs") for t in legend)
        curves = {line.get_label(): line.get_xydata() for line in ax.get_lines()}
        acnmp = next(xy for label, xy in curves.items() if label.startswith("ACNMP"))
        # the median curve over roll-outs 1..9 (the longest run): from its first value, reaching its
        # last at 5 roll-outs and holding it after
        assert acnmp[0].tolist() == [1, 0.3] and acnmp[:, 0].tolist() == list(range(1, 10))
        assert set(acnmp[4:, 1]) == {0.02}
        tolerance = next(xy for label, xy in curves.items() if label.startswith("tolerance"))
        assert set(tolerance[:, 1]) == {0.03}


def test_curve_band_holds_last_value():
    med, lo, hi = curve_band([[[1, 0.5], [4, 0.1]], [[1, 0.3]]], np.arange(1, 6))
    np.testing.assert_allclose(med, [0.4, 0.4, 0.4, 0.2, 0.2])
    assert np.all(lo <= med) and np.all(med <= hi)
