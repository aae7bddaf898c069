"""E4's scene: a planar arm pushes a small cube through the gap between two walls to a goal.

The authors' scene (their CoppeliaSim code): two walls 0.015 x 0.355 x 0.184 m at (0.33, -0.311) and
(0.465, 0.059), both at yaw -0.35 rad; they lie on one line and leave a gap of about 3.9 cm between
their ends; a 1.8 cm cube at (0.40, -0.124), in the gap; the goal (0.445, -0.146), about 5 cm beyond
it on the far side from the robot's base. Success: the cube ends less than 1.5 cm from the goal.

Adapted to the project's arms:

* the whole scene is moved :data:`SHIFT` = 0.15 m further from the robot's base along the walls'
  normal (relative positions unchanged): at the authors' distance (0.40 m) the project's arms
  (0.72 m reach) must fold so far that the 4-DoF arm's joints sit on their limits and IK fails on
  the proxy paths;
* the walls are :data:`WALL_HEIGHT` = 0.06 m tall instead of 0.184 m: the arms' links move in a plane
  10 cm above the table (only the paddle hangs down to the table), so taller walls would block the
  links themselves rather than the pushed cube;
* the paddle is :data:`PADDLE_WIDTH` = 0.02 m wide instead of the pushing arms' 0.05 m, so it fits
  through the 3.9 cm gap (the authors' tool was a thin rod).

:class:`CubeGapSim` is a :class:`~acnmp_core.sim.planar_arm.PlanarArmSim` whose pushed object is
the cube and whose world holds the two walls; :class:`CubeGapTask` scores roll-outs like the
pushing task (reward minus the cube's distance to the goal at every step, over T).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from ...sim.quiet_pybullet import pybullet as p

from ...sim.planar_arm import PlanarArmSim, PushObject, default_geometry

from ..push.task import PlanarPushTask
from ...sim.urdf import ArmGeometry
from ...rollout import RolloutBatch

#: Wall height (m), lowered from the authors' 0.184 m (see the module docstring).
WALL_HEIGHT = 0.06
#: Paddle width (m) of both arms in this scene (see the module docstring).
PADDLE_WIDTH = 0.02
#: The authors' walls' yaw (rad) and positions (m) of the walls' centres, the cube and the goal.
AUTHORS_YAW = -0.35
AUTHORS_XY = {"walls": ((0.33, -0.311), (0.465, 0.059)), "cube": (0.40, -0.124), "goal": (0.445, -0.146)}
#: How far (m) the scene is moved from the base along the walls' normal (see the module docstring).
SHIFT = 0.15


def _shifted(xy) -> tuple[float, float]:
    """The authors' position ``xy`` moved by SHIFT along the walls' normal (cos yaw, sin yaw)."""
    return (round(float(xy[0] + SHIFT * np.cos(AUTHORS_YAW)), 6), round(float(xy[1] + SHIFT * np.sin(AUTHORS_YAW)), 6))


@dataclass(frozen=True)
class CubeGapScene:
    """Positions (m) and sizes (m) of the scene; defaults are the authors', adapted (module docstring).

    wall_size : (thickness, length, height) of each wall. wall_centres : their (x, y) centres.
    wall_yaw : rotation (rad) of both walls about z. cube_xy, cube_size : the cube's start and edge.
    goal_xy : where the cube must end. tolerance : success radius around the goal.
    """

    wall_size: tuple[float, float, float] = (0.015, 0.355, WALL_HEIGHT)
    wall_centres: tuple[tuple[float, float], ...] = tuple(_shifted(xy) for xy in AUTHORS_XY["walls"])
    wall_yaw: float = AUTHORS_YAW
    cube_xy: tuple[float, float] = _shifted(AUTHORS_XY["cube"])
    cube_size: float = 0.018
    cube_mass: float = 0.05
    goal_xy: tuple[float, float] = _shifted(AUTHORS_XY["goal"])
    tolerance: float = 0.015

    @property
    def wall_normal(self) -> np.ndarray:
        """(2,) unit normal of the wall line pointing away from the robot's base (towards the goal)."""
        n = np.array([np.cos(self.wall_yaw), np.sin(self.wall_yaw)])
        return n if n @ np.asarray(self.goal_xy) > 0 else -n

    @property
    def wall_direction(self) -> np.ndarray:
        """(2,) unit vector along the wall line."""
        return np.array([-np.sin(self.wall_yaw), np.cos(self.wall_yaw)])

    @property
    def gap_centre(self) -> np.ndarray:
        """(2,) midpoint between the walls' facing ends."""
        return np.mean(np.asarray(self.wall_centres, dtype=np.float64), axis=0)

    @property
    def gap_width(self) -> float:
        """Clear width (m) between the walls' ends."""
        a, b = np.asarray(self.wall_centres, dtype=np.float64)
        return float(abs((b - a) @ self.wall_direction) - self.wall_size[1])


