"""Meta-World's Sawyer tasks as ACNMP tasks: the scene, the task parameters, the regions.

Five tasks of two kinds: moving an object to a goal (``reach-v3``, ``push-v3``, ``pick-place-v3``) and
working an articulated object where it stands (``window-open-v3``: slide a window open;
``button-press-v3``: press a button in).

Meta-World (Yu et al., CoRL 2019; ``metaworld`` 3.1.1, its v3 environments) drives a Sawyer arm
by end-effector deltas: an action is (dx, dy, dz) in [-1, 1] scaled by ``action_scale`` (0.01 m)
and a gripper command g in [-1, 1] (-1 open, 1 closed). A trajectory here is what the hand should
do at each of :data:`N_STEPS` environment steps (12.5 ms each): (T, 4), the hand's target position
(x, y, z) m after step k in row k and the gripper command g; the Gymnasium adapter tracks it with
``action = (target - hand) / action_scale`` (clipped to [-1, 1]) for x, y, z and sends g as it is
(:data:`CONTROL`, :data:`KP`), fancy_gym's Meta-World controller.

Task parameters, world m: ``reach``: the goal (x, y, z); ``push``: the puck (x, y) and the goal
(x, y); ``pick-place``: the puck (x, y) and the goal (x, y, z); ``window-open``, ``button-press``:
where the window or the button stands (x, y) (the goal follows from it in Meta-World). They are set on the environment
after each ``reset`` (:func:`set_task`) through the environment's own random vector (``_last_rand_vec``,
frozen). The observation's goal is clipped to the task's goal range in Meta-World; the scene widens
that range (:data:`VISIBLE_GOALS`) so that a policy reading the observation sees the goal it is
given, also outside Meta-World's range.

Success is Meta-World's own: ``info["success"]`` at any step of the episode (Meta-World's
evaluation ends an episode at its first success). The error of an episode is the smallest
``info["obj_to_target"]`` it reached (m: the hand's distance to the goal for reach, the puck's
for push and pick-place); an episode succeeds once it falls below the task's radius (0.05 m,
0.05 m, 0.07 m).

Regions: the demonstrations come from :attr:`MetaWorldTask.training`, Meta-World's own ranges of
puck, goal and object positions. A test position is *interpolation* inside it and *extrapolation*
with the goal's (or the articulated object's) x moved 0.10-0.15 m beyond it (|x| in [0.20, 0.25] m,
the side drawn at random), the other parameters inside; every test position is one where Meta-World's scripted expert succeeds
(:func:`~.demos.expert_succeeds`), and puck and goal are at least :data:`MIN_SEPARATION` apart
(closer, Meta-World's ``reset`` draws again forever).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ...errors import InputError

#: environment steps per episode, and rows per trajectory
N_STEPS = 100
#: adapter control per output: x, y, z tracked (PD with KP), the gripper command sent as it is
CONTROL = ("pd", "pd", "pd", "position")
#: 1 / Meta-World's action_scale: an action of 1 moves the hand's mocap 0.01 m
KP = (100.0, 100.0, 100.0, 1.0)
#: Meta-World's reset loops until puck and goal are 0.15 m apart in x, y; test positions keep a margin
MIN_SEPARATION = 0.16
#: the goal range the observation shows (m), wide enough for every test position
VISIBLE_GOALS = ((-0.5, 0.4, 0.0), (0.5, 1.0, 0.5))
#: where the puck sits when the task has none (reach): Meta-World's default
DEFAULT_PUCK = (0.0, 0.6, 0.02)
#: how far beyond the training region the extrapolated goal's x lies (m)
EXTRAPOLATION_X = (0.20, 0.25)


@dataclass(frozen=True)
class MetaWorldTask:
    """One Meta-World task as an ACNMP task.

    env_name : Meta-World's name (``"push-v3"``). kind : the robot kind (``"metaworld-push"``).
    param_names : the task parameters' names. training : (low, high) of the training region, one
    entry per parameter (m). goal_x : the index of the goal's (or the object's) x in the
    parameters, the one extrapolated. radius : Meta-World's success radius (m). credit : how the
    rewards depend on the actions, for :func:`~acnmp_core.adaptation.loop.adapt` ("step": the
    hand's reward at step k is set by row k; "future": the object's depends on everything before).
    object_z : for an articulated object (window, button), its height (m): the parameters are its
    x, y and Meta-World's random vector is that position; None for the tasks with a puck and a goal.
    """

    env_name: str
    kind: str
    param_names: tuple[str, ...]
    training: tuple[tuple[float, ...], tuple[float, ...]]
    goal_x: int
    radius: float
    credit: str
    object_z: float | None = None

    @property
    def n_params(self) -> int:
        return len(self.param_names)

    def rand_vec(self, params: np.ndarray) -> np.ndarray:
        """Meta-World's random vector for ``params``: (6,) puck x, y, z and goal x, y, z, or (3,) the
        articulated object's x, y, z."""
        p = np.asarray(params, dtype=np.float64).reshape(-1)
        if p.shape != (self.n_params,) or not np.all(np.isfinite(p)):
            raise InputError(f"task_params: expected {self.n_params} finite values {list(self.param_names)}, "
                             f"got {np.asarray(params).tolist()}")
        if self.object_z is not None:
            return np.r_[p, self.object_z]
        if self.env_name == "reach-v3":
            return np.r_[DEFAULT_PUCK, p]
        if self.env_name == "push-v3":
            return np.r_[p[0], p[1], 0.02, p[2], p[3], 0.02]
        return np.r_[p[0], p[1], 0.02, p[2:5]]

    def check(self, params: np.ndarray) -> np.ndarray:
        """``params`` as a (P,) array; InputError (one line) when puck and goal are closer than
        :data:`MIN_SEPARATION` in x, y (Meta-World's reset would never return)."""
        vec = self.rand_vec(params)
        if self.object_z is not None:  # no puck: nothing for Meta-World's reset to separate
            return np.asarray(params, dtype=np.float64).reshape(-1)
        gap = float(np.hypot(*(vec[:2] - vec[3:5])))
        if gap < MIN_SEPARATION:
            raise InputError(f"task_params: the puck and the goal are {gap:.3f} m apart in x, y; Meta-World "
                             f"needs at least {MIN_SEPARATION} m ({dict(zip(self.param_names, vec.round(3)))})")
        return np.asarray(params, dtype=np.float64).reshape(-1)

    def valid(self, params: np.ndarray) -> bool:
        try:
            self.check(params)
        except InputError:
            return False
        return True

    def sample_training(self, rng: np.random.Generator) -> np.ndarray:
        """(P,) a position drawn uniformly from the training region (puck and goal apart)."""
        while True:
            p = rng.uniform(*self.training)
            if self.valid(p):
                return p

    def sample_extrapolation(self, rng: np.random.Generator) -> np.ndarray:
        """(P,) a position with the goal's x beyond the training region (see the module docstring)."""
        while True:
            p = rng.uniform(*self.training)
            p[self.goal_x] = rng.choice([-1.0, 1.0]) * rng.uniform(*EXTRAPOLATION_X)
            if self.valid(p):
                return p


