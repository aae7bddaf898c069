"""Scripted expert for the pushing experiment (E2) and its demonstration set.

The cylinder starts at :data:`START_XY`; the task parameter is the target ``(x, y)`` (m) it must be
pushed to. The expert plans in the end effector's pose space ``(x, y, heading)`` and converts every
waypoint to joint angles with damped least-squares IK (warm-started from the previous waypoint, so
the joint trajectory is smooth):

1. hold the home posture (paddle facing the cylinder from the base's side, ``SAFE_RADIUS`` away);
2. circle the cylinder at ``SAFE_RADIUS`` (the paddle cannot touch it there) to the side opposite
   the target, paddle facing the cylinder;
3. move in until the paddle is 5 mm from the cylinder;
4. push in a straight line along the start-to-target direction with a minimum-jerk profile, so the
   paddle decelerates smoothly and the cylinder, held back by table friction, stops with it;
5. hold.

The aim point starts at the target and is corrected from a few simulated trials (the cylinder's
final error is added to the aim), as a demonstrator would retry; the last trial's joint trajectory
is the demonstration. Each trajectory has :data:`N_STEPS` = 300 rows (3 s at the 100 Hz control
rate of :class:`~acnmp_core.sim.planar_arm.PlanarArmSim`); times are the phase ``linspace(0, 1, 300)``.

Targets: :func:`push_targets` gives 11 targets, ``S + d (cos a, sin a)`` around the start. Nine
(``a`` from -60 to 100 deg) train the model; the tenth (``a`` = 140 deg) lies outside their x range
and is the extrapolation case; an 11th inside the range (``a`` = 30 deg, between two training
targets) is held out as the interpolation case. The demonstration file holds all 11 rows with a
``roles`` array ("train", "extrapolation", "interpolation") so the benchmark can split them.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ...data.demo_io import DemoArrays, load_demos, save_demos
from ...sim.kinematics import planar_fk, planar_ik, wrap_angle
from ...sim.planar_arm import PlanarArmSim, PushObject, default_geometry
from ...sim.urdf import ArmGeometry
from ...validation import check_array
from .settings import PAPER, PushSetting

#: Cylinder start (m): the simulator's default, so a default PlanarPushTask matches the demos.
START_XY = PushObject().start_xy
#: Radius (m) of the circle the paddle travels on around the cylinder before the push.
SAFE_RADIUS = 0.075
#: Rows per demonstration.
N_STEPS = 300
#: Phase boundaries (row indices) of hold / circle / approach / push / hold.
PHASES = (20, 120, 150, 280, 300)

# The targets (angle and distance from the start) are those of a PushSetting (push_settings.py);
# the paper setting's distances alternate so the targets span an area, not a single arc.


@dataclass(frozen=True)
class PushTargets:
    """The E2 targets (m): ``targets`` (11, 2) and the row indices of each role."""

    targets: np.ndarray
    train_idx: tuple[int, ...]
    extrapolation_idx: int
    interpolation_idx: int

    @property
    def roles(self) -> np.ndarray:
        """(11,) str: "train", "extrapolation" or "interpolation" per target."""
        roles = np.array(["train"] * len(self.targets), dtype="<U13")
        roles[self.extrapolation_idx] = "extrapolation"
        roles[self.interpolation_idx] = "interpolation"
        return roles


def push_targets(setting: PushSetting = PAPER) -> PushTargets:
    """The 11 targets of ``setting``: rows 0-8 train, row 9 extrapolation, row 10 interpolation."""
    return PushTargets(setting.targets(), tuple(range(9)), 9, 10)


def _min_jerk(n: int) -> np.ndarray:
    """(n,) minimum-jerk profile from 0 to 1 (zero velocity and acceleration at both ends)."""
    s = np.linspace(0.0, 1.0, n)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def home_configuration(geometry: ArmGeometry, obj: PushObject) -> np.ndarray:
    """(N,) the posture every demonstration starts from: paddle ``SAFE_RADIUS`` from the cylinder on
    the base's side, facing it."""
    s = np.asarray(obj.start_xy, dtype=np.float64)
    u = s / np.linalg.norm(s)
    pose = np.array([*(s - SAFE_RADIUS * u), np.arctan2(u[1], u[0])])
    return ik_from_seeds(pose, geometry)


