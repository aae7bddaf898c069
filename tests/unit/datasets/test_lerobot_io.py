"""LeRobot v3 datasets in and out: a dataset lerobot itself wrote becomes demonstrations (`acnmp
demos import --format lerobot`), and a recording's roll-outs become a dataset (`acnmp replay
--export-lerobot`) that LeRobotDataset loads, every frame passing lerobot's own frame check.

The tests that use lerobot are slow (its import alone takes seconds to tens of seconds, and it
needs the ``datasets`` extra: `bash scripts/test.sh --slow` installs it); those without it run in
the default suite."""
from __future__ import annotations

import json

import numpy as np
import pytest

from acnmp_core.datasets.lerobot import read_lerobot
from acnmp_core.data.demo_io import load_demos

FEATURES = {"observation.state": {"dtype": "float32", "shape": (3,), "names": ["shoulder", "elbow", "wrist"]},
            "observation.environment_state": {"dtype": "float32", "shape": (2,), "names": ["x", "y"]},
            "action": {"dtype": "float32", "shape": (3,), "names": ["shoulder", "elbow", "wrist"]},
            "next.reward": {"dtype": "float32", "shape": (1,), "names": None},
            "next.success": {"dtype": "bool", "shape": (1,), "names": None}}


def _write_with_lerobot(lerobot, root, lengths=(12, 15, 9, 14)):
    """A dataset written by LeRobotDataset.create/add_frame/save_episode; returns its frames."""
    ds = lerobot.lerobot_dataset.LeRobotDataset.create("test/arm", fps=30, features=FEATURES, root=root, use_videos=False)
    rng = np.random.default_rng(5)
    episodes = []
    for e, t in enumerate(lengths):
        goal = rng.uniform(-1, 1, size=2).astype(np.float32)
        q = np.cumsum(rng.normal(scale=0.1, size=(t, 3)), axis=0).astype(np.float32)
        for k in range(t):
            ds.add_frame({"observation.state": q[k], "observation.environment_state": goal, "action": q[min(k + 1, t - 1)],
                          "next.reward": np.array([-1.0], np.float32),
                          "next.success": np.array([k == t - 1 and e != 2]), "task": "reach"})
        ds.save_episode()
        episodes.append((q, goal))
    ds.finalize()
    return episodes


@pytest.mark.slow
def test_a_dataset_lerobot_wrote_becomes_demonstrations(lerobot, tmp_path, run_cli):
    episodes = _write_with_lerobot(lerobot, tmp_path / "arm")
    out = tmp_path / "demos.npz"
    code, stdout, err = run_cli("demos", "import", "--format", "lerobot", str(tmp_path / "arm"), "-o", str(out),
                                "--trajectory", "observation.state[0:2]", "--task-params",
                                "observation.environment_state@first", "--successful")
    assert code == 0, err
    demos = load_demos(out)
    kept = [episodes[i] for i in (0, 1, 3)]  # episode 2 did not succeed
    assert demos.values.shape == (3, 15, 2) and demos.lengths.tolist() == [12, 15, 14]
    for i, (q, goal) in enumerate(kept):
        np.testing.assert_array_equal(demos.values[i, :len(q)], q[:, :2])
        np.testing.assert_array_equal(demos.task_params[i], goal)
        np.testing.assert_allclose(demos.times[i, :len(q)], np.linspace(0, 1, len(q)), atol=1e-6)
    assert demos.value_names.tolist() == ["shoulder", "elbow"]
    assert demos.task_param_names.tolist() == ["x", "y"]