def transfer_geometry(n_joints: int) -> ArmGeometry:
    """The project's ``n_joints`` planar arm (:func:`default_geometry`) with the narrow paddle of this scene."""
    return replace(default_geometry(n_joints), paddle_width=PADDLE_WIDTH)


class CubeGapSim(PlanarArmSim):
    """A :class:`PlanarArmSim` world with the cube as the pushed object and the two walls.

    Parameters: ``n_joints`` (the arm, :func:`transfer_geometry`), ``scene``
    (:class:`CubeGapScene`), and :class:`PlanarArmSim`'s keyword arguments. ``rollout`` reports the
    cube's centre as ``object_xy``.
    """

    def __init__(self, n_joints: int = 3, scene: CubeGapScene | None = None, **sim_kwargs) -> None:
        self.scene = scene or CubeGapScene()
        s = self.scene
        # The base class places its object at height obj.height / 2 on every reset: a cube of edge
        # ``cube_size`` described as a PushObject of that height rests on the table the same way.
        obj = PushObject(start_xy=s.cube_xy, radius=s.cube_size / 2, height=s.cube_size, mass=s.cube_mass)
        super().__init__(transfer_geometry(n_joints), obj, **sim_kwargs)
        cid = self.client_id
        p.removeBody(self.object, physicsClientId=cid)
        half = s.cube_size / 2
        box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[half] * 3, physicsClientId=cid)
        self.object = p.createMultiBody(s.cube_mass, box, -1, self._object_pose(s.cube_xy), physicsClientId=cid)
        p.changeDynamics(self.object, -1, lateralFriction=self.obj.lateral_friction,
                         spinningFriction=self.obj.spinning_friction, rollingFriction=0.0, physicsClientId=cid)
        wall = p.createCollisionShape(p.GEOM_BOX, halfExtents=[v / 2 for v in s.wall_size], physicsClientId=cid)
        orn = p.getQuaternionFromEuler([0.0, 0.0, s.wall_yaw])
        self.walls = [p.createMultiBody(0, wall, -1, [x, y, s.wall_size[2] / 2], orn, physicsClientId=cid)
                      for x, y in s.wall_centres]
        for w in self.walls:
            # Slippery walls: the cube slides along a wall it touches instead of sticking to it.
            p.changeDynamics(w, -1, lateralFriction=0.1, physicsClientId=cid)
        for _ in range(10):  # settle once so the contact cache exists before the state is saved
            p.stepSimulation(physicsClientId=cid)
        p.resetBasePositionAndOrientation(self.object, self._object_pose(s.cube_xy), [0, 0, 0, 1],
                                          physicsClientId=cid)
        p.resetBaseVelocity(self.object, [0, 0, 0], [0, 0, 0], physicsClientId=cid)
        p.removeState(self._initial_state, physicsClientId=cid)
        self._initial_state = p.saveState(physicsClientId=cid)


class CubeGapTask(PlanarPushTask):
    """E4's task as a :class:`~acnmp_core.rollout.RolloutEvaluator` on a :class:`CubeGapSim`.

    ``evaluate(trajectories (B, T, N) rad, times (T,), task_params=None)``: the goal is the scene's
    (a task parameter (2,) overrides it). Reward at every step minus the cube's distance (m) to the
    goal, over T (the authors' per-step reward, scaled like E2's); ``errors`` the final distance;
    success when it is below ``scene.tolerance`` (1.5 cm). States as :class:`PlanarPushTask`'s.
    """

    task_param_names = ()

    def __init__(self, n_joints: int = 3, scene: CubeGapScene | None = None, **sim_kwargs) -> None:
        self.sim = CubeGapSim(n_joints, scene, **sim_kwargs)
        self.scene = self.sim.scene
        self.tolerance = float(self.scene.tolerance)
        self.reward = "distance"

    def evaluate(self, trajectories, times, task_params=None) -> RolloutBatch:
        goal = np.asarray(self.scene.goal_xy, dtype=np.float64) if task_params is None else task_params
        batch = super().evaluate(trajectories, times, goal)
        # "less than 1.5 cm" (the authors'), where the pushing task counts "at most".
        batch.success = batch.errors < self.tolerance
        return batch