def ik_from_seeds(pose, geometry: ArmGeometry) -> np.ndarray:
    """(N,) joint angles (rad) putting the tip at ``pose`` (3,) ``[x, y, heading]``, from the first of a
    few fixed IK seeds that reaches it; ValueError if none does."""
    n = geometry.n_joints
    if n < 3:
        raise ValueError(f"geometry: the expert needs at least 3 joints to set the paddle's heading, got {n}")
    # Deterministic seeds tried in turn: a zig-zag elbow (3 DoF) and curled postures (redundant arms),
    # since damped least squares can stall on a joint limit from a poor seed.
    seeds = [np.array([(-0.8 if i == 0 else 1.2 * (-1) ** (i + 1)) for i in range(n)]),
             np.array([-1.0, 1.5] + [0.5 * (-1) ** i for i in range(n - 2)])[:n],
             np.array([-1.0] + [2.4 / (n - 1)] * (n - 1))]
    last = None
    for seed in seeds:
        try:
            q = _ik_checked(pose, seed, geometry)
        except ValueError as exc:
            last = exc
            continue
        return q
    raise last


def _ik_checked(pose, q0, geometry: ArmGeometry, q_rest=None) -> np.ndarray:
    q = planar_ik(pose, q0, geometry.link_lengths, geometry.joint_limits, q_rest=q_rest)
    err = pose - planar_fk(q, geometry.link_lengths)
    err[2] = wrap_angle(err[2])
    if np.linalg.norm(err[:2]) > 1e-3 or abs(err[2]) > 1e-2:
        raise ValueError(f"target: the pose {np.round(pose, 3).tolist()} is out of the arm's reach "
                         f"(IK residual {np.round(err, 4).tolist()})")
    return q


def _pose_path(aim_xy: np.ndarray, geometry: ArmGeometry, obj: PushObject) -> np.ndarray:
    """(N_STEPS, 3) end-effector poses pushing the cylinder centre from the start to ``aim_xy``."""
    s = np.asarray(obj.start_xy, dtype=np.float64)
    d = aim_xy - s
    dist = float(np.linalg.norm(d))
    a = float(np.arctan2(d[1], d[0]))
    u = d / dist
    face = obj.radius + geometry.paddle_thickness / 2  # tip-to-cylinder-centre distance at contact
    h0, h1, h2, h3, h4 = PHASES
    th_home = float(np.arctan2(-s[1], -s[0]))  # angle around the cylinder of the home position
    th_push = th_home + float(wrap_angle(a + np.pi - th_home))  # shorter way round
    poses = np.empty((N_STEPS, 3))

    def on_circle(th, radius):
        # Tip on a circle around the cylinder, paddle heading towards its centre.
        return np.stack([s[0] + radius * np.cos(th), s[1] + radius * np.sin(th), th + np.pi], axis=-1)

    poses[:h0] = on_circle(np.full(h0, th_home), SAFE_RADIUS)
    poses[h0:h1] = on_circle(th_home + (th_push - th_home) * _min_jerk(h1 - h0), np.full(h1 - h0, SAFE_RADIUS))
    r_in = SAFE_RADIUS + (face + 0.005 - SAFE_RADIUS) * _min_jerk(h2 - h1)
    poses[h1:h2] = on_circle(np.full(h2 - h1, th_push), r_in)
    start_tip = s - (face + 0.005) * u
    end_tip = aim_xy - face * u
    prof = _min_jerk(h3 - h2)[:, None]
    poses[h2:h3, :2] = start_tip + (end_tip - start_tip) * prof
    poses[h2:h3, 2] = th_push + np.pi
    poses[h3:] = poses[h3 - 1]
    return poses


def expert_push_trajectory(target_xy, aim_xy=None, *, geometry: ArmGeometry | None = None,
                           obj: PushObject | None = None) -> np.ndarray:
    """Open-loop joint trajectory (N_STEPS, N) rad pushing the cylinder centre towards ``aim_xy``.

    ``aim_xy`` (2,) defaults to ``target_xy`` (2,) m. Raises ValueError if a waypoint is out of reach.
    """
    geometry = geometry if geometry is not None else default_geometry(3)
    obj = obj if obj is not None else PushObject(start_xy=START_XY)
    target = check_array("target_xy", target_xy, shape=(2,))
    aim = target if aim_xy is None else check_array("aim_xy", aim_xy, shape=(2,))
    if np.linalg.norm(aim - np.asarray(obj.start_xy)) < 1e-3:
        raise ValueError("target_xy: expected a target away from the cylinder's start")
    return follow_poses(_pose_path(aim, geometry, obj), geometry, home_configuration(geometry, obj))


