"""The E3 task settings: the paper's stays the task as it was, the authors' has their notebook's
geometry, trigger, stopping criterion and squared clearance; the CLI refuses a bad setting in one line."""
from __future__ import annotations

import math

import numpy as np
import pytest

from acnmp_core.baselines.promp_rl import PrompRLConfig
from acnmp_core.experiments import wall as E
from acnmp_core.tasks.wall import task as W
from acnmp_core.tasks.wall.settings import AUTHORS, PAPER, SETTING_NAMES, wall_setting
from clients.cli import main


def _straight(y_hole: float, x_c: float = 5.0, goal=(8.0, 5.0), end_off: float = 0.0) -> np.ndarray:
    """(1, T, 2): from the start to the hole's height before the wall, flat through it, to the goal."""
    x = np.linspace(0.0, goal[0], 200)
    y = np.where(x < x_c - 1.5, 5.0 + (y_hole - 5.0) * x / (x_c - 1.5), y_hole)
    y = np.where(x > x_c + 1.2, y_hole + (goal[1] - y_hole) * (x - x_c - 1.2) / (goal[0] - x_c - 1.2), y)
    p = np.stack([x, y], axis=1)
    p[-1, 1] += end_off
    return p[None]


def test_setting_values():
    assert SETTING_NAMES[0] == "paper" and wall_setting("paper") is PAPER
    assert (PAPER.wall_thickness, PAPER.hole_width, PAPER.goal_tolerance) == (W.WALL_THICKNESS, W.HOLE_WIDTH, 0.25)
    assert PAPER.same_criteria and not PAPER.squared_clearance
    assert PAPER.task() == W.WallTask()  # the default setting is the task as it always was
    a = wall_setting("authors")
    assert (a.wall_thickness, a.hole_width) == (2.0, 2.0)
    assert (a.goal_tolerance, a.trigger_tolerance) == (0.05, 0.15)
    assert a.goal_clearance**2 == pytest.approx(0.4) and a.trigger_clearance**2 == pytest.approx(0.2)
    assert a.squared_clearance and not a.same_criteria
    with pytest.raises(ValueError, match="expected one of paper, authors"):
        wall_setting("bogus")


def test_authors_criteria_and_squared_clearance():
    c = np.array([5.0, 5.0, 8.0, 5.0])
    centre, off = _straight(5.0), _straight(5.5)  # clearance 1.0 and 0.5 (squared 0.25)
    task, trigger = AUTHORS.task(), AUTHORS.trigger()
    assert task.success(centre, c)[0] and trigger.success(centre, c)[0]
    # Squared clearance 0.25: accepted by the trigger (>= 0.2) but short of the stop (> 0.4).
    assert trigger.success(off, c)[0] and not task.success(off, c)[0]
    # A goal error of 0.1: accepted (<= 0.15), not solved (> 0.05).
    near = _straight(5.0, end_off=0.1)
    assert trigger.success(near, c)[0] and not task.success(near, c)[0]
    t = np.linspace(0, 1, 200)
    m = task.scores(off, c).min_margin[0]
    assert m == pytest.approx(0.5, abs=1e-9)
    assert task.evaluate(off, t, c).returns[0] == pytest.approx(-0.0 + m * m - 0.0, abs=1e-6)
    assert W.WallTask(hole_width=2.0, wall_thickness=2.0).evaluate(off, t, c).returns[0] == pytest.approx(m, abs=1e-6)
    # The paper's thin wall at x = 5 +- 0.1 and hole 5 +- 0.5 would not be cleared by the offset path.
    assert not PAPER.task().success(off, c)[0]