TASKS: dict[str, MetaWorldTask] = {t.kind: t for t in (
    MetaWorldTask("reach-v3", "metaworld-reach", ("goal_x", "goal_y", "goal_z"),
                  ((-0.1, 0.8, 0.05), (0.1, 0.9, 0.3)), 0, 0.05, "step"),
    MetaWorldTask("push-v3", "metaworld-push", ("puck_x", "puck_y", "goal_x", "goal_y"),
                  ((-0.1, 0.6, -0.1, 0.8), (0.1, 0.7, 0.1, 0.9)), 2, 0.05, "future"),
    MetaWorldTask("pick-place-v3", "metaworld-pick-place", ("puck_x", "puck_y", "goal_x", "goal_y", "goal_z"),
                  ((-0.1, 0.6, -0.1, 0.8, 0.05), (0.1, 0.7, 0.1, 0.9, 0.3)), 2, 0.07, "future"),
    MetaWorldTask("window-open-v3", "metaworld-window-open", ("window_x", "window_y"),
                  ((-0.1, 0.7), (0.1, 0.9)), 0, 0.05, "future", object_z=0.16),
    MetaWorldTask("button-press-v3", "metaworld-button-press", ("button_x", "button_y"),
                  ((-0.1, 0.85), (0.1, 0.9)), 0, 0.02, "future", object_z=0.115),
)}


