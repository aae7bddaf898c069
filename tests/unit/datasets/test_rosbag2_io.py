"""ROS 2 bags in and out (issue 65): a bag written by rosbags itself (JointState at 100 Hz, a goal
topic, a JointTrajectory command per episode, 5 episodes) becomes demonstrations with the exact
values written, however its episodes are cut (`acnmp demos import --format rosbag2`); bad input
is one line, exit 2, nothing written; a recording's roll-outs become bags (`acnmp replay
--export-rosbag2`) that rosbags reads, and come back bit for bit."""
from __future__ import annotations

import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from acnmp_core.data.demo_io import load_demos
from tests.unit.datasets.conftest import SKILL_NAMES, SKILL_PARAM_NAMES

rosbags = pytest.importorskip("rosbags", reason="rosbags is not installed (the default set-up installs it)")
from rosbags.highlevel import AnyReader  # noqa: E402
from rosbags.rosbag2 import Reader, StoragePlugin, Writer  # noqa: E402
from rosbags.typesys import Stores, get_types_from_msg, get_typestore  # noqa: E402

JOINTS = ("shoulder", "elbow", "wrist")
HZ, PAUSE = 100, 1.0  # rate of the joint states (Hz), pause between episodes (s)
START = 1_700_000_000  # the first episode's start (s since the epoch)


def _episodes(n=5):
    """Per episode: times (T,) ns since the epoch, joint positions (T, 3), goal (3,) and a commanded
    trajectory (K points (K, 3) at time_from_start (K,) s)."""
    rng = np.random.default_rng(7)
    out, t0 = [], START * 10**9
    for k in range(n):
        steps = 40 + 7 * k
        s = np.linspace(0, 1, steps)
        q = np.stack([np.sin(s * (k + 1)), s**2 - 0.1 * k, rng.normal(size=steps)], axis=1)
        goal = np.array([0.3 + 0.1 * k, -0.2 * k, 0.5])
        offsets = np.array([0.0, 0.15, 0.3 + 0.01 * k])
        out.append((t0 + np.arange(steps) * (10**9 // HZ), q, goal, (rng.normal(size=(3, 3)), offsets)))
        t0 += steps * (10**9 // HZ) + int(PAUSE * 1e9)
    return out


def _every_other_episode(k: int, i: int) -> list[int]:
    """The joint states in another order every other episode, the commanded trajectories in the names' own."""
    return [2, 0, 1] if k % 2 and i >= 0 else [0, 1, 2]


def _write_bag(path: Path, episodes, *, nan_at=None, storage=StoragePlugin.MCAP, jitter=0.002,
               order=_every_other_episode):
    """A bag as a robot records one: /joint_states (header stamped at the sample, received up to
    ``jitter`` s later, the joints in the order ``order(episode, sample)`` gives: by default another
    every other episode), /goal (PoseStamped) at each episode's start, /arm/cmd (a JointTrajectory,
    its joints in the order ``order(episode, -1)``) once per episode."""
    ts = get_typestore(Stores.ROS2_JAZZY)
    T = ts.types
    time, header = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]

    def stamp(ns: int):
        ns = int(ns)
        return header(stamp=time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id="base")

    with Writer(path, version=9, storage_plugin=storage) as w:
        js = w.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=ts)
        goal = w.add_connection("/goal", "geometry_msgs/msg/PoseStamped", typestore=ts)
        cmd = w.add_connection("/arm/cmd", "trajectory_msgs/msg/JointTrajectory", typestore=ts)
        for k, (times, q, g, (points, offsets)) in enumerate(episodes):
            pose = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=g[0], y=g[1], z=g[2]),
                                               orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))
            w.write(goal, int(times[0]),
                    ts.serialize_cdr(T["geometry_msgs/msg/PoseStamped"](header=stamp(times[0]), pose=pose),
                                     "geometry_msgs/msg/PoseStamped"))
            sent = order(k, -1)
            traj = T["trajectory_msgs/msg/JointTrajectory"](header=stamp(times[0]), joint_names=[JOINTS[j] for j in sent],
                                                              points=[
                T["trajectory_msgs/msg/JointTrajectoryPoint"](
                    positions=p[sent], velocities=np.zeros(0), accelerations=np.zeros(0), effort=np.zeros(0),
                    time_from_start=T["builtin_interfaces/msg/Duration"](sec=0, nanosec=int(round(o * 1e9))))
                for p, o in zip(points, offsets)])
            w.write(cmd, int(times[0]) + 1000, ts.serialize_cdr(traj, "trajectory_msgs/msg/JointTrajectory"))
            for i, t in enumerate(times):
                position = q[i].copy()
                if nan_at == (k, i):
                    position[1] = np.nan
                sent = order(k, i)
                msg = T["sensor_msgs/msg/JointState"](header=stamp(t), name=[JOINTS[j] for j in sent],
                                                      position=position[sent], velocity=np.zeros(0),
                                                      effort=np.zeros(0))
                received = int(t) + int(round(jitter * 1e9)) * (i % 3)
                w.write(js, received, ts.serialize_cdr(msg, "sensor_msgs/msg/JointState"))
    return path


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """(the bag with 5 episodes, 5 bags of one episode each, the episodes written)."""
    root = tmp_path_factory.mktemp("bags")
    episodes = _episodes()
    one = _write_bag(root / "five", episodes)
    each = [_write_bag(root / f"episode_{k}", [ep]) for k, ep in enumerate(episodes)]
    return one, each, episodes


