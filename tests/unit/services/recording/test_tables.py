"""A recording as data (services/recording/tables.py): the roll-outs back at float64 with their job's
method, robot and task; Parquet; demonstrations; re-execution that catches a changed result."""
from __future__ import annotations

import json

import numpy as np
import pyarrow.parquet as pq
import pytest

from acnmp_core.data.demo_io import load_demos
from acnmp_core.experiments.viapoint import make_setup
from clients.cli import main
from services.recording.events import batch_rollout_events, job_event, validate_event
from services.recording.reexecute import reexecute
from services.recording.rrd_writer import RrdWriter
from services.recording.tables import read_recording
from services.transport import WireError

JOB = "e1-0123456789"


def _record(path, setup, trajectories, *, first_index=0, job_event_too=True, tamper=None):
    """Execute ``trajectories`` (B, T, 2) on E1's task and record them as the learner does."""
    writer = RrdWriter(path)
    if job_event_too:
        writer.log_event(job_event(JOB, method="acnmp", robot="point2d", task="viapoint", skill="e1", seed=5,
                                   attempt=0, config={"max_rollouts": 9}, task_config=setup.task_config))
    times = setup.target.query_times
    batch = setup.task.evaluate(trajectories, times, None)
    for ev in batch_rollout_events(JOB, first_index, trajectories, times, batch, skill="e1", iteration=0):
        ev["attempt"] = 0
        if tamper is not None and ev["rollout_index"] == tamper:
            ev["return"] += 1e-9
        writer.log_event(ev)
    writer.close()
    return batch


@pytest.fixture(scope="module")
def setup():
    return make_setup()


