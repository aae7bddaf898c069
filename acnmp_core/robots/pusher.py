"""The robot kind ``pusher``: Gymnasium's MuJoCo ``Pusher-v5`` through the Gymnasium adapter.

Its task ``pusher_push`` executes joint targets (T, 7) rad, one per environment step, with the PD
gains of :mod:`acnmp_core.tasks.pusher.scene`; the task parameters (4,) place the object and the
goal (world m); the rewards are Pusher's own per step (minus the object's distance to the goal,
minus half the hand's distance to the object, minus a small control cost), credited to every
earlier step ("future": a push pays off late); success is the object's final distance to the goal
within :data:`~acnmp_core.tasks.pusher.scene.PUSHER_SUCCESS_M`, which is also the reported error.
"""
from __future__ import annotations

import numpy as np

from .gym_robot import Episode, GymRobotConfig, gym_robot

TASK = "pusher_push"


def object_goal_distance(ep: Episode) -> float:
    """The object's final distance (m) to the goal, from Pusher's last observation."""
    return float(np.linalg.norm(ep.final_obs[17:19] - ep.final_obs[20:22]))


def pusher_config() -> GymRobotConfig:
    """The adapter's configuration of Pusher-v5 (imports the scene, not gymnasium itself)."""
    from ..tasks.pusher.scene import ENV_ID, PUSHER_KD, PUSHER_KP, PUSHER_SUCCESS_M, set_pusher_task

    return GymRobotConfig(
        ENV_ID, joint_positions=lambda o: o[:7], joint_velocities=lambda o: o[7:14], kp=PUSHER_KP, kd=PUSHER_KD,
        set_task=set_pusher_task, error=object_goal_distance,
        success=lambda ep: object_goal_distance(ep) <= PUSHER_SUCCESS_M,
        end_effector=lambda o: o[14:17], object_position=lambda o: o[17:20], goal_params=(2, 3))


PUSHER = gym_robot("pusher", "Gymnasium's MuJoCo Pusher-v5: a 7-DoF arm pushing a cylinder to a goal",
                   pusher_config, task=TASK, credit="future")
