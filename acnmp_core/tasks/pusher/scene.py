"""Gymnasium's MuJoCo ``Pusher-v5`` as a task: the scene, the scripted expert, the regions.

The arm (7 joints, torque actions in [-2, 2], 100 steps of 0.05 s) carries a U-shaped hand: a
palm bar (local y) with two fingers pointing forward (local +x) at its ends. It pushes a
cylinder (radius 0.05 m) lying on the table. The object is nearly massless with damped slides, so it
follows only a slow push: at most about 0.05 m/s. Faster, the hand passes through it.

Task parameters (4,), world metres: ``(object_x, object_y, goal_x, goal_y)``, placed after each
``reset`` by :func:`set_pusher_task` (Pusher draws its own object position, which this replaces).

The expert (:func:`pusher_expert`) scripts the hand in Cartesian space and turns it into joint
targets by damped least-squares inverse kinematics on the env's own model, position and
orientation. The hand points along the push direction, palm bar level:

1. joints from the start posture (all 0) to a posture with the hand 0.125 m above the pre-push
   point (minimum jerk, 20 steps);
2. down to the pre-push point, 0.09 m behind the object on the line from the goal through the
   object (10 steps);
3. a push at constant speed to 0.05 m past the goal (65 steps), because the object lags the palm;
4. hold (5 steps).

The IK is warm-started from the previous step, so the targets change smoothly in time and with
the parameters. :data:`PUSHER_KP` and :data:`PUSHER_KD` are the PD gains that track them (see
:mod:`acnmp_core.robots.gym_robot`).

Regions (measured in ``benchmarks/studies/pusher_expert/README.md``): the arm's hand can point along a push
only in part of the table. The expert succeeds for objects at x in [0.28, 0.36] and y in
[-0.35, -0.05] m, with pushes of 0.09 m within 15 degrees of +x. Demonstrations come from
:data:`TRAINING_REGION`; the test positions come from :data:`EXTRAPOLATION_REGION`, 0.10 m to
0.15 m beyond it in y.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

#: the environment this scene is built on
ENV_ID = "Pusher-v5"
#: PD gains (per joint) from joint targets to Pusher's torques: action = KP (q* - q) - KD qdot
PUSHER_KP = np.array([50.0, 50.0, 30.0, 30.0, 20.0, 20.0, 20.0])
PUSHER_KD = np.array([3.0, 3.0, 1.5, 1.5, 0.9, 0.9, 0.9])
#: success: the object's final distance (m) to the goal is at most this
PUSHER_SUCCESS_M = 0.05
#: control steps per episode (Pusher's time limit)
N_STEPS = 100
#: the hand's height (m, world z of ``tips_arm``) while pushing (the object's centre) and above it
Z_PUSH, Z_ABOVE = -0.275, -0.15
#: where the IK starts: an arm bent over the table (rad)
Q_REST = np.array([0.0, 0.4, 0.0, -1.2, 0.0, -0.6, 0.0])
#: length (m) of every push, object to goal
PUSH_LENGTH = 0.09


@dataclass(frozen=True)
class Region:
    """Object positions x, y (m) and push directions (deg from +x) of a box of task parameters."""

    x: tuple[float, float]
    y: tuple[float, float]
    angle_deg: tuple[float, float]

    def params(self, x: float, y: float, angle_deg: float) -> np.ndarray:
        """(4,) task parameters: the object at (x, y), the goal PUSH_LENGTH away at ``angle_deg``."""
        a = np.radians(angle_deg)
        return np.array([x, y, x + PUSH_LENGTH * np.cos(a), y + PUSH_LENGTH * np.sin(a)])

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """(n, 4) task parameters drawn uniformly from the box."""
        return np.stack([self.params(rng.uniform(*self.x), rng.uniform(*self.y), rng.uniform(*self.angle_deg))
                         for _ in range(n)])

    def grid(self, nx: int, ny: int, nangle: int) -> np.ndarray:
        """(nx * ny * nangle, 4) task parameters on a grid spanning the box (corners included)."""
        return np.stack([self.params(x, y, a) for x in np.linspace(*self.x, nx) for y in np.linspace(*self.y, ny)
                         for a in np.linspace(*self.angle_deg, nangle)])


#: where the demonstrations are
TRAINING_REGION = Region(x=(0.31, 0.33), y=(-0.10, -0.05), angle_deg=(-5.0, 5.0))
#: where the tests are: the object 0.20-0.25 m further in -y than any demonstration, pushed at up
#: to twice the demonstrations' angles
EXTRAPOLATION_REGION = Region(x=(0.30, 0.34), y=(-0.35, -0.30), angle_deg=(-10.0, 10.0))


def training_params() -> np.ndarray:
    """(12, 4) the demonstrations' task parameters: 2 x 3 object positions x 2 push directions."""
    return TRAINING_REGION.grid(2, 3, 2)


