"""Write my_robot/demos.npz: five reaches to goals at x = 0.6 m, y from -0.2 to 0.2 m.

Each demonstration moves the joints from the start posture to the elbow-down inverse kinematics of
its goal along a minimum-jerk profile, 50 steps over phase 0..1. Run: python -m my_robot.make_demos
"""
from pathlib import Path

import numpy as np

from acnmp_core.data.demo_io import DemoArrays, save_demos

from .env import LINKS, START, STEPS

GOALS = np.array([[0.6, y] for y in (-0.2, -0.1, 0.0, 0.1, 0.2)])


def ik(goal: np.ndarray) -> np.ndarray:
    """Elbow-down joint angles (2,) rad putting the hand at ``goal`` (2,) m."""
    c2 = (goal @ goal - LINKS @ LINKS) / (2 * LINKS[0] * LINKS[1])
    q2 = np.arccos(np.clip(c2, -1.0, 1.0))
    q1 = np.arctan2(goal[1], goal[0]) - np.arctan2(LINKS[1] * np.sin(q2), LINKS[0] + LINKS[1] * np.cos(q2))
    return np.array([q1, q2])


def demos() -> DemoArrays:
    """The five demonstrations: times (5, 50), values (5, 50, 2) rad, task_params (5, 2) m."""
    s = np.linspace(0.0, 1.0, STEPS)
    blend = 10 * s**3 - 15 * s**4 + 6 * s**5
    values = np.stack([START + blend[:, None] * (ik(g) - START) for g in GOALS])
    return DemoArrays(times=np.tile(s, (len(GOALS), 1)), values=values, task_params=GOALS.copy())


if __name__ == "__main__":
    print(save_demos(Path(__file__).with_name("demos.npz"), demos()))