def test_remaining_error_counts_the_missing_clearance():
    """The error an adaptation's exploration follows is how far a roll-out is from *this* task's
    success: in the authors' setting a path through the hole with clearance 0.5 (short of the
    0.632 asked for) and exact ends still has an error of 0.132, not 0 (with 0, the exploration
    narrowed to its floor while the clearance was still missing); the test metric and the paper setting (clearance 0) keep the depth into the wall."""
    c = np.array([5.0, 5.0, 8.0, 5.0])
    t = np.linspace(0, 1, 200)
    centre, off = _straight(5.0), _straight(5.5)
    task = AUTHORS.task()
    assert task.evaluate(off, t, c).errors[0] == pytest.approx(math.sqrt(0.4) - 0.5, abs=1e-9)
    assert task.evaluate(centre, t, c).errors[0] == pytest.approx(0.0, abs=1e-9)
    assert task.errors(off, c)[0] == pytest.approx(0.0, abs=1e-9)  # the test metric: no penetration
    into_wall = _straight(5.0 + 1.3)  # 0.3 beyond the hole's edge, inside the thick wall
    for paper_like in (PAPER.task(), W.WallTask(hole_width=2.0, wall_thickness=2.0)):
        batch = paper_like.evaluate(np.concatenate([into_wall, off]), t, c)
        np.testing.assert_allclose(batch.errors, paper_like.errors(np.concatenate([into_wall, off]), c))
    assert W.WallTask(hole_width=2.0, wall_thickness=2.0).evaluate(into_wall, t, c).errors[0] == \
        pytest.approx(0.3, abs=1e-9)


def test_authors_demonstrations_clear_the_thick_wall():
    setup = E.make_setup(1, seed=0, n_initial=30, n_test=5, setting=AUTHORS)
    y = np.stack([d.values for d in setup.initial])
    params = setup.initial.all_task_params()
    assert AUTHORS.task().success(y, params).all()
    # The paper's demonstrations are unchanged by the new parameters.
    t1, v1, _ = W.make_demo_set(5, np.random.default_rng(3), n_steps=50)
    t2, v2, _ = W.make_demo_set(5, np.random.default_rng(3), n_steps=50, wall_thickness=W.WALL_THICKNESS,
                                hole_width=W.HOLE_WIDTH)
    np.testing.assert_array_equal(v1, v2)


def test_cli_bad_setting_is_one_line(capsys):
    assert main(["experiment", "wall", "--setting", "bogus"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["acnmp: error: --setting: expected one of paper, authors, got 'bogus'"]
    assert main(["experiment", "wall", "--methods", "acnmp,nope"]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_trigger_decides_adaptation_in_the_loop():
    r = E.run_wall(3, 0, n_initial=12, n_test=10, eval_every=3, methods=("promp_rl",), setting=AUTHORS,
                   promp_config=PrompRLConfig(**{**E.PROMP_DEFAULTS, "max_rollouts": 60}))
    s = r["methods"]["promp_rl"]
    assert r["setting"] == "authors" and "test_success_rate_strict" in s
    assert s["test_success_rate_strict"] <= s["test_success_rate"]
    assert math.isfinite(s["test_error_mean"])


def test_cli_snap_options_reach_the_run(tmp_path, capsys):
    import json

    out = tmp_path / "e3.json"
    assert main(["experiment", "wall", "--envs", "1", "--initial", "10", "--test", "20", "--eval-every", "1",
                 "--methods", "promp_rl", "--snap-paths", "all", "--solutions-as-found", "--threads", "1", "--quiet",
                 "--json", str(out)]) == 0
    cfg = json.loads(out.read_text())["config"]
    assert (cfg["snap_outputs"], cfg["snap_rollouts"], cfg["snap_solutions"]) == (True, True, False)
    common = ["experiment", "wall", "--envs", "1", "--initial", "10", "--test", "20", "--methods", "promp_rl", "--quiet"]
    for flags, snapped, heading in (([], True, "boundary conditions enforced"),
                                    (["--snap-paths", "none"], False, "paths as generated (the paper's variant)")):
        capsys.readouterr()
        assert main([*common, *flags, "--json", str(out)]) == 0
        assert json.loads(out.read_text())["config"]["snap_outputs"] is snapped
        assert heading in capsys.readouterr().out
    assert main(["experiment", "wall", "--snap-paths", "ends"]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert main(["experiment", "wall", "--threads", "0"]) == 2
    assert "--threads" in capsys.readouterr().err