def extrapolation_params(n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 4) test task parameters drawn from :data:`EXTRAPOLATION_REGION`."""
    return EXTRAPOLATION_REGION.sample(n, rng)


def _slides(model, params: np.ndarray) -> dict[int, float]:
    """qpos index -> value placing the object and the goal at ``params`` (4,) world m."""
    params = np.asarray(params, dtype=np.float64).reshape(4)
    out = {}
    for body, xy in (("object", params[:2]), ("goal", params[2:])):
        offset = xy - model.body(body).pos[:2]
        for axis, name in ((0, "x"), (1, "y")):
            out[int(model.jnt_qposadr[model.joint(f"{'obj' if body == 'object' else 'goal'}_slide{name}").id])] = offset[axis]
    return out


def set_pusher_task(env, params: np.ndarray) -> np.ndarray:
    """Place the object and the goal at ``params`` (4,) = (object x, y, goal x, y) world m, at rest,
    right after ``env.reset``; returns the new observation (23,)."""
    u = env.unwrapped
    qpos, qvel = u.data.qpos.copy(), u.data.qvel.copy()
    for index, value in _slides(u.model, params).items():
        qpos[index], qvel[index] = value, 0.0
    u.set_state(qpos, qvel)
    return u._get_obs()


@functools.lru_cache(maxsize=1)
def _kinematics():
    """The Pusher model and a private MjData for the expert's inverse kinematics."""
    import gymnasium as gym
    import mujoco

    env = gym.make(ENV_ID)
    model = env.unwrapped.model
    return model, mujoco.MjData(model)


def _min_jerk(n: int) -> np.ndarray:
    s = np.linspace(0.0, 1.0, n)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def _hand_frame(direction: np.ndarray) -> np.ndarray:
    """(3, 3) the hand's orientation for a push along ``direction`` (2,): fingers along it, bar level."""
    x = np.array([direction[0], direction[1], 0.0])
    z = np.array([0.0, 0.0, 1.0])
    return np.stack([x, np.cross(z, x), z], axis=1)


def _ik(target: np.ndarray, frame: np.ndarray, q: np.ndarray, slides: dict, iters: int = 30,
        weight: float = 0.3) -> np.ndarray:
    """Joint angles (7,) putting ``tips_arm`` at ``target`` (3,) m with the hand's orientation
    ``frame`` (3, 3), from ``q`` (7,) by damped least squares within the joint limits."""
    import mujoco

    model, data = _kinematics()
    hand = model.body("tips_arm").id
    lo, hi = model.jnt_range[:7, 0], model.jnt_range[:7, 1]
    jp, jr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    for index, value in slides.items():
        data.qpos[index] = value
    q = q.copy()
    for _ in range(iters):
        data.qpos[:7] = q
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        rot = data.xmat[hand].reshape(3, 3)
        err = np.r_[target - data.xpos[hand], weight * 0.5 * sum(np.cross(rot[:, i], frame[:, i]) for i in range(3))]
        if np.linalg.norm(err) < 1e-5:
            break
        mujoco.mj_jacBody(model, data, jp, jr, hand)
        jac = np.vstack([jp[:, :7], weight * jr[:, :7]])
        q = np.clip(q + jac.T @ np.linalg.solve(jac @ jac.T + 1e-4 * np.eye(6), err), lo, hi)
    return q


def pusher_expert(params: np.ndarray, n_steps: int = N_STEPS) -> np.ndarray:
    """The scripted push (module docstring) for task parameters ``params`` (4,) m: joint targets
    (n_steps, 7) rad, one per environment step, for the PD tracking of :data:`PUSHER_KP`/``KD``."""
    params = np.asarray(params, dtype=np.float64).reshape(4)
    model, _ = _kinematics()
    slides = _slides(model, params)
    obj, goal = params[:2], params[2:]
    direction = (goal - obj) / max(np.linalg.norm(goal - obj), 1e-9)
    frame = _hand_frame(direction)
    pre = np.r_[obj - 0.09 * direction, Z_PUSH]
    end = np.r_[goal + 0.05 * direction, Z_PUSH]
    above = np.r_[pre[:2], Z_ABOVE]
    q = Q_REST
    for _ in range(3):
        q = _ik(above, frame, q, slides, iters=100)
    n_move, n_lower, n_hold = 20, 10, 5
    out = list(_min_jerk(n_move)[:, None] * q)  # from the start posture (all joints 0)
    for point in above + _min_jerk(n_lower)[:, None] * (pre - above):
        q = _ik(point, frame, q, slides)
        out.append(q)
    n_push = n_steps - n_move - n_lower - n_hold
    for point in pre + np.linspace(0.0, 1.0, n_push + 1)[1:, None] * (end - pre):
        q = _ik(point, frame, q, slides)
        out.append(q)
    out += [q] * n_hold
    return np.asarray(out[:n_steps])


def pusher_demos():
    """The demonstration set: :func:`training_params` pushes by the expert, as
    :class:`~acnmp_core.data.demo_io.DemoArrays` (times (12, 100) phase 0..1, values (12, 100, 7) rad,
    task parameters (12, 4) m, named)."""
    from ...data.demo_io import DemoArrays

    params = training_params()
    values = np.stack([pusher_expert(p) for p in params])
    times = np.tile(np.linspace(0.0, 1.0, N_STEPS), (len(params), 1))
    model, _ = _kinematics()
    return DemoArrays(times=times, values=values, task_params=params,
                      task_param_names=np.array(["object_x", "object_y", "goal_x", "goal_y"]),
                      value_names=np.array([model.joint(j).name for j in range(7)]))
