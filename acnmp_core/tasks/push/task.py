"""The push task: a planar arm pushes a cylinder to a target on the table (the reward and success)."""
from __future__ import annotations

import numpy as np

from ...rollout import ClosedAtExit, RolloutBatch
from ...validation import check_array
from ...sim.planar_arm import PlanarArmSim, PushObject, default_geometry
from ...sim.urdf import ArmGeometry


class PlanarPushTask(ClosedAtExit):
    """The pushing task as a :class:`~acnmp_core.rollout.RolloutEvaluator`.

    ``evaluate(trajectories (B, T, N), times (T,), task_params (2,))`` runs each joint trajectory on
    the simulator; ``task_params`` is the target ``(x, y)`` (m) of the cylinder.

    Reward (``reward``): "distance" (default) gives every step minus the cylinder's distance (m) to
    the target at that step, divided by T, so the return is minus the time-averaged distance and a
    per-step advantage says at which steps a push moved the cylinder nearer; "final" gives zero at
    every step but the last, which gets minus the final distance (the return is then minus the
    final error); "tracking" (the authors' code, E2 ``authors`` setting) gives every step minus the
    squared distance (m^2) between the cylinder and ``reference_path`` (T, 2) m at that step, the
    cylinder's path in a demonstration of the same target. Either way ``errors`` is the final distance (m) and success is that distance being
    at most ``tolerance`` (default 0.03 m, one cylinder radius: the object then still overlaps the
    target point).

    ``times`` must have T entries and be increasing; the simulator runs one row per control step
    (``control_dt``), so ``times`` only labels the steps (the project uses phase in [0, 1]).

    States returned (B, T, ...): ``joint_angles``, ``ee_xy``, ``ee_yaw``, ``object_xy``.
    """

    task_param_names = ("target_x", "target_y")
    REWARDS = ("distance", "final", "tracking")
    #: The cylinder moves by contact: an action is credited with every reward after it.
    credit = "future"

    def __init__(self, n_joints: int = 3, *, geometry: ArmGeometry | None = None, obj: PushObject | None = None,
                 tolerance: float = 0.03, reward: str = "distance", reference_path=None, **sim_kwargs) -> None:
        if reward not in self.REWARDS:
            raise ValueError(f"reward: expected one of {self.REWARDS}, got {reward!r}")
        if (reward == "tracking") != (reference_path is not None):
            raise ValueError("reference_path: expected a (T, 2) path with reward 'tracking' and only then")
        self.reference_path = None if reference_path is None else check_array("reference_path", reference_path,
                                                                             ndim=2)
        geometry = geometry if geometry is not None else default_geometry(n_joints)
        self.sim = PlanarArmSim(geometry, obj, **sim_kwargs)
        self.tolerance = float(tolerance)
        self.reward = reward

    @property
    def n_joints(self) -> int:
        return self.sim.n_joints

    def evaluate(self, trajectories, times, task_params=None) -> RolloutBatch:
        trajs = check_array("trajectories", trajectories, ndim=3, min_size=1)
        b, t_len, n = trajs.shape
        if n != self.n_joints:
            raise ValueError(f"trajectories: expected {self.n_joints} joint angles per step, got {n}")
        times = check_array("times", times, shape=(t_len,))
        if t_len > 1 and np.any(np.diff(times) <= 0):
            raise ValueError("times: expected strictly increasing times")
        if task_params is None:
            raise ValueError("task_params: expected the target (x, y), got None")
        target = check_array("task_params", task_params, shape=(2,))
        rewards = np.zeros((b, t_len))
        errors = np.zeros(b)
        keys = ("joint_angles", "ee_xy", "ee_yaw", "object_xy")
        states: dict[str, list] = {k: [] for k in keys}
        for i in range(b):
            out = self.sim.rollout(trajs[i])
            dist = np.linalg.norm(out["object_xy"] - target, axis=1)  # (T,)
            errors[i] = dist[-1]
            if self.reward == "distance":
                rewards[i] = -dist / t_len
            elif self.reward == "tracking":
                if self.reference_path.shape != out["object_xy"].shape:
                    raise ValueError(f"reference_path: expected shape {out['object_xy'].shape}, "
                                     f"got {self.reference_path.shape}")
                rewards[i] = -np.sum((out["object_xy"] - self.reference_path) ** 2, axis=1)
            else:
                rewards[i, -1] = -dist[-1]
            for k in keys:
                states[k].append(out[k])
        return RolloutBatch(rewards=rewards, success=errors <= self.tolerance,
                            states={k: np.stack(v) for k, v in states.items()}, errors=errors)

    def close(self) -> None:
        self.sim.close()