def _import(run_cli, bags, out, *args):
    code, stdout, err = run_cli("demos", "import", "--format", "rosbag2", *map(str, bags), "-o", str(out), *args)
    assert code == 0, err
    return load_demos(out)


@pytest.mark.parametrize("how", ["topic:/goal", "gap:0.5", "ranges", "a bag each"])
def test_a_bag_rosbags_wrote_is_imported_to_the_exact_values_written(written, tmp_path, run_cli, how):
    one, each, episodes = written
    if how == "ranges":  # seconds from the trajectory's first message
        starts = [(ep[0][0] - episodes[0][0][0]) * 1e-9 for ep in episodes]
        how = "ranges:" + ",".join(f"{a:.3f}-{a + len(ep[0]) / HZ - 0.005:.3f}" for a, ep in zip(starts, episodes))
    bags, split = ([one], ["--split", how]) if how != "a bag each" else (each, [])
    demos = _import(run_cli, bags, tmp_path / "d.npz", *split, "--trajectory", "/joint_states:position[shoulder,wrist]",
                    "--task-params", "/goal:pose.position@first")
    assert len(demos) == 5 and demos.lengths.tolist() == [len(ep[0]) for ep in episodes]
    for i, (times, q, goal, _) in enumerate(episodes):
        n = len(times)
        np.testing.assert_array_equal(demos.values[i, :n], q[:, [0, 2]])  # by name, whatever the order sent
        np.testing.assert_array_equal(demos.task_params[i], goal)
        np.testing.assert_allclose(demos.times[i, :n], np.linspace(0, 1, n), atol=1e-9)  # header stamps, to the ns
    assert demos.value_names.tolist() == ["shoulder", "wrist"]
    assert demos.task_param_names.tolist() == ["pose.position.x", "pose.position.y", "pose.position.z"]


def test_receive_times_joint_trajectory_points_and_given_task_params(written, tmp_path, run_cli):
    one, _, episodes = written
    stamped = _import(run_cli, [one], tmp_path / "h.npz", "--split", "topic:/goal", "--trajectory",
                      "/joint_states:position[elbow]", "--phase", "time")
    received = _import(run_cli, [one], tmp_path / "r.npz", "--split", "topic:/goal", "--trajectory",
                       "/joint_states:position[elbow]", "--phase", "time", "--time", "receive")
    n = len(episodes[0][0])
    np.testing.assert_allclose(stamped.times[0, :n], np.arange(n) / HZ, atol=1e-9)
    np.testing.assert_allclose(received.times[0, :n], np.arange(n) / HZ + 0.002 * (np.arange(n) % 3), atol=1e-9)
    # a JointTrajectory per episode: a row per point, at its time_from_start; parameters given per episode
    given = [f"{k},{-k}" for k in range(5)]
    cmd = _import(run_cli, [one], tmp_path / "c.npz", "--split", "topic:/goal", "--trajectory",
                  "/arm/cmd:points[*].positions[0:2]", "--phase", "time",
                  *[a for g in given for a in ("--given-task-params", g)], "--given-task-param-names", "a,b")
    for i, (_, _, _, (points, offsets)) in enumerate(episodes):
        np.testing.assert_array_equal(cmd.values[i], points[:, :2])
        np.testing.assert_allclose(cmd.times[i], offsets, atol=1e-9)
        assert cmd.task_params[i].tolist() == [i, -i]
    assert cmd.value_names.tolist() == ["shoulder", "elbow"] and cmd.task_param_names.tolist() == ["a", "b"]