def _paths(setup, n=4, seed=0):
    rng = np.random.default_rng(seed)
    base = np.stack([d.values for d in setup.demos])[:, :: max(1, setup.demos[0].values.shape[0] // 101)]
    t = len(setup.target.query_times)
    return np.stack([np.interp(setup.target.query_times, np.linspace(0, 1, base.shape[1]), base[i % len(base), :, d])
                     for i in range(n) for d in range(2)]).reshape(n, 2, t).transpose(0, 2, 1) \
        + rng.normal(scale=1e-3, size=(n, t, 2)) * np.pi  # float64 digits float32 would lose


def test_rollouts_come_back_at_float64_with_their_jobs_method(tmp_path, setup):
    paths = _paths(setup)
    batch = _record(tmp_path / "r.rrd", setup, paths)
    t = read_recording(tmp_path / "r.rrd")
    assert t.rollouts.num_rows == 4 and t.jobs.num_rows == 1
    np.testing.assert_array_equal(t.trajectories(JOB), paths)  # bit for bit
    row = t.rollout_rows(JOB)[2]
    assert (row["method"], row["robot"], row["task"], row["skill"], row["attempt"]) == ("acnmp", "point2d", "viapoint",
                                                                                         "e1", 0)
    np.testing.assert_array_equal(row["reward"], batch.rewards[2])
    np.testing.assert_array_equal(row["times"], setup.target.query_times)
    assert json.loads(t.jobs.to_pylist()[0]["task_config"]) == json.loads(json.dumps(setup.task_config))


def test_parquet_tables_and_a_roll_out_in_two_files_once(tmp_path, setup):
    paths = _paths(setup, n=3)
    _record(tmp_path / "a.rrd", setup, paths)
    _record(tmp_path / "b.rrd", setup, paths[1:], first_index=1, job_event_too=False)  # 1, 2 again
    written = read_recording([tmp_path / "a.rrd", tmp_path / "b.rrd"]).write_parquet(tmp_path / "out")
    rollouts = pq.read_table(written["rollouts"])
    assert sorted(rollouts.column("rollout_index").to_pylist()) == [0, 1, 2]
    assert np.asarray(rollouts.column("trajectory").to_pylist()[0]).shape == (len(setup.target.query_times), 2)
    assert set(written) == {"rollouts", "jobs", "latents", "models", "metrics"}


def test_a_tasks_parameters_are_columns_an_outside_reader_filters_on(tmp_path, setup, capsys):
    """E1's via-point sat in jobs.task_config as JSON text and rollouts.task_params was null: now
    every task parameter is a column of its own in both tables, read by pyarrow alone."""
    paths = _paths(setup)
    writer = RrdWriter(tmp_path / "r.rrd")
    writer.log_event(job_event(JOB, method="acnmp", robot="point2d", task="viapoint", task_config=setup.task_config))
    times = setup.target.query_times
    batch = setup.task.evaluate(paths, times, None)
    for ev in batch_rollout_events(JOB, 0, paths, times, batch):
        writer.log_event(ev)
    two = setup.task.evaluate(paths[:2], times, None)
    for ev in batch_rollout_events("reach-1", 0, paths[:2], times, two, task_params=np.array([0.6, 0.45])):
        writer.log_event(ev)  # a robot task whose parameters travel with each roll-out
    writer.close()
    assert main(["replay", str(tmp_path / "r.rrd"), "--export", str(tmp_path / "out")]) == 0
    capsys.readouterr()
    via_y = setup.task_config["point"][1][1]
    rollouts = pq.read_table(tmp_path / "out" / "rollouts.parquet",
                             filters=[("task_config.point.1.1", ">", via_y - 1e-9)])
    assert rollouts.num_rows == 4 and set(rollouts.column("job").to_pylist()) == {JOB}
    assert rollouts.column("task_config.t_v.1").to_pylist() == [0.25] * 4
    reach = pq.read_table(tmp_path / "out" / "rollouts.parquet", filters=[("task_params.1", "==", 0.45)])
    assert reach.num_rows == 2 and reach.column("task_params.0").to_pylist() == [0.6, 0.6]
    jobs = pq.read_table(tmp_path / "out" / "jobs.parquet")
    assert jobs.column("task_config.tolerance.1").to_pylist() == [setup.task_config["tolerance"][1]]


def test_replay_says_which_success_it_counts_and_how_to_open_it_in_a_browser(tmp_path, setup, capsys):
    paths = _paths(setup)
    batch = _record(tmp_path / "r.rrd", setup, paths)
    assert main(["replay", str(tmp_path / "r.rrd")]) == 0
    out = capsys.readouterr().out
    assert f"{int(batch.success.sum())} of them succeeded (share of roll-outs that succeeded " in out
    assert "whether a job succeeded, the `success` of an experiment's JSON, is its result" in out
    # and how to look at it in a browser (the web viewer on loopback, not every interface)
    assert f"or in a browser:        rerun --serve-web --bind 127.0.0.1 {tmp_path / 'r.rrd'}" in out
    assert main(["replay", str(tmp_path / "r.rrd"), "--json"]) == 0
    job = json.loads(capsys.readouterr().out)["jobs"][JOB]
    assert job["rollouts_succeeded"] == int(batch.success.sum()) and "success_rate" not in job


def test_demonstrations_from_a_recording(tmp_path, setup, capsys):
    paths = _paths(setup)
    batch = _record(tmp_path / "r.rrd", setup, paths)
    out = tmp_path / "d.npz"
    assert main(["demos", "from-recording", str(tmp_path / "r.rrd"), "--best-per-job", "-o", str(out)]) == 0
    assert "1 demonstrations" in capsys.readouterr().out
    best = int(np.argmax(batch.rewards.sum(axis=1)))
    np.testing.assert_array_equal(load_demos(out).values[0], paths[best])
    # none succeeded (noisy copies of demonstrations miss the extrapolated via-point): one line, exit 2
    assert not batch.success.any()
    assert main(["demos", "from-recording", str(tmp_path / "r.rrd"), "--successful", "-o", str(out)]) == 2
    assert "none succeeded" in capsys.readouterr().err


def test_reexecution_gives_the_recorded_returns_and_catches_a_changed_one(tmp_path, setup, capsys):
    paths = _paths(setup)
    _record(tmp_path / "r.rrd", setup, paths)
    results, skipped = reexecute(read_recording(tmp_path / "r.rrd"))
    assert len(results) == 4 and all(r.equal for r in results) and skipped == {}
    _record(tmp_path / "t.rrd", setup, paths, tamper=2)
    assert main(["replay", str(tmp_path / "t.rrd"), "--execute"]) == 1
    out = capsys.readouterr().out
    assert f"job {JOB}: 4 roll-outs again, 3 equal" in out and "differs: job" in out
    _record(tmp_path / "n.rrd", setup, paths, job_event_too=False)
    results, skipped = reexecute(read_recording(tmp_path / "n.rrd"))
    assert results == [] and "no job event" in skipped[JOB]


def test_wrong_uses_are_one_line(tmp_path, capsys):
    assert main(["replay", str(tmp_path / "none.rrd"), "--export", str(tmp_path / "o")]) == 1
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert main(["replay", str(tmp_path / "none.rrd"), "--job", "x"]) == 2
    assert "--job: only with --execute, --export-lerobot, --export-minari or --export-rosbag2" in capsys.readouterr().err
    assert main(["replay", str(tmp_path / "none.rrd"), "--limit", "2"]) == 2
    assert "--namespace, --limit: only with --execute" in capsys.readouterr().err
    for bad in ({"method": 3}, {"seed": -1}, {"config": {"nested": 1}}):
        ev = job_event(JOB, method="acnmp", robot="point2d", task="viapoint")
        with pytest.raises(WireError):
            validate_event({**ev, **bad})