def task(kind: str) -> MetaWorldTask:
    """The task of robot kind ``kind``; InputError naming the kinds otherwise."""
    try:
        return TASKS[kind]
    except KeyError:
        raise InputError(f"Meta-World task: expected one of {sorted(TASKS)}, got {kind!r}") from None


@functools.lru_cache(maxsize=1)
def _wrappers():
    """The two wrappers, built on first use (gymnasium and metaworld are imported only then)."""
    import gymnasium as gym
    from gymnasium.spaces import Box

    class VisibleGoal(gym.Wrapper):
        """Widens the goal range Meta-World clips the observation's goal to (see the module docstring)."""

        def __init__(self, env):
            super().__init__(env)
            low, high = VISIBLE_GOALS
            env.unwrapped.goal_space = Box(np.array(low), np.array(high), dtype=np.float64)

    class SuccessEver(gym.Wrapper):
        """Adds ``info["success_ever"]`` (any step so far succeeded) and ``info["min_error"]`` (the
        smallest ``obj_to_target`` so far, m) to every step's info."""

        def reset(self, **kwargs):
            self._ever, self._min = False, float("inf")
            return self.env.reset(**kwargs)

        def step(self, action):
            obs, reward, terminated, truncated, info = self.env.step(action)
            self._ever = self._ever or bool(info.get("success", 0.0))
            self._min = min(self._min, float(info.get("obj_to_target", np.inf)))
            info = {**info, "success_ever": self._ever, "min_error": self._min}
            return obs, reward, terminated, truncated, info

    return VisibleGoal, SuccessEver


#: what a user without Meta-World is told
MISSING = "the Meta-World tasks need the metaworld extra: pip install 'acnmp[metaworld]'"


def require_metaworld() -> None:
    """InputError (one line saying which extra to install) when ``metaworld`` cannot be imported."""
    try:
        import gymnasium  # noqa: F401
        import metaworld  # noqa: F401  (registers Meta-World's environments with gymnasium)
    except ImportError as exc:
        raise InputError(f"{MISSING} ({exc})") from None


def make_env(kind: str, seed: int = 0):
    """A new environment of ``kind``: Meta-World's goal-observable ``<task>`` with the goal range
    widened and the success and error bookkeeping (``info["success_ever"]``, ``info["min_error"]``)."""
    spec = task(kind)
    require_metaworld()
    import gymnasium as gym

    visible, success = _wrappers()
    # the passive checker warns at every reset that the widened goal lies outside Meta-World's space
    env = gym.make("Meta-World/goal_observable", env_name=spec.env_name, seed=seed, disable_env_checker=True)
    return success(visible(env))


def set_task(kind: str):
    """The adapter's task setter of ``kind``: ``(env, params (P,)) -> obs`` resets ``env`` with the
    puck and goal at ``params``."""
    spec = task(kind)

    def setter(env, params: np.ndarray) -> np.ndarray:
        inner = env.unwrapped
        inner._last_rand_vec = spec.rand_vec(spec.check(params))
        inner._freeze_rand_vec = True
        obs, _ = env.reset()
        return np.asarray(obs, dtype=np.float64)

    return setter


def fixed_task_env(kind: str, params: np.ndarray):
    """``kind``'s environment (:func:`make_env`) reset at ``params`` (P,) every episode and cut at
    :data:`N_STEPS` steps: the step-based environment of the peers that learn a policy."""
    import gymnasium as gym

    setter = set_task(kind)

    class FixedTask(gym.Wrapper):
        def reset(self, *, seed=None, options=None):
            self.env.reset(seed=seed)
            return setter(self.env, params), {}

    return gym.wrappers.TimeLimit(FixedTask(make_env(kind)), N_STEPS)