def test_list_shows_topics_types_and_counts(written, run_cli):
    one, _, episodes = written
    code, out, err = run_cli("demos", "import", "--format", "rosbag2", str(one), "--list")
    assert code == 0, err
    rows = {line.split()[0]: line.split() for line in out.splitlines()[1:]}
    assert rows["/joint_states"][1:3] == ["sensor_msgs/msg/JointState", str(sum(len(ep[0]) for ep in episodes))]
    assert rows["/goal"][1:3] == ["geometry_msgs/msg/PoseStamped", "5"]
    assert "position[] (float64)" in out and "points[] (JointTrajectoryPoint: positions[], velocities[]," in out
    # what a reference needs (issue 72): the numbers inside a message and the joint names the messages give
    assert "pose (Pose: position.x, position.y, position.z, orientation.x, orientation.y, orientation.z, " \
           "orientation.w)" in out
    below = out.splitlines()[out.splitlines().index(next(line for line in out.splitlines() if "/joint_states" in line)) + 1]
    assert below.split() == ["name", "seen:", "shoulder,", "elbow,", "wrist", "(in", "2", "orders:", "placed", "by",
                             "name)"]
    assert "joint_names seen: shoulder, elbow, wrist\n" in out + "\n"


def test_a_task_parameter_constant_over_every_episode_is_warned_of(written, tmp_path, run_cli):
    """Issue 72: `/goal:pose.position@first` quietly made the goal's z (0.5 in every episode) a third task
    parameter; the import says so on stderr (and writes the file: the user may want it)."""
    one, _, _ = written
    code, out, err = run_cli("demos", "import", "--format", "rosbag2", str(one), "-o", str(tmp_path / "d.npz"),
                             "--split", "topic:/goal", "--trajectory", "/joint_states",
                             "--task-params", "/goal:pose.position@first")
    assert code == 0 and out.startswith("wrote ") and err.strip() == (
        "acnmp demos import: warning: task parameter 'pose.position.z' is 0.5 in every demonstration (a constant "
        "tells the skill nothing; select the others, e.g. FIELD[0:2]@first)")
    code, _, err = run_cli("demos", "import", "--format", "rosbag2", str(one), "-o", str(tmp_path / "e.npz"),
                           "--split", "topic:/goal", "--trajectory", "/joint_states",
                           "--task-params", "/goal:pose.position[0:2]@first")
    assert code == 0 and err == ""


def _shuffled(k: int, i: int) -> list[int]:
    """Another order of the joints in every message (as several drivers publish them), the first
    message of each topic the names' own."""
    return [0, 1, 2] if k == 0 and i in (0, -1) else np.random.default_rng([k, i + 1]).permutation(3).tolist()