def follow_poses(poses, geometry: ArmGeometry, q0) -> np.ndarray:
    """Joint trajectory (T, N) rad tracking tip poses (T, 3) ``[x, y, heading]`` from posture ``q0`` (N,).

    IK is warm-started from the previous row (a smooth path gives a smooth trajectory); a redundant
    arm is pulled towards ``q0`` in its null space. Raises ValueError if a pose is out of reach.
    """
    q = np.asarray(q0, dtype=np.float64).copy()
    rest = q.copy()
    traj = np.empty((len(poses), geometry.n_joints))
    for k, pose in enumerate(poses):
        q = _ik_checked(pose, q, geometry, q_rest=rest)
        traj[k] = q
    return traj


def expert_push(target_xy, *, sim: PlanarArmSim, trials: int = 4) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The expert's demonstration for one target, corrected over ``trials`` simulated attempts.

    Returns the joint trajectory (N_STEPS, N) and the executed states of its roll-out (see
    :meth:`PlanarArmSim.rollout`).
    """
    target = check_array("target_xy", target_xy, shape=(2,))
    aim = target.copy()
    best = None
    for _ in range(max(1, trials)):
        traj = expert_push_trajectory(target, aim, geometry=sim.geometry, obj=sim.obj)
        states = sim.rollout(traj)
        err = target - states["object_xy"][-1]
        if best is None or np.linalg.norm(err) < best[0]:
            best = (float(np.linalg.norm(err)), traj, states)
        if np.linalg.norm(err) < 2e-3:
            break
        aim = aim + err  # retry aiming past the miss by the miss
    return best[1], best[2]


def make_push_demos(n_joints: int = 3, *, trials: int = 4, geometry: ArmGeometry | None = None,
                    setting: PushSetting = PAPER, **sim_kwargs) -> tuple[DemoArrays, np.ndarray]:
    """Run the expert on all 11 targets of :func:`push_targets` ``(setting)``, the cylinder at the
    setting's start.

    Returns
    -------
    demos : :class:`~acnmp_core.data.demo_io.DemoArrays` with times (11, 300) phase, values (11, 300, N)
        joint angles (rad), task_params (11, 2) target (m), names and ``roles``.
    final_errors : (11,) distance (m) between the cylinder's final position and its target.
    """
    geometry = geometry if geometry is not None else default_geometry(n_joints)
    tg = push_targets(setting)
    values, errors = [], []
    with PlanarArmSim(geometry, PushObject(start_xy=setting.start_xy), **sim_kwargs) as sim:
        for target in tg.targets:
            traj, states = expert_push(target, sim=sim, trials=trials)
            values.append(traj)
            errors.append(float(np.linalg.norm(states["object_xy"][-1] - target)))
    n = len(values)
    demos = DemoArrays(
        times=np.tile(np.linspace(0.0, 1.0, N_STEPS), (n, 1)),
        values=np.stack(values),
        task_params=tg.targets.copy(),
        task_param_names=np.array(["target_x", "target_y"]),
        value_names=np.array([f"joint{i + 1}" for i in range(geometry.n_joints)]),
        roles=tg.roles,
    )
    return demos, np.asarray(errors)


def default_demo_path(n_joints: int = 3, setting: PushSetting = PAPER) -> str:
    """Where :func:`push_demos` caches the generated set: ``$ACNMP_CACHE`` or ``~/.cache/acnmp``
    (the paper setting keeps its original file name)."""
    root = os.environ.get("ACNMP_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "acnmp")
    tag = "" if setting.name == PAPER.name else f"{setting.name}_"
    return os.path.join(root, f"push_demos_{tag}{n_joints}dof.npz")


def push_demos(n_joints: int = 3, path: str | None = None, *, regenerate: bool = False,
               setting: PushSetting = PAPER) -> DemoArrays:
    """The E2 demonstration set of ``setting``, loaded from ``path`` (default :func:`default_demo_path`)
    or generated with :func:`make_push_demos` and saved there first (about 2 s)."""
    path = path or default_demo_path(n_joints, setting)
    if not regenerate and os.path.exists(path):
        return load_demos(path)
    demos, _ = make_push_demos(n_joints, setting=setting)
    save_demos(path, demos)
    return demos


def object_paths(values, setting: PushSetting = PAPER, *, geometry: ArmGeometry | None = None) -> np.ndarray:
    """(N, T, 2) m: the cylinder's path when each joint trajectory of ``values`` (N, T, J) rad is
    executed, the cylinder at ``setting``'s start. Gives the demonstrations' effects (their final
    cylinder positions) and the authors' tracking reference (the path of a held-out demonstration)."""
    vals = check_array("values", values, ndim=3, min_size=1)
    geometry = geometry if geometry is not None else default_geometry(vals.shape[2])
    with PlanarArmSim(geometry, PushObject(start_xy=setting.start_xy)) as sim:
        return np.stack([sim.rollout(v)["object_xy"] for v in vals])