@pytest.mark.slow
def test_recorded_rollouts_export_as_a_dataset_lerobot_loads_and_checks(lerobot, tmp_path, recording, run_cli):
    path, rollouts = recording
    root = tmp_path / "e1-lerobot"
    code, out, err = run_cli("replay", str(path), "--export-lerobot", str(root), "--fps", "50")
    assert code == 0, err
    ds = lerobot.lerobot_dataset.LeRobotDataset("acnmp/e1", root=root)
    steps = [len(r["times"]) for r in rollouts]
    assert ds.num_episodes == len(rollouts) and len(ds) == sum(steps) and ds.fps == 50
    assert ds.meta.stats is not None and set(ds.meta.stats) >= {"action", "observation.state", "next.reward"}
    start = 0
    for e, r in enumerate(rollouts):
        for k in range(steps[e]):
            item = ds[start + k]
            frame = {name: np.asarray(item[name].numpy(), dtype=spec["dtype"]).reshape(spec["shape"])
                     for name, spec in ds.features.items() if name not in lerobot.utils.DEFAULT_FEATURES}
            lerobot.utils.validate_frame({**frame, "task": item["task"]}, ds.features)  # lerobot's own check
            assert item["task"] == "viapoint" and int(item["episode_index"]) == e
            np.testing.assert_allclose(frame["action"], r["trajectory"][k], rtol=1e-6)  # loaded as float32
        start += steps[e]
    episode = ds.meta.episodes[3]
    assert episode["acnmp/job"] == rollouts[3]["job"] and episode["acnmp/success"] == rollouts[3]["success"]
    # and back: the successful ones as demonstrations, bit for bit (read here at float64)
    back = tmp_path / "back.npz"
    assert run_cli("demos", "import", "--format", "lerobot", str(root), "-o", str(back), "--trajectory", "action",
                   "--task-params", "acnmp/task_params", "--successful")[0] == 0
    good = [r for r in rollouts if r["success"]]
    np.testing.assert_array_equal(load_demos(back).values, np.stack([r["trajectory"] for r in good]))


def test_the_export_reads_back_without_lerobot(tmp_path, recording, run_cli):
    path, rollouts = recording
    root = tmp_path / "e1"
    assert run_cli("replay", str(path), "--export-lerobot", str(root))[0] == 0
    info = json.loads((root / "meta" / "info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["total_episodes"] == len(rollouts) == 6
    data = read_lerobot(root)
    for ep, r in zip(data.episodes, rollouts):
        np.testing.assert_array_equal(ep.frames["action"], r["trajectory"])
        np.testing.assert_array_equal(ep.frames["observation.state"][1:], r["trajectory"][:-1])
        np.testing.assert_array_equal(ep.frames["observation.phase"][:, 0], r["times"])
        np.testing.assert_array_equal(ep.fields["acnmp/task_params"], r["task_params"])
        assert ep.success == r["success"] and ep.labels["acnmp/method"] == "acnmp"


@pytest.mark.parametrize("setup, args, expected", [
    ("none", ["--trajectory", "action"], "not a LeRobot dataset (expected a directory with meta/info.json)"),
    ("v2", ["--trajectory", "action"], "info.json: codebase_version v2.1 (expected v3.x"),
    ("ok", ["--trajectory", "actions"], "info.json: feature 'actions': no such per-frame feature"),
    ("ok", ["--trajectory", "action", "--resample", "1"], "--resample"),
    ("ok", ["--trajectory", "action[0", ], "not a feature reference"),
])
def test_bad_input_is_one_line_exit_2_and_nothing_written(tmp_path, recording, run_cli, setup, args, expected):
    root = tmp_path / "ds"
    if setup != "none":
        assert run_cli("replay", str(recording[0]), "--export-lerobot", str(root))[0] == 0
    if setup == "v2":
        info = json.loads((root / "meta" / "info.json").read_text())
        (root / "meta" / "info.json").write_text(json.dumps({**info, "codebase_version": "v2.1"}))
    out = tmp_path / "demos.npz"
    code, _, err = run_cli("demos", "import", "--format", "lerobot", str(root), "-o", str(out), *args)
    assert code == 2 and expected in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists()


def test_an_export_never_writes_into_an_existing_dataset(tmp_path, recording, run_cli):
    root = tmp_path / "ds"
    root.mkdir()
    (root / "keep.txt").write_text("mine")
    code, _, err = run_cli("replay", str(recording[0]), "--export-lerobot", str(root))
    assert code == 2 and "already exists" in err
    assert [p.name for p in root.iterdir()] == ["keep.txt"]
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".ds.")] == []  # no temporary left
