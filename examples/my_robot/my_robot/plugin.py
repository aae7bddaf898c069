"""The plugin: ReachEnv as the robot kind ``my_arm`` (declared in pyproject.toml's entry points)."""
import numpy as np

from acnmp_core.robots.gym_robot import GymRobotConfig, gym_robot

from .env import ReachEnv

CONFIG = GymRobotConfig(
    ReachEnv,                                   # a factory (or a registered id such as "Pusher-v5")
    joint_positions=lambda obs: obs[:2],        # where the joint angles are in the observation
    # ReachEnv's actions are joint velocities: q <- q + dt * action. kp = 1/dt makes each step land
    # on its trajectory row (q <- target); a smaller kp trails it by 1/kp - dt seconds.
    control="pd", kp=1.0 / ReachEnv.dt, kd=0.0,
    success="is_success",                       # info entry of the last step
    error=lambda ep: float(ep.final_info["distance"]),
    end_effector=lambda obs: np.array([obs[2], obs[3], 0.0]),
    goal_params=(0, 1))                         # task parameters (x, y) are the goal, drawn as a point

ROBOT = gym_robot("my_arm", "a 2-link arm reaching a goal (the examples/my_robot plugin)", CONFIG,
                  task="reach")
