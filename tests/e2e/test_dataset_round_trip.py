"""Datasets both ways on a deployment.

1. E1 run across a local deployment and recorded; its roll-outs exported as a LeRobot and a
   Minari dataset and as ROS 2 bags, each loaded by its own library (rosbags for the bags), the
   successful roll-outs imported back as demonstrations (bit for bit), and a skill trained on them
   reproduces every one within E1's tolerance (0.03 m). benchmarks/performance/bench_datasets.py
   is the same at full size.
2. A dataset from outside the project: episodes of examples/my_robot's Gymnasium environment
   (ReachEnv) driven by an expert, written by minari's own API, imported with `acnmp demos import`,
   trained on a deployment of that robot (`acnmp up --demos`), and adapted there to a goal beyond
   every episode of the dataset.

Both need minutes and the formats' libraries (the ``datasets`` extra): slow."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from benchmarks.performance.bench_datasets import FORMATS, library_load, round_trip
from tests.e2e.test_my_robot_example import EXAMPLE, installed_example  # noqa: F401  (a fixture)
from tests.e2e.test_up_demos import ctrl_c_at_the_end

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_e1_recorded_exported_loaded_imported_and_reproduced(tmp_path, lerobot, run_cli, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    rrd = tmp_path / "e1.rrd"
    code, _, err = run_cli("experiment", "viapoint", "--seeds", "7-7", "--budget", "30", "--train-steps", "3000",
                           "--distributed", "--fresh", "--workers", "2", "--record", str(rrd), "--quiet")
    assert code == 0, err
    for fmt in FORMATS:
        (tmp_path / fmt).mkdir()
        r = round_trip(rrd, fmt, tmp_path / fmt, load=library_load)
        assert r["library_episodes"] == r["rollouts"] > 0, r  # the format's own library read every episode
        assert r["successful"] >= 1 and r["imported_bit_for_bit"], r
        assert r["within_tolerance"], r  # each successful roll-out reproduced within 0.03 m (RMSE)


def _reach_episodes(goals):
    """Expert episodes of ReachEnv: joint velocities along a minimum-jerk path to each goal's
    elbow-down inverse kinematics; (observations (51, 6), actions (50, 2), infos) each."""
    from my_robot.env import START, STEPS, ReachEnv
    from my_robot.make_demos import ik

    env = ReachEnv()
    s = np.linspace(0.0, 1.0, STEPS + 1)
    blend = 10 * s**3 - 15 * s**4 + 6 * s**5
    out = []
    for goal in goals:
        path = START + blend[:, None] * (ik(goal) - START)
        obs, _ = env.reset(options={"task_params": goal})
        observations, actions, rewards, success, distance = [obs], [], [], [], []
        for k in range(STEPS):
            action = ((path[k + 1] - path[k]) / env.dt).astype(np.float32)
            obs, reward, _, _, info = env.step(action)
            observations.append(obs), actions.append(action), rewards.append(reward)
            success.append(info["is_success"]), distance.append(info["distance"])
        out.append((np.array(observations), np.array(actions), rewards, np.array(success), np.array(distance)))
    return env, out


@pytest.mark.slow
def test_a_minari_dataset_of_a_gymnasium_env_is_imported_trained_and_adapted_beyond_it(
        installed_example, acnmp_up, tmp_path, run_cli, monkeypatch):  # noqa: F811
    import minari
    from minari.data_collector import EpisodeBuffer

    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    monkeypatch.syspath_prepend(str(installed_example))
    goals = np.array([[0.6, y] for y in (-0.2, -0.1, 0.0, 0.1, 0.2)])
    env, episodes = _reach_episodes(goals)
    buffers = [EpisodeBuffer(id=i, observations=obs, actions=act, rewards=rew, terminations=[False] * len(rew),
                             truncations=[False] * (len(rew) - 1) + [True], infos={"is_success": ok, "distance": dist},
                             options={"task_params": goal})
               for i, ((obs, act, rew, ok, dist), goal) in enumerate(zip(episodes, goals))]
    minari.create_dataset_from_buffers("reach/expert-v0", buffers, observation_space=env.observation_space,
                                       action_space=env.action_space, algorithm_name="minimum-jerk expert",
                                       author="acnmp tests", author_email="-", code_permalink="tests/e2e",
                                       description="ReachEnv reaches to x = 0.6 m, y in [-0.2, 0.2] m")
    assert all(ok[-1] for _, _, _, ok, _ in episodes)

    demos = tmp_path / "reach.npz"
    code, out, err = run_cli("demos", "import", "--format", "minari", "reach/expert-v0", "-o", str(demos),
                             "--trajectory", "observations[0:2]", "--task-params", "observations[4:6]@first",
                             "--successful")
    assert code == 0 and "5 demonstrations of up to 51 steps x 2 dims" in out, err

    env_vars = dict(os.environ, PYTHONPATH=os.pathsep.join([str(installed_example), str(ROOT)]))
    proc, _ = acnmp_up("--robot", "my_arm", "--workers", "1", "--no-default-skill", "--demos", f"reach={demos}",
                       "--train-steps", "800", "--state-dir", str(tmp_path / "state"), path=(str(installed_example),))
    with ctrl_c_at_the_end(proc):
        run = subprocess.run([sys.executable, str(EXAMPLE / "adapt.py"), "0.6", "0.45"], cwd=tmp_path, env=env_vars,
                             capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stderr[-2000:]
    assert "success True" in run.stdout, run.stdout  # y = 0.45 m: beyond every episode's goal (|y| <= 0.2)
