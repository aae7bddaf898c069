"""Any Gymnasium environment as a robot: a whole trajectory executed as one seeded episode.

As in fancy_gym's black-box wrapper, the action of the episode is a trajectory of joint targets
(T, D), one per environment step, tracked by a PD controller (or sent as position commands)
whose commands become the environment's Box actions. The episode's per-step rewards are the
environment's (or those a user function computes from the whole episode), its success comes from
``info`` or a predicate, and its task parameters reach the environment through
``reset(options={"task_params": ...})`` or a setter the user names.

Timing: an episode takes one step per trajectory row, at most T. Step k sends the action made
from row k and the joint positions observed before the step, so row k is where the joints should
be after step k (``states["joint_angles"][k]``), ``(k + 1) * dt`` s after ``reset``; a
trajectory that starts at the reset posture makes its first step a hold. The episode ends when
the environment terminates or truncates it, or after the T-th step, whichever comes first
(:attr:`Episode.truncated_by_trajectory`: the trajectory ran out first, and an environment that
reports only at its episode's end has not reported; the user functions' errors say so).

PD gains. For joint-velocity actions (``q <- q + dt * action``) the PD command with ``kd = 0``
gives ``q <- q + kp * dt * (target - q)``: ``kp = 1 / dt`` lands each step exactly on its row
(while ``(target - q) / dt`` stays inside the action bounds, else the clipped command catches up
over the next steps); a smaller kp leaves ``1 - kp * dt`` of the error at every step and trails a
moving trajectory by ``1 / kp - dt`` s; ``kp > 2 / dt`` overshoots without settling. For torque
actions the gains are the usual tuning (Pusher's: :mod:`acnmp_core.tasks.pusher.scene`); for
position actions use ``control="position"``.

What an environment needs (:class:`GymRobotConfig`):

- a ``Box`` action space of D dimensions, D the trajectory's columns;
- its joint positions (D,) readable from the observation (``joint_positions``, default: the
  first D entries, as in Gymnasium's MuJoCo arms), and ideally their velocities
  (``joint_velocities``; default: finite differences over the environment's ``dt``).

For an environment whose observation does not hold its joint positions, write a
``gymnasium.ObservationWrapper`` that appends them (from the simulator's state) and give a factory
that returns the wrapped environment. Everything reads the observation, so batches can run in
sub-processes through Gymnasium's vector API (``vector_envs``).

:func:`gym_robot` turns a config into a :class:`~acnmp_core.robots.spec.RobotSpec`: a robot kind
with one task of its own, served by ``acnmp serve worker --robot ...`` like any other, its
roll-outs drawn as the end effector's path (:class:`~acnmp_core.robots.spec.EndEffectorPathDrawing`).
"""
from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..errors import InputError
from ..rollout import ClosedAtExit, RolloutBatch
from .spec import DrawnTarget, EndEffectorPathDrawing, Joint, RobotBody, RobotSpec, TaskFactory

ObsReader = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Episode:
    """One executed episode, as user functions (``success``, ``error``, ``reward``) see it.

    An episode takes at most T steps, one per trajectory row: it ends when the environment
    terminates or truncates it, or after its T-th step, whichever comes first.

    states : executed states over the T steps: ``joint_angles`` (T, D) rad (or the env's units),
        ``joint_targets`` (T, D), ``actions`` (T, D), and ``ee_xyz`` / ``object_xyz`` (T, 3) m when
        their readers are configured; row k is the state after step k.
    rewards : (T,) the environment's per-step rewards (0 after the episode ended).
    final_obs : the last observation; final_info : the last ``info`` map.
    task_params : (P,) the task parameters of the batch.
    steps : the number of environment steps taken (< T when the episode ended early).
    truncated_by_trajectory : True when the trajectory ran out first: the environment neither
        terminated nor truncated in the T steps, so ``final_info`` is that of a step in the middle
        of the environment's own episode (entries an environment gives only at its episode's end
        are missing).
    env_max_steps : the length of the environment's own episodes (its ``TimeLimit``), None when
        unknown.
    """

    states: Mapping[str, np.ndarray]
    rewards: np.ndarray
    final_obs: np.ndarray
    final_info: Mapping[str, Any]
    task_params: np.ndarray
    steps: int
    truncated_by_trajectory: bool = False
    env_max_steps: int | None = None