def test_joints_in_another_order_in_every_message_are_placed_by_name(tmp_path, run_cli):
    """Issue 72, defect 1: with the default path the columns followed the first message's order,
    and a message listing its joints otherwise put other joints' values under their names (exit
    0, 15 % of the rows right). Every message's values go to their joints, whatever the order, in
    one bag and across bags; a JointTrajectory's likewise; a selection whose components change
    from one message to another is refused."""
    episodes = _episodes(3)
    one = _write_bag(tmp_path / "shuffled", episodes, order=_shuffled)
    each = [_write_bag(tmp_path / f"shuffled_{k}", [ep], order=lambda _, i, k=k: _shuffled(k, i))
            for k, ep in enumerate(episodes)]
    for bags, split in (([one], ["--split", "topic:/goal"]), (each, [])):
        for trajectory in ("/joint_states", "/joint_states:position", "/joint_states:position[0:3]"):
            demos = _import(run_cli, bags, tmp_path / "d.npz", *split, "--trajectory", trajectory)
            for i, (times, q, _, _) in enumerate(episodes):
                np.testing.assert_array_equal(demos.values[i, :len(times)], q)
            assert demos.value_names.tolist() == list(JOINTS)
        commanded = _import(run_cli, bags, tmp_path / "c.npz", *split, "--trajectory", "/arm/cmd", "--phase", "time")
        for i, (_, _, _, (points, offsets)) in enumerate(episodes):
            np.testing.assert_array_equal(commanded.values[i], points)
        assert commanded.value_names.tolist() == list(JOINTS)
    out = tmp_path / "refused.npz"
    code, _, err = run_cli("demos", "import", "--format", "rosbag2", str(one), "-o", str(out), "--split", "topic:/goal",
                           "--trajectory", "/joint_states:position[0:2]")
    assert code == 2 and len(err.strip().splitlines()) == 1 and not out.exists(), err
    assert f"{one}: feature '/joint_states:position[0:2]': topic '/joint_states': the message at " in err
    assert "where the first named shoulder, elbow (expected the same components in every message" in err


def _nan_bag(root: Path) -> Path:
    return _write_bag(root / "nan", _episodes(2), nan_at=(1, 4))


def _untyped_bag(root: Path) -> Path:
    """A SQLite bag of a custom message type without its definition (as ROS 2 Humble recorded them)."""
    ts = get_typestore(Stores.ROS2_JAZZY)
    ts.register(get_types_from_msg("float64 force\nfloat64[] taus", "lab_msgs/msg/Grip"))
    path = root / "grip"
    with Writer(path, version=8, storage_plugin=StoragePlugin.SQLITE3) as w:
        c = w.add_connection("/grip", "lab_msgs/msg/Grip", typestore=ts)
        w.write(c, 10**9, ts.serialize_cdr(ts.types["lab_msgs/msg/Grip"](force=1.0, taus=np.ones(2)), "lab_msgs/msg/Grip"))
    db = sqlite3.connect(next(path.glob("*.db3")))
    db.execute("delete from message_definitions")
    db.commit()
    db.close()
    return path


@pytest.mark.parametrize("bag, args, expected", [
    ("none", ["--trajectory", "/joint_states"], "not a ROS 2 bag (expected a directory with metadata.yaml"),
    ("one", ["--trajectory", "/joint_state"], "no topic '/joint_state' (the trajectory's; expected one of /arm/cmd, /goal"),
    ("one", ["--trajectory", "/joint_states:positions"],
     "sensor_msgs/msg/JointState has no field 'positions' (expected one of header, name, position, velocity, effort)"),
    ("one", ["--trajectory", "/joint_states:position[knee]"], "no component named 'knee' (expected one of"),
    ("one", ["--trajectory", "/goal"], "no default field (expected /goal:FIELD"),
    ("one", ["--trajectory", "/joint_states", "--split", "ranges:0-1,40-41"],
     "episode 1 (ranges:0-1,40-41, "),
    ("one", ["--trajectory", "/joint_states", "--split", "topic:/goal", "--task-params", "/goal:pose@last",
             "--given-task-params", "1,2"], "1 rows of given task parameters for 5 episodes"),
    ("one", ["--trajectory", "/joint_states", "--split", "every:2"], "not a split"),
    ("one", ["--trajectory", "/joint_states", "--task-params", "/goal:pose"], "expected /goal:pose@first"),
    ("one", ["--trajectory", "/joint_states", "--successful"], "does not mark episodes successful"),
    ("one", ["--trajectory", "/joint_states", "--align", "after"], "--align: for a feature with one row more"),
    ("untyped", ["--trajectory", "/grip:taus"], "message type lab_msgs/msg/Grip is unknown"),
    ("nan", ["--trajectory", "/joint_states", "--split", "topic:/goal"], "holds NaN or inf (expected finite numbers)"),
])
def test_bad_input_is_one_line_exit_2_and_nothing_written(written, tmp_path, run_cli, bag, args, expected):
    path = {"none": lambda: tmp_path, "one": lambda: written[0], "untyped": lambda: _untyped_bag(tmp_path),
            "nan": lambda: _nan_bag(tmp_path)}[bag]()
    out = tmp_path / "demos.npz"
    code, _, err = run_cli("demos", "import", "--format", "rosbag2", str(path), "-o", str(out), *args)
    assert code == 2 and expected in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists()


