"""Gymnasium environments as robots (issue 33): a trajectory (T, D) executed as one seeded episode
through a PD or position controller; rewards, success, task parameters, early ends, vector envs;
roll-outs recorded with the end effector's path. Uses examples/my_robot's ReachEnv (no MuJoCo) and
a few small environments of its own."""
from __future__ import annotations

import dataclasses
import sys

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium", reason="gymnasium is not installed (scripts/setup.sh installs it)")

from acnmp_core.errors import InputError  # noqa: E402
from acnmp_core.robots.gym_robot import GymRobotConfig, GymRolloutEvaluator, gym_robot  # noqa: E402
from acnmp_core.robots.spec import DrawnTarget, EndEffectorPathDrawing  # noqa: E402
from tests.paths import ROOT  # noqa: E402

sys.path.insert(0, str(ROOT / "examples" / "my_robot"))
from my_robot.env import ReachEnv, hand  # noqa: E402
from my_robot.make_demos import demos  # noqa: E402
from my_robot.plugin import CONFIG  # noqa: E402  (the example's configuration, as a user copies it)


def test_a_demonstration_tracked_by_pd_reaches_its_goal_and_the_episode_is_seeded():
    d = demos()
    ev = GymRolloutEvaluator(CONFIG)
    batch = ev.evaluate(d.values, d.times[0], d.task_params[0])  # every roll-out aims at goal 0
    assert batch.rewards.shape == (5, 50) and batch.states["joint_angles"].shape == (5, 50, 2)
    assert batch.success.tolist() == [True, False, False, False, False]
    assert batch.errors[0] < 0.03 and np.all(batch.rewards[:, :-1] == 0)
    np.testing.assert_allclose(batch.rewards[:, -1], -batch.errors)
    np.testing.assert_allclose(batch.states["ee_xyz"][0, -1, :2], hand(batch.states["joint_angles"][0, -1]))
    again = ev.evaluate(d.values, d.times[0], d.task_params[0])
    np.testing.assert_array_equal(again.rewards, batch.rewards)


def test_velocity_actions_with_kp_one_over_dt_reach_each_row_at_its_step():
    """The example's actions are joint velocities and its kp is 1/dt: step k lands on row k of the
    trajectory (``joint_angles[k]``, the state after step k), with no lag behind a moving target."""
    d = demos()
    ev = GymRolloutEvaluator(CONFIG)
    assert CONFIG.kp == pytest.approx(1.0 / ev.dt) and CONFIG.kd == 0.0
    batch = ev.evaluate(d.values, d.times[0], d.task_params[0])
    # exact up to the float32 the action space carries
    np.testing.assert_allclose(batch.states["joint_angles"], d.values, atol=1e-6)
    np.testing.assert_array_equal(batch.states["joint_targets"], d.values)
    # a smaller gain trails each moving row by 1/kp - dt seconds (here 1.5 steps at kp = 20)
    slow = GymRolloutEvaluator(dataclasses.replace(CONFIG, kp=20.0)).evaluate(d.values[4:], d.times[0], d.task_params[4])
    lag = np.abs(slow.states["joint_angles"][0] - d.values[4]).max()
    assert lag > 0.02


def test_position_control_sends_the_targets_and_a_setter_places_the_task():
    seen = []

    def set_goal(env, params):
        seen.append(params.copy())
        env.unwrapped.goal = params
        return env.unwrapped._obs()

    cfg = dataclasses.replace(CONFIG, control="position", set_task=set_goal)
    targets = np.full((1, 4, 2), 0.5)
    batch = GymRolloutEvaluator(cfg).evaluate(targets, np.arange(4), np.array([0.1, 0.2]))
    np.testing.assert_array_equal(batch.states["actions"][0], np.full((4, 2), 0.5))
    assert len(seen) == 1 and seen[0].tolist() == [0.1, 0.2]


