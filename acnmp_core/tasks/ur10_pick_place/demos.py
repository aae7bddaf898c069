"""Scripted expert for the UR10 pick and place (E5) and its demonstration set.

The expert plans the tool centre point (TCP) in Cartesian space with a fixed orientation (tool
axis down, fingers closing along the world x axis) and converts every waypoint to joint angles with
damped least-squares IK (:meth:`~acnmp_core.sim.ur10.UR10Sim.inverse_kinematics`), warm-started
from the previous waypoint so the joint path is smooth. Segments (rows of
:data:`~acnmp_core.tasks.ur10_pick_place.task.SEGMENTS`, minimum-jerk profiles, so every segment starts
and ends at rest):

1. hold the authors' start pose;
2. move in joint space to the pre-grasp pose, ``PREGRASP_ABOVE`` above the grasp point;
3. descend to the grasp point (``h_obj - GRASP_DEPTH``);
4. hold while the gripper closes (the task closes it at ``GRASP_PHASE``);
5. lift straight up to the obstacle-avoidance height (``h_obs + CLEARANCE + h_obj - GRASP_DEPTH``);
6. carry horizontally over the obstacle to above the place position (above the obstacle's centre
   halfway, at ``CROSS_PHASE``);
7. lower until the object's bottom is ``PLACE_GAP`` above the table;
8. hold while the gripper opens (at ``RELEASE_PHASE``);
9. retreat ``RETREAT`` straight up.

Demonstrations: :data:`TRAIN_HEIGHTS`, h_obj in {2, 6} cm x h_obs in {2, 4, 6, 8} cm (8 rows, role
"train"), and the same expert at :data:`TEST_HEIGHTS` (8, 10), (9, 11) and (10, 12) cm (role
"extrapolation"), the ground truth the paper compares against. 625 rows each, times = phase
``linspace(0, 1, 625)``, values = the six arm joints (rad).
"""
from __future__ import annotations

import os

import numpy as np

from ...data.demo_io import DemoArrays, load_demos, save_demos
from ...sim.ur10 import UR10Sim
from ...sim.ur10_description import UR10_ARM_JOINTS
from .task import (GRASP_DEPTH, N_STEPS, SEGMENTS, UR10PickPlaceTask, avoidance_point, check_task_params,
                              grasp_point)

#: TCP rotation (columns: its x, y, z axes in the world): z down, fingers closing along world x.
TOOL_ROTATION = np.array([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]])
#: Height (m) of the pre-grasp pose above the grasp point.
PREGRASP_ABOVE = 0.10
#: Gap (m) between the carried object's bottom and the table when the gripper opens.
PLACE_GAP = 0.003
#: Height (m) the TCP rises after releasing.
RETREAT = 0.08
#: (h_obj, h_obs) in metres of the training demonstrations and of the extrapolation tests.
TRAIN_HEIGHTS = tuple((o, b) for o in (0.02, 0.06) for b in (0.02, 0.04, 0.06, 0.08))
TEST_HEIGHTS = ((0.08, 0.10), (0.09, 0.11), (0.10, 0.12))
#: Bump when the scene, the robot or the expert changes, so stale cached demonstrations are not read.
DEMO_VERSION = 2  # 2: the expert at (10, 12) cm too