def test_recorded_rollouts_export_as_bags_rosbags_reads_and_come_back_bit_for_bit(tmp_path, recording, run_cli):
    path, rollouts = recording
    out = tmp_path / "bags"
    code, stdout, err = run_cli("replay", str(path), "--export-rosbag2", str(out))
    assert code == 0, err
    bags = sorted(out.iterdir())
    assert [b.name for b in bags] == [f"rollout_{i:04d}" for i in range(len(rollouts))]
    assert all(next(b.glob("*.mcap"), None) is not None for b in bags)  # MCAP storage
    for bag, r in zip(bags, rollouts):  # as the format's own library reads them
        with AnyReader([bag]) as reader:
            msgs = {}
            for conn, _, raw in reader.messages():
                msgs.setdefault(conn.topic, []).append(reader.deserialize(raw, conn.msgtype))
        (traj,) = msgs["/acnmp/trajectory"]
        assert traj.joint_names == list(SKILL_NAMES)
        np.testing.assert_array_equal(np.stack([p.positions for p in traj.points]), r["trajectory"])
        # a bag's times are whole nanoseconds: each within 0.5 ns of the recorded one, as docs/DATA.md says (issue 72)
        from_start = np.array([p.time_from_start.sec * 10**9 + p.time_from_start.nanosec for p in traj.points])
        assert np.abs(from_start - (r["times"] - r["times"][0]) * 1e9).max() <= 0.5
        assert [m.data for m in msgs["/acnmp/reward"]] == r["reward"].tolist()
        assert [m.data for m in msgs["/acnmp/success"]] == [r["success"]]
        (params,) = msgs["/acnmp/task_params"]
        np.testing.assert_array_equal(params.data, r["task_params"])
        assert params.layout.dim[0].label == ",".join(SKILL_PARAM_NAMES)
        meta = (bag / "metadata.yaml").read_text()
        assert f"acnmp.job: {r['job']}" in meta and "acnmp.skill: e1" in meta
    # and back: the successful ones, bit for bit, named as the skill's
    back = _import(run_cli, bags, tmp_path / "back.npz", "--trajectory", "/acnmp/trajectory", "--task-params",
                   "acnmp.task_params", "--successful")
    good = [r for r in rollouts if r["success"]]
    np.testing.assert_array_equal(back.values, np.stack([r["trajectory"] for r in good]))
    np.testing.assert_array_equal(back.task_params, np.stack([r["task_params"] for r in good]))
    assert np.abs(back.times - np.stack([r["times"] for r in good])).max() <= 0.5e-9  # the phase: the times over 1 s
    assert tuple(back.value_names) == SKILL_NAMES and tuple(back.task_param_names) == SKILL_PARAM_NAMES
    # an existing directory is refused, nothing written into it
    code, _, err = run_cli("replay", str(path), "--export-rosbag2", str(out))
    assert code == 2 and "already exists" in err and sorted(out.iterdir()) == bags