def test_a_per_output_control_tracks_some_outputs_and_sends_the_others_as_they_are():
    """A hand PD-tracked and a gripper command passed through (the Meta-World kinds): the "position"
    output's action is its row, whatever the joint reading and the gain; the "pd" one is the PD
    command. The default (one control for all) is unchanged, and a tuple of the wrong length is one line."""
    d = demos()
    traj = d.values[:1].copy()
    cfg = dataclasses.replace(CONFIG, control=("pd", "position"))
    mixed = GymRolloutEvaluator(cfg).evaluate(traj, d.times[0], d.task_params[0])
    pd = GymRolloutEvaluator(CONFIG).evaluate(traj, d.times[0], d.task_params[0])
    box = ReachEnv().action_space
    np.testing.assert_allclose(mixed.states["actions"][0, :, 1], np.clip(traj[0, :, 1], box.low[1], box.high[1]), atol=1e-6)
    # the first step of both starts from the same state: the tracked output gets the same PD command
    np.testing.assert_allclose(mixed.states["actions"][0, 0, 0], pd.states["actions"][0, 0, 0])
    assert not np.allclose(mixed.states["actions"][0, :, 1], pd.states["actions"][0, :, 1])
    with pytest.raises(InputError, match="control: 3 entries for trajectories of D=2") as err:
        GymRolloutEvaluator(dataclasses.replace(CONFIG, control=("pd", "pd", "position"))).evaluate(
            traj, d.times[0], d.task_params[0])
    assert "\n" not in str(err.value)
    with pytest.raises(InputError, match="control: expected 'pd' or 'position'"):
        dataclasses.replace(CONFIG, control=("pd", "torque"))


class _Marked(gym.Wrapper):
    """The user's own wrapper: what ``set_task`` must receive (the environment as the factory made it)."""


def test_set_task_gets_the_environment_as_made_with_its_wrappers_also_in_sub_processes():
    kinds = []

    def set_goal(env, params):
        kinds.append(type(env).__name__)
        env.unwrapped.goal = params
        return env.unwrapped._obs()

    cfg = dataclasses.replace(CONFIG, env=lambda: _Marked(ReachEnv()), set_task=set_goal)
    d = demos()
    one = GymRolloutEvaluator(cfg).evaluate(d.values[[0, 4]], d.times[0], d.task_params[4])
    assert kinds == ["_Marked"] * 2 and one.errors[1] < 1e-3 < one.errors[0]  # demonstration 4's goal was placed
    with GymRolloutEvaluator(dataclasses.replace(cfg, vector_envs=2)) as ev:  # set_task runs in the sub-processes
        two = ev.evaluate(d.values[[0, 4]], d.times[0], d.task_params[4])
    np.testing.assert_allclose(two.errors, one.errors)


class _EndsEarly(gym.Env):
    """1 joint moving at the commanded velocity; terminates after 3 steps; reward 1 per step."""

    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    observation_space = gym.spaces.Box(-np.inf, np.inf, (1,), np.float64)
    dt = 0.1

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.q, self.t = np.zeros(1), 0
        return self.q.copy(), {}

    def step(self, action):
        self.q = self.q + np.asarray(action, dtype=np.float64) * self.dt
        self.t += 1
        return self.q.copy(), 1.0, self.t >= 3, False, {"t": self.t}


def test_an_episode_that_ends_early_holds_its_last_state_and_earns_nothing_more():
    cfg = GymRobotConfig(_EndsEarly, kp=5.0, success=lambda ep: ep.steps == 3,
                         reward=lambda ep: float(ep.states["joint_angles"][-1, 0]))
    batch = GymRolloutEvaluator(cfg).evaluate(np.ones((2, 6, 1)), np.arange(6))
    q = batch.states["joint_angles"][0, :, 0]
    assert np.all(q[3:] == q[2]) and q[2] > q[1] > q[0] > 0
    assert batch.success.all()
    # a trajectory-level reward (a float) goes to the last step taken
    assert np.count_nonzero(batch.rewards[0]) == 1 and batch.rewards[0, 2] == pytest.approx(q[2])