@dataclass(frozen=True)
class GymRobotConfig:
    """How to run a Gymnasium environment as a robot.

    env : a registered environment id (``"Pusher-v5"``) or a function returning a new environment.
    env_kwargs : keyword arguments of ``gymnasium.make`` (only with an id).
    joint_positions : obs -> (D,) joint positions; default ``obs[:D]``.
    joint_velocities : obs -> (D,) joint velocities; default: finite differences over ``dt``.
    control : "pd" (action = kp (target - q) - kd qdot, clipped to the action space) or
        "position" (action = target, clipped); or one of them per output (D,), e.g.
        ``("pd", "pd", "pd", "position")`` for a hand tracked by PD whose gripper command is sent
        as it is.
    kp, kd : PD gains, a number or (D,); for joint-velocity actions kp = 1 / dt and kd = 0 (the
        module docstring derives it).
    set_task : ``(env, task_params (P,)) -> obs`` placing the task after ``reset`` and returning
        the new observation; ``env`` is the environment as made (what ``gymnasium.make`` or your
        factory returns, with its wrappers, the same in a vector env's sub-processes): reach the
        simulator through ``env.unwrapped`` and return the observation as ``env`` would (through
        its wrappers). None: the parameters go as ``reset(options={"task_params": ...})``.
    success : the name of a boolean ``info`` entry of the last step (an error when the last step's
        info lacks it), or ``Episode -> bool``.
    error : ``Episode -> float``, the remaining error in the task's units (what a tolerance bounds).
    reward : ``Episode -> (T,) or float``, rewards computed from the whole episode instead of the
        environment's (a float is given to the last step).
    What these functions raise becomes one :class:`~acnmp_core.errors.InputError` line saying how
    the episode ended.
    end_effector, object_position : obs -> (3,) m, for the recording's drawing and the states.
    goal_params : indices of the goal's x, y[, z] in the task parameters (drawn as the target "goal").
    targets : more points of the task drawn with each roll-out (:class:`~acnmp_core.robots.spec.DrawnTarget`:
        a name and the indices of its x, y[, z] in the task parameters), e.g. a via-point.
    joints : the D joints (names, limits), for ``acnmp robots`` and the docs; default: read from a
        MuJoCo environment's model, else ``joint0..`` without limits.
    seed : the seed of every episode's ``reset`` (every roll-out starts from the same state).
    vector_envs : batches run in this many sub-processes (``gymnasium.vector.AsyncVectorEnv``);
        0 runs them one after the other in this process.
    """

    env: str | Callable[[], Any]
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    joint_positions: ObsReader | None = None
    joint_velocities: ObsReader | None = None
    control: str | tuple[str, ...] = "pd"
    kp: float | Sequence[float] = 1.0
    kd: float | Sequence[float] = 0.0
    set_task: Callable[[Any, np.ndarray], np.ndarray] | None = None
    success: str | Callable[[Episode], bool] | None = None
    error: Callable[[Episode], float] | None = None
    reward: Callable[[Episode], Any] | None = None
    end_effector: ObsReader | None = None
    object_position: ObsReader | None = None
    goal_params: tuple[int, ...] = ()
    targets: tuple[DrawnTarget, ...] = ()
    joints: tuple[Joint, ...] | None = None
    seed: int = 0
    vector_envs: int = 0

    def __post_init__(self) -> None:
        if not (isinstance(self.env, str) or callable(self.env)):
            raise InputError(f"env: expected an environment id or a function returning an environment, "
                             f"got {type(self.env).__name__}")
        controls = (self.control,) if isinstance(self.control, str) else tuple(self.control)
        if not controls or any(c not in ("pd", "position") for c in controls):
            raise InputError(f"control: expected 'pd' or 'position', or one of them per output, got {self.control!r}")
        if not isinstance(self.vector_envs, int) or self.vector_envs < 0:
            raise InputError(f"vector_envs: expected an integer >= 0, got {self.vector_envs!r}")
        if self.success is not None and not (isinstance(self.success, str) or callable(self.success)):
            raise InputError("success: expected an info key or a function Episode -> bool")

    def make_env(self):
        """A new environment, wrapped so that ``reset(options={"task_params": p})`` places the task."""
        import gymnasium as gym

        env = gym.make(self.env, **dict(self.env_kwargs)) if isinstance(self.env, str) else self.env()
        if not isinstance(env.action_space, gym.spaces.Box):
            raise InputError(f"env: the action space must be a Box, got {type(env.action_space).__name__}")
        return _task_reset_wrapper()(env, self.set_task) if self.set_task is not None else env