def test_an_export_at_the_robots_pace_plays_over_the_duration_given_and_imports_back(tmp_path, recording, run_cli):
    """Issue 72: `time_from_start` was the phase (1 s for a motion the robot runs in 2 s); --duration 2
    scales each roll-out's times to 2 s (its points, rewards and success at that pace, for `ros2 bag
    play`), and the import's phase gives the recorded phase back."""
    path, rollouts = recording
    out = tmp_path / "paced"
    code, _, err = run_cli("replay", str(path), "--export-rosbag2", str(out), "--duration", "2")
    assert code == 0, err
    bags = sorted(out.iterdir())
    for bag, r in zip(bags, rollouts):
        with AnyReader([bag]) as reader:
            stamps = {}
            for conn, stamp, raw in reader.messages():
                stamps.setdefault(conn.topic, []).append((stamp, reader.deserialize(raw, conn.msgtype)))
        (_, traj), = stamps["/acnmp/trajectory"]
        from_start = np.array([p.time_from_start.sec * 10**9 + p.time_from_start.nanosec for p in traj.points])
        phase = (r["times"] - r["times"][0]) / (r["times"][-1] - r["times"][0])
        assert from_start[-1] == 2 * 10**9 and np.abs(from_start - phase * 2e9).max() <= 0.5
        rewards = np.array([s for s, _ in stamps["/acnmp/reward"]])
        assert rewards[-1] - rewards[0] == 2 * 10**9 and stamps["/acnmp/success"][0][0] == rewards[-1]
        assert "acnmp.duration: '2.0'" in (bag / "metadata.yaml").read_text()
    back = _import(run_cli, bags, tmp_path / "back.npz", "--trajectory", "/acnmp/trajectory")
    assert np.abs(back.times - np.stack([r["times"] for r in rollouts])).max() <= 0.5e-9
    code, _, err = run_cli("replay", str(path), "--export-lerobot", str(tmp_path / "l"), "--duration", "2")
    assert code == 2 and "--duration: only with --export-rosbag2" in err


def test_the_plugin_examples_bag_becomes_its_demonstrations(tmp_path, run_cli, monkeypatch):
    """examples/my_robot/my_robot/make_bag.py records the example's five reaches as the arm would;
    imported, they are the example's demonstrations exactly (the path of docs/DATA.md's example)."""
    import sys

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[3] / "examples" / "my_robot"))
    from my_robot.make_bag import write_bag
    from my_robot.make_demos import demos

    for name in [m for m in sys.modules if m == "my_robot" or m.startswith("my_robot.")]:
        monkeypatch.delitem(sys.modules, name)  # forgotten after the test, as sys.path is
    bag = write_bag(tmp_path / "reach_bag")
    got = _import(run_cli, [bag], tmp_path / "reach.npz", "--split", "topic:/goal", "--trajectory",
                  "/joint_states:position[shoulder,elbow]", "--task-params", "/goal:point[0:2]@first")
    want = demos()
    np.testing.assert_array_equal(got.values, want.values)
    np.testing.assert_array_equal(got.task_params, want.task_params)
    np.testing.assert_allclose(got.times, want.times, atol=1e-12)
    assert got.value_names.tolist() == ["shoulder", "elbow"] and got.task_param_names.tolist() == ["point.x", "point.y"]


def _as_read(bag: Path):
    """What the format's own library reads of ``bag``'s /joint_states and /goal (rosbags' Reader,
    the messages deserialised with ROS 2 Jazzy's types, as the bag's metadata names them): (joint
    positions in the first message's joint order (T, 3), sorted by header stamp; the stamps (T,)
    ns; the first goal's position (3,)), or None when it cannot read them or reads fewer or more
    messages than its metadata.yaml counts."""
    store = get_typestore(Stores.ROS2_JAZZY)
    try:
        with Reader(bag) as reader:
            states, goals = [], []
            used = [c for c in reader.connections if c.topic in ("/joint_states", "/goal")]
            for conn, _, raw in reader.messages(used):
                msg = store.deserialize_cdr(raw, conn.msgtype)
                if conn.topic == "/joint_states":
                    states.append((msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec, list(msg.name),
                                   np.asarray(msg.position, dtype=np.float64)))
                else:
                    goals.append([msg.pose.position.x, msg.pose.position.y, msg.pose.position.z])
            if any(reader.topics[t].msgcount != n for t, n in (("/joint_states", len(states)), ("/goal", len(goals)))):
                return None
    except Exception:  # noqa: BLE001 - whatever the format's own library raises for a damaged bag
        return None
    first = states[0][1]
    if any(sorted(names) != sorted(first) or len(position) != len(first) for _, names, position in states):
        return None
    stamps = np.array([s for s, _, _ in states])
    order = np.argsort(stamps, kind="stable")
    rows = np.stack([position[[names.index(n) for n in first]] for _, names, position in states])
    return rows[order], stamps[order], np.array(goals[0])