class _ReportsAtTheEnd(gym.Env):
    """1 joint at the commanded velocity; its episodes last 100 steps (a TimeLimit), and only the
    last step's info says how far the joint ended from 1 (``goal_error``), as many environments do."""

    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    observation_space = gym.spaces.Box(-np.inf, np.inf, (1,), np.float64)
    dt = 0.1

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.q = np.zeros(1)
        return self.q.copy(), {}

    def step(self, action):
        self.q = self.q + np.asarray(action, dtype=np.float64) * self.dt
        return self.q.copy(), 0.0, False, False, {}


class _GoalErrorAtTheEnd(gym.Wrapper):
    def step(self, action):
        obs, reward, term, trunc, info = self.env.step(action)
        if term or trunc:
            info = {**info, "goal_error": abs(float(obs[0]) - 1.0)}
        return obs, reward, term, trunc, info


def _reports_at_the_end():
    return _GoalErrorAtTheEnd(gym.wrappers.TimeLimit(_ReportsAtTheEnd(), 100))


#: That environment as a robot kind (tests/unit/experiments/test_own_robot.py runs it by reference).
SLIDER = gym_robot("slider", "a joint whose environment reports its goal error at the end only",
                   GymRobotConfig(_reports_at_the_end, kp=10.0, error=lambda ep: ep.final_info["goal_error"]),
                   task="slide")


def test_a_trajectory_shorter_than_the_episode_ends_it_and_the_user_function_error_says_so():
    seen = []

    def error(ep):
        seen.append(ep)
        return ep.final_info["goal_error"]

    cfg = GymRobotConfig(_reports_at_the_end, kp=10.0, error=error)
    with pytest.raises(InputError) as raised:
        GymRolloutEvaluator(cfg).evaluate(np.ones((1, 50, 1)), np.arange(50))
    message = str(raised.value)
    assert "\n" not in message and message.startswith("GymRobotConfig.error: your function raised KeyError: 'goal_error'")
    assert "its 50 rows ran 50 steps and the environment had not ended its episode (its episodes last 100 steps)" in message
    assert "give trajectories of 100 rows" in message and "max_episode_steps=50" in message
    (ep,) = seen  # the user's function saw the whole 50-step episode, marked as cut by the trajectory
    assert ep.steps == 50 and ep.truncated_by_trajectory and ep.env_max_steps == 100
    # an info key as success: the same account instead of a silent False
    with pytest.raises(InputError, match=r"GymRobotConfig.success: the last step's info has no 'goal_error' \(its keys: \[\]\); "
                                         r"the episode ended with the trajectory"):
        GymRolloutEvaluator(GymRobotConfig(_reports_at_the_end, success="goal_error")).evaluate(
            np.ones((1, 50, 1)), np.arange(50))
    # an environment that does not say how long its episodes are: the same, without the length
    unknown = GymRobotConfig(lambda: _GoalErrorAtTheEnd(_ReportsAtTheEnd()), error=error)
    with pytest.raises(InputError, match=r"the environment had not ended its episode, so the last info is a "
                                         r"mid-episode one; give trajectories as long as its episodes"):
        GymRolloutEvaluator(unknown).evaluate(np.ones((1, 50, 1)), np.arange(50))
    # a function's message of several lines still makes one line
    def multiline(ep):
        raise ValueError("first\nsecond")
    with pytest.raises(InputError, match=r"^GymRobotConfig.error: your function raised ValueError: first; [^\n]*$"):
        GymRolloutEvaluator(dataclasses.replace(cfg, error=multiline)).evaluate(np.ones((1, 100, 1)), np.arange(100))
    # a trajectory as long as the episode: the environment ends it, the function gets its entry
    full = GymRolloutEvaluator(cfg).evaluate(np.ones((1, 100, 1)), np.arange(100))
    assert not seen[-1].truncated_by_trajectory and seen[-1].steps == 100 and full.errors[0] < 0.01