@functools.lru_cache(maxsize=1)
def _task_reset_wrapper():
    """The wrapper class, built once on first use (gymnasium is imported only then)."""
    import gymnasium as gym

    class TaskReset(gym.Wrapper):
        """Calls the user's task setter after each reset that carries ``task_params``."""

        def __init__(self, env, set_task):
            super().__init__(env)
            self._set_task = set_task

        def reset(self, *, seed=None, options=None):
            options = dict(options or {})
            params = options.pop("task_params", None)
            obs, info = self.env.reset(seed=seed, options=options or None)
            if params is not None:
                obs = np.asarray(self._set_task(self.env, np.asarray(params, dtype=np.float64)))
            return obs, info

    return TaskReset


class GymRolloutEvaluator(ClosedAtExit):
    """Executes trajectories (B, T, D) as episodes of a Gymnasium environment (a
    :class:`~acnmp_core.rollout.RolloutEvaluator`); see :class:`GymRobotConfig`."""

    def __init__(self, config: GymRobotConfig, credit: str = "step"):
        self.config = config
        #: how the rewards depend on the actions, for :func:`~acnmp_core.adaptation.loop.adapt`
        self.credit = credit
        self._env = None
        self._vector = None

    # -- environments ------------------------------------------------------------------------
    def _single(self):
        if self._env is None:
            self._env = self.config.make_env()
        return self._env

    def _vector_env(self):
        if self._vector is None:
            import gymnasium as gym

            self._vector = gym.vector.AsyncVectorEnv([self.config.make_env] * self.config.vector_envs)
        return self._vector

    def close(self) -> None:
        """Close the environments (the evaluator can be used again: they are made anew)."""
        for env in (self._env, self._vector):
            if env is not None:
                env.close()
        self._env = self._vector = None

    @property
    def dt(self) -> float:
        """Seconds per environment step (``env.unwrapped.dt`` or 1)."""
        return float(getattr(self._single().unwrapped, "dt", 1.0))

    @property
    def env_max_steps(self) -> int | None:
        """The length of the environment's own episodes (its ``spec.max_episode_steps``, or the
        limit of a ``TimeLimit`` wrapper), None when the environment does not say."""
        env = self._single()
        steps = getattr(getattr(env, "spec", None), "max_episode_steps", None)
        while not steps and env is not None:  # a TimeLimit around an environment without a spec
            steps = getattr(env, "_max_episode_steps", None)
            env = getattr(env, "env", None)
        return int(steps) if steps else None

    # -- execution ---------------------------------------------------------------------------
    def evaluate(self, trajectories: np.ndarray, times: np.ndarray, task_params: np.ndarray | None = None) -> RolloutBatch:
        """Execute each trajectory (B, T, D) of joint targets, one per environment step, as one episode
        reset with ``seed`` and ``task_params`` (P,); returns the :class:`RolloutBatch` (rewards (B, T),
        success (B,), errors (B,) with an ``error`` function, states of :class:`Episode`)."""
        trajs = np.asarray(trajectories, dtype=np.float64)
        if trajs.ndim != 3:
            raise InputError(f"trajectories: expected (B, T, D), got shape {trajs.shape}")
        params = np.zeros(0) if task_params is None else np.asarray(task_params, dtype=np.float64).reshape(-1)
        n = self.config.vector_envs
        chunks = [trajs[i:i + max(n, 1)] for i in range(0, len(trajs), max(n, 1))]
        episodes = [ep for chunk in chunks for ep in self._run(chunk, params)]
        return self._batch(episodes)

    def _run(self, trajs: np.ndarray, params: np.ndarray) -> list[Episode]:
        """Episodes of the trajectories (n, T, D), run side by side (vector env) or one at a time."""
        if self.config.vector_envs == 0:
            return [self._episodes(self._single(), traj[None], params, vector=False)[0] for traj in trajs]
        env = self._vector_env()
        padded = np.concatenate([trajs, np.repeat(trajs[-1:], self.config.vector_envs - len(trajs), axis=0)])
        return self._episodes(env, padded, params, vector=True)[:len(trajs)]

    def _episodes(self, env, trajs: np.ndarray, params: np.ndarray, *, vector: bool) -> list[Episode]:
        cfg = self.config
        n, steps, dims = trajs.shape
        box = env.single_action_space if vector else env.action_space
        if box.shape != (dims,):
            raise InputError(f"trajectories: the environment's actions are {box.shape}, the trajectories have D={dims}")
        low, high = np.asarray(box.low, dtype=np.float64), np.asarray(box.high, dtype=np.float64)
        options = {"task_params": params} if params.size else None
        # a vector env would seed its sub-environments seed, seed + 1, ...: every roll-out gets the same
        obs, info = env.reset(seed=[cfg.seed] * n if vector else cfg.seed, options=options)
        obs = np.asarray(obs, dtype=np.float64).reshape(n, -1)
        read_q = cfg.joint_positions or (lambda o: o[:dims])
        read_qd = cfg.joint_velocities
        extra = {name: reader for name, reader in (("ee_xyz", cfg.end_effector), ("object_xyz", cfg.object_position))
                 if reader is not None}
        kp, kd, dt = np.asarray(cfg.kp, dtype=np.float64), np.asarray(cfg.kd, dtype=np.float64), self.dt
        q = np.array([read_q(o) for o in obs], dtype=np.float64)
        q_prev = q
        logs: dict[str, list[np.ndarray]] = {name: [] for name in ("joint_angles", "joint_targets", "actions", *extra)}
        rewards = np.zeros((n, steps))
        taken = np.full(n, steps, dtype=np.int64)  # steps each episode ran (it may end early)
        ended = np.zeros(n, dtype=bool)  # the environment terminated or truncated it
        finals: list[Any] = [None] * n
        final_obs = obs.copy()
        position = _position_outputs(cfg.control, dims)
        for t in range(steps):
            target = trajs[:, t]
            if position.all():
                action = target
            else:
                qd = (np.array([read_qd(o) for o in obs], dtype=np.float64) if read_qd is not None
                      else (q - q_prev) / dt)
                action = np.where(position, target, kp * (target - q) - kd * qd)
            action = np.clip(action, low, high)
            obs_t, reward, term, trunc, info = env.step(action.astype(box.dtype) if vector else action[0].astype(box.dtype))
            obs_t = np.asarray(obs_t, dtype=np.float64).reshape(n, -1)
            live = taken > t  # those still running before this step
            rewards[live, t] = np.asarray(reward, dtype=np.float64).reshape(n)[live]
            q_prev, q = q, np.array([read_q(o) for o in obs_t], dtype=np.float64)
            logs["joint_angles"].append(q)
            logs["joint_targets"].append(target)
            logs["actions"].append(action)
            for name, reader in extra.items():
                logs[name].append(np.array([reader(o) for o in obs_t], dtype=np.float64))
            for i in np.flatnonzero(live):
                final_obs[i] = obs_t[i]
                finals[i] = _info_of(info, i) if vector else info
            now = live & (np.asarray(term) | np.asarray(trunc)).reshape(n)
            taken[now] = t + 1
            ended |= now
            obs = obs_t
            if not (taken > t + 1).any():
                break
        states = {}
        for name, rows in logs.items():
            values = np.stack(rows, axis=1)  # (n, steps run, width)
            # an episode that ended early holds its last state (and targets) to the end
            index = np.minimum(np.arange(steps)[None, :], taken[:, None] - 1)
            states[name] = np.take_along_axis(values, np.minimum(index, values.shape[1] - 1)[..., None], axis=1)
        max_steps = self.env_max_steps
        return [Episode({k: v[i] for k, v in states.items()}, rewards[i], final_obs[i], finals[i] or {}, params,
                        int(taken[i]), truncated_by_trajectory=not ended[i], env_max_steps=max_steps)
                for i in range(n)]

    def _batch(self, episodes: list[Episode]) -> RolloutBatch:
        cfg = self.config
        rewards = np.stack([self._rewards(ep) for ep in episodes])
        if cfg.success is None:
            success = np.zeros(len(episodes), dtype=bool)
        elif isinstance(cfg.success, str):
            success = np.array([bool(_info_entry(cfg.success, ep)) for ep in episodes])
        else:
            success = np.array([bool(_user_call("success", cfg.success, ep)) for ep in episodes])
        errors = None if cfg.error is None else np.array([float(_user_call("error", cfg.error, ep)) for ep in episodes])
        states = {k: np.stack([ep.states[k] for ep in episodes]) for k in episodes[0].states}
        return RolloutBatch(rewards=rewards, success=success, states=states, errors=errors)

    def _rewards(self, ep: Episode) -> np.ndarray:
        if self.config.reward is None:
            return ep.rewards
        value = np.asarray(_user_call("reward", self.config.reward, ep), dtype=np.float64)
        if value.ndim == 0:
            out = np.zeros_like(ep.rewards)
            out[max(ep.steps, 1) - 1] = float(value)
            return out
        if value.shape != ep.rewards.shape:
            raise InputError(f"reward: expected a float or shape {ep.rewards.shape}, got {value.shape}")
        return value