def _damaged(bag: Path, storage: str) -> list[tuple[str, bytes]]:
    """(what was done, the storage file's new bytes): truncations at every sixteenth of the file
    and at 99.9 % (issue 72: a sqlite3 bag truncated so), 48 bytes flipped (each on its own, at
    places drawn with a fixed seed) and 4000 random bytes written over its middle (issue 72: an
    MCAP so damaged crashed with OverflowError)."""
    data = next(p for p in bag.iterdir() if p.suffix in (".mcap", ".db3")).read_bytes()
    rng = np.random.default_rng(72 + len(storage))
    cases = [(f"truncated to {n} of {len(data)} bytes", data[:n])
             for n in sorted({len(data) * k // 16 for k in range(16)} | {int(len(data) * 0.999)})]
    for at in sorted(rng.choice(len(data), size=48, replace=False).tolist()):
        flipped = bytearray(data)
        flipped[at] ^= int(rng.integers(1, 256))
        cases.append((f"byte {at} flipped", bytes(flipped)))
    middle = len(data) // 2 - 2000
    noise = rng.integers(0, 256, size=4000, dtype=np.uint8).tobytes()
    return cases + [(f"4000 random bytes at {middle}", data[:middle] + noise + data[middle + 4000:])]


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_a_damaged_bag_imports_what_it_holds_or_is_refused_in_one_line(tmp_path, run_cli, storage):
    """Issue 72, defect 2: a damaged bag crashed the import (exit 1, OverflowError or CorruptError,
    the bag not named). Every truncation and byte flip of an MCAP and a sqlite3 bag either imports
    exactly what the format's own library reads from those bytes (exit 0), or is refused (exit 2)
    in one line naming the bag, with nothing written; never a traceback, never a partial file.
    "What the library reads": neither storage checksums a message as rosbags writes it (MCAP
    chunks without a CRC, sqlite3 none), so a flipped byte inside a number is another number to any
    reader (docs/DATA.md says so); a flip in a copy of a standard type's definition the bag holds
    changes nothing read (the types are ROS 2 Jazzy's where the bag's digest says they are)."""
    episode = _episodes(1)
    written = _write_bag(tmp_path / "written", episode, storage=getattr(StoragePlugin, storage.upper()),
                         order=_shuffled)
    storage_file = next(p for p in written.iterdir() if p.suffix in (".mcap", ".db3")).name
    args = ["--trajectory", "/joint_states", "--task-params", "/goal:pose.position@first", "--time", "header",
            "--phase", "time"]
    wrong, refused = [], 0
    for k, (what, data) in enumerate([("as written", None), *_damaged(written, storage)]):
        bag, out = tmp_path / f"bag_{k}", tmp_path / f"demos_{k}.npz"
        shutil.copytree(written, bag)
        if data is not None:
            (bag / storage_file).write_bytes(data)
        code, _, err = run_cli("demos", "import", "--format", "rosbag2", str(bag), "-o", str(out), *args)
        held = _as_read(bag)
        if code == 2 and data is not None:
            refused += 1
            if len(err.strip().splitlines()) != 1 or f"acnmp: error: {bag}" not in err or out.exists():
                wrong.append(f"{what}: refused, but {err.strip()!r}, written: {out.exists()}")
            continue
        if code != 0 or held is None:
            wrong.append(f"{what}: exit {code} ({err.strip()[:200]}), the format's reader "
                         + ("reads it" if held is not None else "cannot read it whole"))
            continue
        demos, (rows, stamps, goal) = load_demos(out), held
        n = int(demos.lengths[0]) if demos.lengths is not None else demos.values.shape[1]
        if not (np.array_equal(demos.values[0, :n], rows) and np.array_equal(demos.task_params[0], goal)
                and np.allclose(demos.times[0, :n], (stamps - stamps[0]) * 1e-9, rtol=0, atol=1e-12)):
            wrong.append(f"{what}: exit 0 with other values than the bag holds")
    assert not wrong, wrong
    assert refused > 0  # damage the format can tell was found
