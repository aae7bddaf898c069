"""Minari datasets in and out: a dataset minari itself wrote from a Gymnasium environment becomes
demonstrations (`acnmp demos import --format minari`), and a recording's roll-outs become a
dataset (`acnmp replay --export-minari`) that minari loads and whose every step fits its spaces."""
from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from acnmp_core.datasets.minari import read_minari
from acnmp_core.data.demo_io import load_demos
from clients.cli import main

minari = pytest.importorskip("minari", reason="minari is not installed (the test extra installs it)")


def _pendulum_dataset(dataset_id: str, episodes: int = 4, steps: int = 20):
    """A dataset written by minari's own API from Pendulum-v1 episodes (random torques, seeded).
    (minari's DataCollector needs jax; create_dataset_from_buffers with whole episodes does not.)"""
    from minari.data_collector import EpisodeBuffer

    env = gym.make("Pendulum-v1", max_episode_steps=steps)
    rng = np.random.default_rng(3)
    buffers = []
    for i in range(episodes):
        obs, _ = env.reset(seed=i)
        observations, actions, rewards = [obs], [], []
        for _ in range(steps):
            action = rng.uniform(-2, 2, size=1).astype(np.float32)
            obs, reward, term, trunc, _ = env.step(action)
            observations.append(obs), actions.append(action), rewards.append(reward)
        success = np.zeros(steps, dtype=bool)
        success[-1] = i % 2 == 0
        buffers.append(EpisodeBuffer(id=i, seed=i, observations=np.array(observations), actions=np.array(actions),
                                     rewards=rewards, terminations=[False] * steps, truncations=[False] * (steps - 1) + [True],
                                     infos={"success": success}, options={"goal": np.array([0.1 * i, 1.0])}))
    return minari.create_dataset_from_buffers(dataset_id, buffers, env=env, eval_env=env, algorithm_name="random",
                                              author="test", author_email="test@example.org",
                                              code_permalink="tests/unit/datasets", description="pendulum")


def test_a_dataset_minari_wrote_becomes_demonstrations(minari_root, tmp_path, run_cli):
    written = _pendulum_dataset("test/pendulum-v0")
    out = tmp_path / "demos.npz"
    code, stdout, err = run_cli("demos", "import", "--format", "minari", "test/pendulum-v0", "-o", str(out),
                                "--trajectory", "observations[0:2],actions", "--task-params",
                                "observations[2]@first,options/goal", "--successful")
    assert code == 0, err
    demos = load_demos(out)
    kept = [ep for ep in written.iterate_episodes() if ep.infos["success"].any()]
    assert demos.values.shape == (2, 20, 3)  # observations cut to the 20 actions
    for i, ep in enumerate(kept):
        np.testing.assert_allclose(demos.values[i, :, :2], ep.observations[:20, :2])
        np.testing.assert_allclose(demos.values[i, :, 2], ep.actions[:, 0])
        np.testing.assert_allclose(demos.task_params[i], [ep.observations[0, 2], 0.1 * ep.id, 1.0])
    np.testing.assert_allclose(demos.times[0], np.linspace(0, 1, 20))
    assert demos.value_names.tolist() == ["observations[0]", "observations[1]", "actions"]
    assert demos.task_param_names.tolist() == ["observations[2]", "options/goal[0]", "options/goal[1]"]


def test_observations_align_with_the_steps_they_start_or_reach(minari_root, tmp_path, run_cli):
    """Issue 65, friction 5: Minari's observations hold T+1 rows (the reset state first); a skill
    imported from them alone was shifted one step, and nothing could align them."""
    written = _pendulum_dataset("test/pendulum-v0", episodes=2)
    episodes = list(written.iterate_episodes())
    for align, rows in ((None, slice(0, 21)), ("after", slice(1, 21)), ("before", slice(0, 20))):
        out = tmp_path / f"{align}.npz"
        code, _, err = run_cli("demos", "import", "--format", "minari", "test/pendulum-v0", "-o", str(out),
                               "--trajectory", "observations[0:2]", *(["--align", align] if align else []))
        assert code == 0, err
        demos = load_demos(out)
        for i, ep in enumerate(episodes):
            np.testing.assert_allclose(demos.values[i], ep.observations[rows, :2])
        np.testing.assert_allclose(demos.times[0], np.linspace(0, 1, rows.stop - rows.start))