def test_a_batch_through_the_vector_api_gives_the_same_roll_outs():
    d = demos()
    one = GymRolloutEvaluator(CONFIG).evaluate(d.values, d.times[0], d.task_params[2])
    with GymRolloutEvaluator(dataclasses.replace(CONFIG, vector_envs=2)) as ev:
        two = ev.evaluate(d.values, d.times[0], d.task_params[2])  # 5 roll-outs: chunks of 2, 2, 1
    np.testing.assert_allclose(two.rewards, one.rewards)
    np.testing.assert_allclose(two.states["joint_angles"], one.states["joint_angles"])
    assert two.success.tolist() == one.success.tolist()


def test_wrong_inputs_are_one_line_errors():
    ev = GymRolloutEvaluator(CONFIG)
    with pytest.raises(InputError, match=r"actions are \(2,\), the trajectories have D=3"):
        ev.evaluate(np.zeros((1, 5, 3)), np.arange(5), np.zeros(2))
    with pytest.raises(InputError, match="expected \\(B, T, D\\)"):
        ev.evaluate(np.zeros((5, 3)), np.arange(5))
    with pytest.raises(InputError, match="Box"):
        GymRobotConfig(lambda: gym.make("CartPole-v1")).make_env()
    with pytest.raises(InputError, match="control"):
        GymRobotConfig(ReachEnv, control="torque")
    spec = gym_robot("reacher2", "test", CONFIG, task="reach_t")
    factory = spec.new_tasks["reach_t"]
    with pytest.raises(InputError, match="takes only 'seed'"):
        factory.build({"goal": 1})
    assert factory.build({"seed": 3}).config.seed == 3


def test_a_gym_robot_is_recorded_with_its_end_effector_path_and_every_target_of_its_task(tmp_path, verify_rrd):
    """A task may name several targets (a via-point and a goal): each is drawn, labelled, where
    the roll-out's task parameters put it."""
    import rerun as rr

    from services.recording.events import batch_rollout_events, decode_event
    from services.recording.rrd_writer import RrdWriter
    from services.transport import encode

    cfg = dataclasses.replace(CONFIG, goal_params=(2, 3), targets=(DrawnTarget("via-point", (0, 1)),))
    spec = gym_robot("reacher3", "test", cfg, task="reach_r")
    d = demos()
    batch = GymRolloutEvaluator(CONFIG).evaluate(d.values[:2], d.times[0], d.task_params[0])
    params = np.array([0.3, 0.4, *d.task_params[0]])  # via-point (x, y), then the goal (x, y)
    events = batch_rollout_events("job-1", 0, d.values[:2], d.times[0], batch, task_params=params,
                                  drawing=spec.drawing)
    path = tmp_path / "gym.rrd"
    with RrdWriter(path) as w:
        for e in events:
            assert e["drawing"] == "ee_path" and e["target_names"] == "goal,via-point"
            w.log_event(decode_event(encode(e)))
    verify_rrd(path)
    reader = rr.chunk.RrdReader(path)
    drawn = {}
    for c in reader.stream(store=reader.recordings()[0]):
        if c.entity_path.startswith("/arm/job-1/targets/"):
            b = c.to_record_batch()
            drawn[c.entity_path] = (b.column("Points3D:labels").to_pylist()[0],
                                    b.column("Points3D:positions").to_pylist()[0][0])
    ground = 0.0  # the example draws its effector at z = 0, and a 2-D target at the path's first height
    assert drawn == {"/arm/job-1/targets/goal": (["goal"], pytest.approx([*d.task_params[0], ground])),
                     "/arm/job-1/targets/via-point": (["via-point"], pytest.approx([0.3, 0.4, ground]))}
    entities = {c.entity_path for c in reader.stream(store=reader.recordings()[0])}
    assert {"/arm/job-1/effector", "/arm/job-1/effector_path"} <= entities


def test_drawn_targets_are_checked_when_the_robot_is_described():
    with pytest.raises(InputError, match="targets.via: expected the indices of x, y"):
        DrawnTarget("via", (0,))
    with pytest.raises(InputError, match="a target's name is 1-40"):
        DrawnTarget("via,point", (0, 1))
    with pytest.raises(InputError, match="each target needs its own name"):
        EndEffectorPathDrawing((0, 1), (DrawnTarget("goal", (2, 3)),))