def _min_jerk(n: int) -> np.ndarray:
    """(n,) minimum-jerk profile from 0 to 1 (zero velocity and acceleration at both ends)."""
    s = np.linspace(0.0, 1.0, n)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def _line(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    """(n, 3) points from ``a`` to ``b`` (both included) with a minimum-jerk profile."""
    return a + (b - a) * _min_jerk(n)[:, None]


def expert_tcp_path(h_obj: float, h_obs: float, sim: UR10Sim) -> np.ndarray:
    """(N_STEPS - SEGMENTS[1], 3) TCP positions (m) of the Cartesian segments 3-9 (from the
    pre-grasp pose on)."""
    sc = sim.scene
    grasp = grasp_point(h_obj, sc)
    over = avoidance_point(h_obj, h_obs, sc)
    pre = grasp + [0.0, 0.0, PREGRASP_ABOVE]
    lifted = np.array([*sc.pick_xy, over[2]])
    above_place = np.array([*sc.place_xy, over[2]])
    # The object's bottom hangs (h_obj - GRASP_DEPTH) below the TCP.
    down = np.array([*sc.place_xy, h_obj - GRASP_DEPTH + PLACE_GAP])
    up = down + [0.0, 0.0, RETREAT]
    s = SEGMENTS
    parts = [
        _line(pre, grasp, s[2] - s[1]),
        np.repeat(grasp[None], s[3] - s[2], axis=0),
        _line(grasp, lifted, s[4] - s[3]),
        _line(lifted, above_place, s[5] - s[4]),
        _line(above_place, down, s[6] - s[5]),
        np.repeat(down[None], s[7] - s[6], axis=0),
        _line(down, up, s[8] - s[7]),
    ]
    return np.concatenate(parts)


def expert_trajectory(task_params, *, sim: UR10Sim) -> np.ndarray:
    """The expert's joint trajectory (N_STEPS, 6) rad for ``task_params`` (2,) = (h_obj, h_obs) m.

    Raises ValueError if a waypoint is out of the arm's reach.
    """
    h_obj, h_obs = check_task_params(task_params)
    q_start = sim.start_pose.copy()
    path = expert_tcp_path(h_obj, h_obs, sim)
    traj = np.empty((N_STEPS, 6))
    s0, s1 = SEGMENTS[0], SEGMENTS[1]
    traj[:s0] = q_start
    q_pre = sim.inverse_kinematics(path[0], TOOL_ROTATION, q_start)
    traj[s0:s1] = q_start + (q_pre - q_start) * _min_jerk(s1 - s0)[:, None]
    q = q_pre
    for k, pos in enumerate(path):
        q = sim.inverse_kinematics(pos, TOOL_ROTATION, q)
        traj[s1 + k] = q
    return traj


def make_ur10_demos(heights=None, *, task: UR10PickPlaceTask | None = None) -> tuple[DemoArrays, np.ndarray, np.ndarray]:
    """Run the expert at every ``(h_obj, h_obs)`` of ``heights`` (default: train then test heights)
    and execute each trajectory in physics.

    Returns
    -------
    demos : :class:`~acnmp_core.data.demo_io.DemoArrays`, times (N, 625) phase, values (N, 625, 6) rad,
        task_params (N, 2) m, roles "train" / "extrapolation" (for the default heights).
    success : (N,) bool, the task's success of each executed demonstration.
    errors : (N,) the task's error (m): grasp distance + avoidance distance of the executed TCP.
    """
    default = heights is None
    heights = np.asarray(TRAIN_HEIGHTS + TEST_HEIGHTS if default else heights, dtype=np.float64)
    own = task is None
    task = task if task is not None else UR10PickPlaceTask()
    times = np.linspace(0.0, 1.0, N_STEPS)
    try:
        values, success, errors = [], [], []
        for hp in heights:
            traj = expert_trajectory(hp, sim=task.sim)
            batch = task.evaluate(traj[None], times, hp)
            values.append(traj)
            success.append(bool(batch.success[0]))
            errors.append(float(batch.errors[0]))
    finally:
        if own:
            task.close()
    n = len(values)
    roles = None
    if default:
        roles = np.array(["train"] * len(TRAIN_HEIGHTS) + ["extrapolation"] * len(TEST_HEIGHTS))
    demos = DemoArrays(
        times=np.tile(times, (n, 1)),
        values=np.stack(values),
        task_params=heights.copy(),
        task_param_names=np.array(["h_obj", "h_obs"]),
        value_names=np.array(list(UR10_ARM_JOINTS)),
        roles=roles,
    )
    return demos, np.asarray(success), np.asarray(errors)


def default_demo_path() -> str:
    """Where :func:`ur10_demos` caches the set: ``$ACNMP_CACHE`` or ``~/.cache/acnmp``."""
    root = os.environ.get("ACNMP_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "acnmp")
    return os.path.join(root, f"ur10_pick_place_demos_v{DEMO_VERSION}.npz")


def ur10_demos(path: str | None = None, *, regenerate: bool = False) -> DemoArrays:
    """The E5 demonstration set (8 "train" + 3 "extrapolation" rows), loaded from ``path`` (default
    :func:`default_demo_path`) or generated with :func:`make_ur10_demos` and saved there first.

    Raises RuntimeError if a generated demonstration fails in physics (the expert is then broken
    for this scene, and the set is not saved).
    """
    path = path or default_demo_path()
    if not regenerate and os.path.exists(path):
        return load_demos(path)
    demos, success, errors = make_ur10_demos()
    if not success.all():
        bad = [tuple(demos.task_params[i].tolist()) for i in np.flatnonzero(~success)]
        raise RuntimeError(f"ur10_demos: the expert fails in physics at (h_obj, h_obs) = {bad}")
    save_demos(path, demos)
    return demos

