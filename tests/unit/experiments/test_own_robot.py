"""``acnmp experiment robot`` (issue 33): a plugin robot and its demonstrations, LfD only against
ACNMP at named task parameters, in one process; wrong inputs are one line."""
from __future__ import annotations

import json

import numpy as np
import pytest

from clients.cli import main
from tests.paths import ROOT

pytest.importorskip("gymnasium", reason="gymnasium is not installed (scripts/setup.sh installs it)")
EXAMPLE = ROOT / "examples" / "my_robot"


def test_a_failed_adaptation_reports_what_it_executed(tmp_path, monkeypatch, capsys):
    """Issue 36 row 5: a failed run printed the error of a mean measured after the budget (inside
    the tolerance, yet "success False") while its curve ended elsewhere. Now the row's error is the
    last mean executed within the budget, the curve ends there, and the mean after the budget is
    named as such."""
    monkeypatch.syspath_prepend(str(EXAMPLE))
    out = tmp_path / "r.json"
    assert main(["experiment", "robot", "--robot", "my_robot.plugin:ROBOT", "--demos", str(EXAMPLE / "my_robot/demos.npz"),
                 "--at", "0.6,0.45", "--train-steps", "300", "--budget", "5", "--json", str(out)]) == 0
    run = json.loads(out.read_text())["runs"][1]
    assert run["method"] == "acnmp" and not run["success"] and run["rollouts"] == 5
    assert run["final_error"] == run["curve"][-1][1] and run["curve"][-1][0] <= 5
    assert isinstance(run["after_budget_error"], float)
    assert "the update after the budget, measured once and not counted" in capsys.readouterr().out


def test_a_plugin_robot_runs_lfd_and_acnmp_at_the_named_points(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(EXAMPLE))
    out = tmp_path / "r.json"
    assert main(["experiment", "robot", "--robot", "my_robot.plugin:ROBOT", "--demos", str(EXAMPLE / "my_robot/demos.npz"),
                 "--at", "0.6,0.45", "--at", "0.6,0.0", "--train-steps", "300", "--budget", "10", "--quiet",
                 "--json", str(out), "--plot", str(tmp_path / "r.png")]) == 0
    assert (tmp_path / "r.png").stat().st_size > 0
    r = json.loads(out.read_text())
    assert (r["robot"], r["task"], r["points"]) == ("my_arm", "reach", [[0.6, 0.45], [0.6, 0.0]])
    assert [(x["method"], x["case"]) for x in r["runs"]] == [("lfd", "point0"), ("acnmp", "point0"),
                                                              ("lfd", "point1"), ("acnmp", "point1")]
    far = r["runs"][0]
    assert not far["success"] and far["rollouts"] == 1 and far["final_error"] > 0.03  # 0.25 m beyond the demos
    assert all(x["rollouts"] <= 10 for x in r["runs"])


@pytest.mark.parametrize("args, message", [
    (["--at", "0.6"], "--at: expected points of 2 comma-separated task parameters, as the demonstrations have "
                      "(e.g. --at 0.6,-0.2, the first demonstration's); got 0.6 (1 value)"),
    (["--at", "0.6,0.1", "--at", "1,2,3"], "got 1,2,3 (3 values)"),
    (["--at", "0.6,x"], "argument --at: expected comma-separated numbers"),
    (["--at", "0.6,0.1", "--task", "push"], "task: robot 'my_arm' runs ['reach'], not 'push'"),
])
def test_wrong_inputs_are_one_line(args, message, monkeypatch, capsys):
    monkeypatch.syspath_prepend(str(EXAMPLE))
    code = main(["experiment", "robot", "--robot", "my_robot.plugin:ROBOT", "--demos",
                 str(EXAMPLE / "my_robot/demos.npz"), *args])
    err = capsys.readouterr().err
    assert code == 2 and message in err and "Traceback" not in err


def test_demonstrations_shorter_than_the_episode_say_so_in_one_line(tmp_path, capsys):
    """Issue 54 item 4: 50-row demonstrations on a 100-step environment ended in `KeyError:
    'goal_error'` from the user's error function; now one line says what happened and what to do."""
    from acnmp_core.data.demo_io import DemoArrays, save_demos

    s = np.linspace(0.0, 1.0, 50)
    demos = save_demos(tmp_path / "demos.npz", DemoArrays(np.tile(s, (3, 1)), np.stack([a * s[:, None] for a in (0.5, 1.0, 1.5)]),
                                                          np.array([[0.5], [1.0], [1.5]])))
    code = main(["experiment", "robot", "--robot", "tests.unit.robots.test_gym_robot:SLIDER", "--demos", str(demos), "--at", "1.0",
                 "--train-steps", "20", "--budget", "2", "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert "acnmp: error: GymRobotConfig.error: your function raised KeyError: 'goal_error'" in err
    assert "its 50 rows ran 50 steps and the environment had not ended its episode (its episodes last 100 " \
           "steps), so the last info is a mid-episode one; give trajectories of 100 rows" in err
