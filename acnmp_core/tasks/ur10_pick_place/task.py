"""E5: the UR10 picks a box and places it beyond an obstacle (paper Sec. 4.4, Table 2 left).

Task parameters: ``(h_obj, h_obs)`` (m), the heights of the box to pick and of the obstacle. The
learnt output is the six arm joints (rad), one row per 8 ms control step (the project's
trajectories have :data:`N_STEPS` = 625 rows, 5 s, like the authors' demonstrations). The gripper is
not learnt: it is scripted from the trajectory's phase, closed from :data:`GRASP_PHASE` until
:data:`RELEASE_PHASE`, the phases at which the scripted expert (:mod:`acnmp_core.tasks.ur10_pick_place.demos`)
has reached the grasp point and has set the object down.

Points (m), for a scene :class:`~acnmp_core.sim.ur10.PickPlaceScene`:

* grasp point: above the object's centre at ``h_obj - GRASP_DEPTH`` (the fingers close on its upper
  part, their tips ``tcp_above_tip`` lower);
* obstacle-avoidance point: above the obstacle's centre at
  ``h_obs + CLEARANCE + (h_obj - GRASP_DEPTH)``: the TCP height at which the carried box's
  bottom passes ``CLEARANCE`` above the obstacle.

Reward (per step, (T,)): zero except at the grasp step (the row nearest :data:`GRASP_PHASE`), minus
the TCP's distance to the grasp point, and at the crossing step (nearest :data:`CROSS_PHASE`, where
the expert is above the obstacle), minus the TCP's distance to the obstacle-avoidance point. The
return is minus the sum of the two distances, the paper's reward; ``errors`` is that sum (m).

Success (physics, not the reward): the object was lifted (rose >= ``lift_tolerance`` above its
start) between two touching fingers, nothing touched the obstacle at any step, and the object ends
within ``place_tolerance`` (2 cm) of the place position resting on the table (centre distance to
``(place_x, place_y, h_obj / 2)``).
"""
from __future__ import annotations

import numpy as np

from ...sim.ur10 import PickPlaceScene, UR10Sim
from ...sim.ur10_description import GripperGeometry
from ...rollout import ClosedAtExit, RolloutBatch
from ...validation import check_array

#: Rows of the project's UR10 trajectories (5 s at 125 Hz).
N_STEPS = 625
#: Row boundaries of the expert's segments (for N_STEPS rows): hold, to pre-grasp, descend, close,
#: lift, carry, lower, open, retreat.
SEGMENTS = (20, 150, 210, 250, 310, 471, 530, 560, 625)
#: Phases (fraction of the trajectory) of the gripper closing, of crossing the obstacle, of opening.
GRASP_PHASE = SEGMENTS[2] / (N_STEPS - 1)
CROSS_PHASE = (SEGMENTS[4] + SEGMENTS[5] - 1) / 2 / (N_STEPS - 1)
RELEASE_PHASE = SEGMENTS[6] / (N_STEPS - 1)
#: Grasp point depth below the object's top (m).
GRASP_DEPTH = 0.01
#: Clearance (m) of the carried object's bottom above the obstacle at the avoidance point.
CLEARANCE = 0.04
#: Height ranges (m) the task accepts: the grasp needs the fingertips above the table.
H_OBJ_RANGE = (0.02, 0.20)
H_OBS_RANGE = (0.005, 0.30)


def check_task_params(task_params) -> tuple[float, float]:
    """``(h_obj, h_obs)`` (m) from a (2,) array; ValueError naming ``task_params`` otherwise."""
    if task_params is None:
        raise ValueError("task_params: expected (h_obj, h_obs) in metres, got None")
    h = check_array("task_params", task_params, shape=(2,))
    for v, (lo, hi), name in ((h[0], H_OBJ_RANGE, "h_obj"), (h[1], H_OBS_RANGE, "h_obs")):
        if not lo <= v <= hi:
            raise ValueError(f"task_params: {name} = {v} m is outside [{lo}, {hi}] m")
    return float(h[0]), float(h[1])


def grasp_point(h_obj: float, scene: PickPlaceScene) -> np.ndarray:
    """(3,) the TCP position (m) at which the fingers close on the object."""
    return np.array([*scene.pick_xy, h_obj - GRASP_DEPTH])


def avoidance_point(h_obj: float, h_obs: float, scene: PickPlaceScene) -> np.ndarray:
    """(3,) the TCP position (m) above the obstacle at which the carried object clears it by CLEARANCE."""
    return np.array([*scene.obstacle_xy, h_obs + CLEARANCE + h_obj - GRASP_DEPTH])


def phase_of(times) -> np.ndarray:
    """(T,) the phase in [0, 1] of strictly increasing ``times`` (T,) (any unit)."""
    times = np.asarray(times, dtype=np.float64)
    if len(times) < 2:
        return np.zeros(len(times))
    return (times - times[0]) / (times[-1] - times[0])


def gripper_schedule(times) -> np.ndarray:
    """(T,) bool: the gripper is closed from GRASP_PHASE (inclusive) to RELEASE_PHASE (exclusive)."""
    ph = phase_of(times)
    # A tiny slack so the rows of N_STEPS-long phase grids land on the boundaries despite rounding.
    return (ph >= GRASP_PHASE - 1e-9) & (ph < RELEASE_PHASE - 1e-9)