def _position_outputs(control: str | tuple[str, ...], dims: int) -> np.ndarray:
    """(D,) bool: the outputs sent as position commands (the others are PD-tracked); InputError
    when a per-output ``control`` does not name D outputs."""
    if isinstance(control, str):
        return np.full(dims, control == "position")
    if len(control) != dims:
        raise InputError(f"control: {len(control)} entries for trajectories of D={dims} outputs; give one per output")
    return np.array([c == "position" for c in control])


def _user_call(role: str, fn: Callable[[Episode], Any], ep: Episode) -> Any:
    """``fn(ep)``, the user's ``role`` function; what it raises becomes one :class:`InputError`
    line saying how the episode ended (the usual cause: a trajectory shorter than the
    environment's episodes, whose end-of-episode ``info`` the function expected)."""
    try:
        return fn(ep)
    except InputError:
        raise
    except Exception as exc:
        said = (str(exc).splitlines() or [""])[0]  # one line, whatever the function's message
        raise InputError(f"GymRobotConfig.{role}: your function raised {type(exc).__name__}: {said}; "
                         f"{_how_it_ended(ep)}") from exc


def _info_entry(key: str, ep: Episode) -> Any:
    """Entry ``key`` of the episode's last ``info``; InputError saying how the episode ended when
    the environment did not give it."""
    if key not in ep.final_info:
        raise InputError(f"GymRobotConfig.success: the last step's info has no {key!r} (its keys: {sorted(ep.final_info)}); "
                         f"{_how_it_ended(ep)}")
    return ep.final_info[key]