@pytest.mark.parametrize("args, expected", [
    (["--trajectory", "observation"], "main_data.hdf5: feature 'observation': no such per-frame feature"),
    (["--trajectory", "actions", "--task-params", "options/gaol"], "feature 'options/gaol': no such per-episode field"),
    (["--trajectory", "actions", "--episodes", "9"], "no episode 9"),
])
def test_bad_input_is_one_line_exit_2_and_nothing_written(minari_root, tmp_path, run_cli, args, expected):
    _pendulum_dataset("test/pendulum-v0", episodes=2)
    out = tmp_path / "demos.npz"
    code, _, err = run_cli("demos", "import", "--format", "minari", "test/pendulum-v0", "-o", str(out), *args)
    assert code == 2 and expected in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists()


def test_not_a_minari_dataset_is_named(minari_root, tmp_path, run_cli):
    code, _, err = run_cli("demos", "import", "--format", "minari", "nobody/nothing-v0", "-o", str(tmp_path / "d.npz"),
                           "--trajectory", "actions")
    assert code == 2 and "nobody/nothing-v0: not a Minari dataset" in err


def test_recorded_rollouts_export_as_a_dataset_minari_loads_and_checks(minari_root, tmp_path, recording, run_cli):
    path, rollouts = recording
    code, out, err = run_cli("replay", str(path), "--export-minari", "acnmp/e1-rollouts-v0")
    assert code == 0, err
    ds = minari.load_dataset("acnmp/e1-rollouts-v0")
    assert ds.total_episodes == len(rollouts) and ds.total_steps == sum(len(r["times"]) for r in rollouts)
    meta = list(ds.storage.get_episode_metadata(range(ds.total_episodes)))
    for ep, m, r in zip(ds.iterate_episodes(), meta, rollouts):
        steps = len(r["times"])
        assert len(ep) == steps and ep.observations["state"].shape == (steps + 1, 2)
        for k in range(steps + 1):  # minari's spaces hold every step the export wrote
            assert ds.observation_space.contains({key: v[k] for key, v in ep.observations.items()})
        assert all(ds.action_space.contains(a) for a in ep.actions)
        np.testing.assert_array_equal(ep.actions, r["trajectory"])
        np.testing.assert_array_equal(ep.rewards, r["reward"])
        assert bool(ep.terminations[-1]) == r["success"] and bool(ep.truncations[-1]) != r["success"]
        assert m["acnmp"]["job"] == r["job"] and m["acnmp"]["method"] == "acnmp" and m["acnmp"]["skill"] == "e1"
        np.testing.assert_array_equal(m["acnmp"]["task_params"], r["task_params"])
    assert "acnmp/e1-rollouts-v0" in minari.list_local_datasets()
    # and back: the successful ones as demonstrations, bit for bit
    demos_path = tmp_path / "back.npz"
    assert run_cli("demos", "import", "--format", "minari", "acnmp/e1-rollouts-v0", "-o", str(demos_path),
                   "--trajectory", "actions", "--task-params", "acnmp/task_params", "--successful")[0] == 0
    good = [r for r in rollouts if r["success"]]
    demos = load_demos(demos_path)
    np.testing.assert_array_equal(demos.values, np.stack([r["trajectory"] for r in good]))
    np.testing.assert_array_equal(demos.task_params, np.stack([r["task_params"] for r in good]))


def test_an_existing_dataset_is_not_overwritten(minari_root, recording, run_cli):
    path, _ = recording
    assert run_cli("replay", str(path), "--export-minari", "acnmp/once-v0")[0] == 0
    assert len(read_minari("acnmp/once-v0").episodes) == 6
    before = sorted(p.name for p in (minari_root / "acnmp").iterdir())
    code, _, err = run_cli("replay", str(path), "--export-minari", "acnmp/once-v0")
    assert code == 2 and "already exists" in err
    assert sorted(p.name for p in (minari_root / "acnmp").iterdir()) == before