def reward_steps(times) -> tuple[int, int]:
    """(grasp row, crossing row): the rows whose phase is nearest GRASP_PHASE and CROSS_PHASE."""
    ph = phase_of(times)
    return int(np.argmin(np.abs(ph - GRASP_PHASE))), int(np.argmin(np.abs(ph - CROSS_PHASE)))


class UR10PickPlaceTask(ClosedAtExit):
    """The pick-and-place task as a :class:`~acnmp_core.rollout.RolloutEvaluator`.

    ``evaluate(trajectories (B, T, 6), times (T,), task_params (2,) = (h_obj, h_obs) m)`` runs each
    joint trajectory (rad) on one :class:`~acnmp_core.sim.ur10.UR10Sim` with the gripper scripted
    from the phase of ``times`` (see the module docstring for the reward and success). The
    simulator runs one row per 8 ms control step whatever ``times`` says; ``times`` only gives the
    phase (the project uses ``linspace(0, 1, T)``).

    States returned (B, T, ...): ``joint_angles`` (6) rad, ``finger_opening`` m, ``tcp_xyz`` (3) m,
    ``object_xyz`` (3) m, ``object_quat`` (4) (x, y, z, w), ``obstacle_contact`` bool,
    ``finger_contacts`` int: with the scene and the heights, enough to draw every step.

    Parameters
    ----------
    scene, gripper : the layout and the gripper (defaults as in :class:`~acnmp_core.sim.ur10.UR10Sim`).
    place_tolerance : success radius (m) around the place position.
    lift_tolerance : how far (m) the object must rise to count as grasped.
    sim_kwargs : passed to :class:`~acnmp_core.sim.ur10.UR10Sim`.
    """

    task_param_names = ("h_obj", "h_obs")

    def __init__(self, *, scene: PickPlaceScene | None = None, gripper: GripperGeometry | None = None,
                 place_tolerance: float = 0.02, lift_tolerance: float = 0.02, **sim_kwargs) -> None:
        if not place_tolerance > 0:
            raise ValueError(f"place_tolerance: expected a positive distance (m), got {place_tolerance!r}")
        if not lift_tolerance > 0:
            raise ValueError(f"lift_tolerance: expected a positive distance (m), got {lift_tolerance!r}")
        self.sim = UR10Sim(scene, gripper, **sim_kwargs)
        self.place_tolerance = float(place_tolerance)
        self.lift_tolerance = float(lift_tolerance)

    @property
    def scene(self) -> PickPlaceScene:
        return self.sim.scene

    def evaluate(self, trajectories, times, task_params=None) -> RolloutBatch:
        """Execute B joint trajectories (B, T, 6) rad at ``task_params`` (2,) = (h_obj, h_obs) m.

        Returns a :class:`~acnmp_core.rollout.RolloutBatch`: rewards (B, T), success (B,), states
        (B, T, ...), errors (B,) = grasp distance + avoidance distance (m).
        """
        trajs = check_array("trajectories", trajectories, ndim=3, min_size=1)
        b, t_len, n = trajs.shape
        if n != 6:
            raise ValueError(f"trajectories: expected 6 joint angles per step (the UR10's arm joints), got {n}")
        if t_len < 2:
            raise ValueError(f"trajectories: expected at least 2 steps, got {t_len}")
        times = check_array("times", times, shape=(t_len,))
        if np.any(np.diff(times) <= 0):
            raise ValueError("times: expected strictly increasing times")
        h_obj, h_obs = check_task_params(task_params)
        self.sim.set_heights(h_obj, h_obs)
        closed = gripper_schedule(times)
        k_grasp, k_cross = reward_steps(times)
        g_pt = grasp_point(h_obj, self.scene)
        a_pt = avoidance_point(h_obj, h_obs, self.scene)
        place = np.array([*self.scene.place_xy, h_obj / 2])
        start_z = h_obj / 2
        rewards = np.zeros((b, t_len))
        errors = np.zeros(b)
        success = np.zeros(b, dtype=bool)
        states: dict[str, list] = {}
        for i in range(b):
            out = self.sim.rollout(trajs[i], closed)
            d_grasp = float(np.linalg.norm(out["tcp_xyz"][k_grasp] - g_pt))
            d_cross = float(np.linalg.norm(out["tcp_xyz"][k_cross] - a_pt))
            rewards[i, k_grasp] -= d_grasp
            rewards[i, k_cross] -= d_cross  # both at one row only if T is tiny; the sum stays right
            errors[i] = d_grasp + d_cross
            lifted = np.any((out["object_xyz"][:, 2] >= start_z + self.lift_tolerance)
                            & (out["finger_contacts"] == 2))
            placed = np.linalg.norm(out["object_xyz"][-1] - place) <= self.place_tolerance
            success[i] = bool(lifted and placed and not out["obstacle_contact"].any())
            for key, val in out.items():
                states.setdefault(key, []).append(val)
        return RolloutBatch(rewards=rewards, success=success, states={k: np.stack(v) for k, v in states.items()},
                            errors=errors)

    def close(self) -> None:
        self.sim.close()