def _how_it_ended(ep: Episode) -> str:
    """How ``ep`` ended, and what to do when the trajectory ran out before the environment's episode."""
    rows = len(ep.rewards)
    if not ep.truncated_by_trajectory:
        return f"the environment ended the episode after {ep.steps} of the trajectory's {rows} steps"
    own = "" if ep.env_max_steps is None else f" (its episodes last {ep.env_max_steps} steps)"
    longer = "as long as its episodes" if ep.env_max_steps is None else f"of {ep.env_max_steps} rows"
    return (f"the episode ended with the trajectory: its {rows} rows ran {rows} steps and the environment "
            f"had not ended its episode{own}, so the last info is a mid-episode one; give trajectories "
            f"{longer} (demonstrations and query times of that many steps), or make the environment end "
            f"at {rows} steps (gymnasium.make(..., max_episode_steps={rows}))")


def _info_of(info: Mapping[str, Any], i: int) -> dict[str, Any]:
    """Environment ``i``'s entries of a vector environment's ``info`` (arrays with ``_key`` masks)."""
    out = {}
    for key, value in info.items():
        if key.startswith("_"):
            continue
        mask = info.get(f"_{key}")
        if mask is None or bool(np.asarray(mask)[i]):
            out[key] = np.asarray(value)[i] if isinstance(value, np.ndarray) else value
    return out


def env_joints(config: GymRobotConfig) -> tuple[Joint, ...]:
    """The D joints of the environment's actions: ``config.joints`` when given; for a MuJoCo
    environment the names and ranges of the joints its actuators drive; otherwise ``joint0..``
    without limits."""
    if config.joints is not None:
        return tuple(config.joints)
    env = config.make_env()
    try:
        dims = env.action_space.shape[0]
        model = getattr(env.unwrapped, "model", None)
        if model is not None and getattr(model, "nu", 0) == dims:
            ids = [int(model.actuator_trnid[a, 0]) for a in range(dims)]
            return tuple(Joint(model.joint(j).name, *(float(x) for x in
                               (model.jnt_range[j] if model.jnt_limited[j] else (-np.inf, np.inf)))) for j in ids)
        return tuple(Joint(f"joint{i}", -np.inf, np.inf) for i in range(dims))
    finally:
        env.close()


def gym_robot(kind: str, summary: str, config: GymRobotConfig | Callable[[], GymRobotConfig], *,
              task: str | None = None, credit: str = "step") -> RobotSpec:
    """A robot kind running a Gymnasium environment: its one task (``task``, default
    ``"<kind>_episode"``) executes trajectories with ``config`` (or what the function ``config``
    returns, built on first use so that importing a plugin stays cheap). The task's parameters
    (``task_config``) may set ``seed`` (int), the seed of every episode."""
    task = task or f"{kind.replace('-', '_')}_episode"
    resolve = _once(config)

    def build(params: dict) -> GymRolloutEvaluator:
        unknown = sorted(set(params) - {"seed"})
        if unknown:
            raise InputError(f"task_config: {task} takes only 'seed', got {unknown}")
        cfg = resolve()
        if "seed" in params:
            seed = params["seed"]
            if not isinstance(seed, int) or isinstance(seed, bool):
                raise InputError(f"task_config.seed: expected an integer, got {seed!r}")
            cfg = dataclasses.replace(cfg, seed=seed)
        return GymRolloutEvaluator(cfg, credit)

    def body() -> RobotBody:
        cfg = resolve()
        drawing = EndEffectorPathDrawing(tuple(cfg.goal_params), tuple(cfg.targets)) if cfg.end_effector else None
        return RobotBody(env_joints(cfg), drawing)

    return RobotSpec(kind, summary, tasks={task: {}}, body=body, new_tasks={task: TaskFactory(build, credit)})


def _once(config):
    if isinstance(config, GymRobotConfig):
        return lambda: config
    if not callable(config):
        raise InputError(f"config: expected a GymRobotConfig or a function returning one, got {type(config).__name__}")
    cache: list[GymRobotConfig] = []

    def resolve() -> GymRobotConfig:
        if not cache:
            made = config()
            if not isinstance(made, GymRobotConfig):
                raise InputError(f"config: the function returned {type(made).__name__}, not a GymRobotConfig")
            cache.append(made)
        return cache[0]

    return resolve
