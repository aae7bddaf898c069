"""A planar N-DoF arm pushing a cylinder on a table, simulated headless in PyBullet.

Simulation
----------
* PyBullet in DIRECT mode (no GUI, no display), one physics client per :class:`PlanarArmSim`; every
  call passes ``physicsClientId`` so several simulators can live in one process.
* Physics time step ``sim_dt`` = 1/200 s; ``substeps`` = 2 physics steps per control step, so the
  control rate is 100 Hz (``control_dt`` = 0.01 s). A 300-step trajectory lasts 3 s of simulated time.
* Position control: each trajectory row is the joint target (rad) for one control step, sent with a
  finite-difference velocity feed-forward, PD gains ``position_gain``/``velocity_gain`` and a force
  limit ``max_force`` (N m).
* The world is reset before every roll-out: the arm to the trajectory's first row (clipped), the
  cylinder to its start (plus optional seeded noise), all velocities to zero, and the contact cache
  cleared by restoring a saved state, so a roll-out depends only on its inputs (and, with noise, on the
  seed and the number of roll-outs run before it).

A 300-step roll-out is 600 physics steps; ``benchmarks/performance/bench_tasks.py`` measures its cost.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from .quiet_pybullet import pybullet as p

from ..validation import check_array
from .physics import PhysicsClient
from .urdf import ArmGeometry, write_planar_arm_urdf

#: Default link lengths (m) of the project's planar arms.
DEFAULT_LINK_LENGTHS = {3: (0.30, 0.30, 0.12), 4: (0.25, 0.22, 0.15, 0.10)}


def default_geometry(n_joints: int = 3, link_lengths=None, joint_limits=None) -> ArmGeometry:
    """An :class:`ArmGeometry` for an ``n_joints`` arm.

    Defaults: link lengths from :data:`DEFAULT_LINK_LENGTHS` (else 0.6 m split evenly), joint 1 in
    [-pi, pi], every other joint in [-2.8, 2.8] rad (about +-160 deg, so a link cannot fold onto the
    previous one).
    """
    if link_lengths is None:
        link_lengths = DEFAULT_LINK_LENGTHS.get(n_joints, tuple([0.6 / n_joints] * n_joints))
    if joint_limits is None:
        joint_limits = [(-np.pi, np.pi)] + [(-2.8, 2.8)] * (len(link_lengths) - 1)
    return ArmGeometry(link_lengths=tuple(link_lengths), joint_limits=tuple(map(tuple, joint_limits)))


@dataclass(frozen=True)
class PushObject:
    """The pushable cylinder: start position on the table (m), radius and height (m), mass (kg)."""

    start_xy: tuple[float, float] = (0.35, 0.0)
    radius: float = 0.03
    height: float = 0.06
    mass: float = 0.2
    lateral_friction: float = 0.5
    spinning_friction: float = 0.001


class PlanarArmSim(PhysicsClient):
    """One PyBullet world: table plane, planar arm, pushable cylinder.

    Parameters
    ----------
    geometry : the arm (:func:`default_geometry` by default, 3 DoF).
    obj : the cylinder (:class:`PushObject`).
    sim_dt : physics time step (s).
    substeps : physics steps per control step; control period = ``sim_dt * substeps``.
    position_gain, velocity_gain, max_force : joint position-controller gains and force limit (N m).
    solver_iterations : constraint-solver iterations per physics step (fewer is faster; 30 keeps
        the paddle-cylinder contact stiff enough at these speeds).
    object_noise : std (m) of Gaussian noise added to the cylinder's start per roll-out (0: none).
    seed : seeds the noise generator.
    """

    def __init__(
        self,
        geometry: ArmGeometry | None = None,
        obj: PushObject | None = None,
        *,
        sim_dt: float = 1.0 / 200.0,
        substeps: int = 2,
        position_gain: float = 0.5,
        velocity_gain: float = 1.0,
        max_force: float = 50.0,
        solver_iterations: int = 30,
        object_noise: float = 0.0,
        seed: int = 0,
    ) -> None:
        self.geometry = geometry if geometry is not None else default_geometry(3)
        self.obj = obj if obj is not None else PushObject()
        self.sim_dt = float(sim_dt)
        self.substeps = int(substeps)
        self.control_dt = self.sim_dt * self.substeps
        self.position_gain, self.velocity_gain, self.max_force = position_gain, velocity_gain, max_force
        self.object_noise = float(object_noise)
        self.rng = np.random.default_rng(seed)
        self.limits = np.asarray(self.geometry.joint_limits, dtype=np.float64)
        self._cid: int | None = p.connect(p.DIRECT)
        cid = self._cid
        p.setGravity(0, 0, -9.81, physicsClientId=cid)
        p.setPhysicsEngineParameter(fixedTimeStep=self.sim_dt, numSolverIterations=solver_iterations,
                                    deterministicOverlappingPairs=1, physicsClientId=cid)
        plane = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid)
        self.table = p.createMultiBody(0, plane, physicsClientId=cid)
        p.changeDynamics(self.table, -1, lateralFriction=self.obj.lateral_friction, physicsClientId=cid)
        self.arm = p.loadURDF(str(write_planar_arm_urdf(self.geometry)), [0, 0, 0], useFixedBase=True,
                              physicsClientId=cid)
        self.joints = list(range(self.geometry.n_joints))
        self.ee_link = self.geometry.n_joints  # the fixed paddle link follows the N revolute joints
        # Low paddle friction: the push force then acts through the cylinder's centre, keeping pushes straight.
        p.changeDynamics(self.arm, self.ee_link, lateralFriction=0.1, physicsClientId=cid)
        for j in self.joints:
            # Disable the default velocity motors so only our position targets drive the joints.
            p.setJointMotorControl2(self.arm, j, p.VELOCITY_CONTROL, force=0, physicsClientId=cid)
        col = p.createCollisionShape(p.GEOM_CYLINDER, radius=self.obj.radius, height=self.obj.height,
                                     physicsClientId=cid)
        vis = p.createVisualShape(p.GEOM_CYLINDER, radius=self.obj.radius, length=self.obj.height,
                                  rgbaColor=[0.8, 0.1, 0.1, 1], physicsClientId=cid)
        self.object = p.createMultiBody(self.obj.mass, col, vis, self._object_pose(self.obj.start_xy),
                                        physicsClientId=cid)
        p.changeDynamics(self.object, -1, lateralFriction=self.obj.lateral_friction,
                         spinningFriction=self.obj.spinning_friction, rollingFriction=0.0,
                         physicsClientId=cid)
        # Let the cylinder settle on the table once, so the broadphase pairs and contact cache exist
        # before the state is saved: every roll-out (the first included) then starts from the same cache.
        for _ in range(10):
            p.stepSimulation(physicsClientId=cid)
        p.resetBasePositionAndOrientation(self.object, self._object_pose(self.obj.start_xy), [0, 0, 0, 1],
                                          physicsClientId=cid)
        p.resetBaseVelocity(self.object, [0, 0, 0], [0, 0, 0], physicsClientId=cid)
        # A saved state restores positions, velocities and the contact cache: resets are bit-exact.
        self._initial_state = p.saveState(physicsClientId=cid)

    # ------------------------------------------------------------------ helpers
    @property
    def n_joints(self) -> int:
        return self.geometry.n_joints

    def _object_pose(self, xy) -> list[float]:
        return [float(xy[0]), float(xy[1]), self.obj.height / 2]

    def check_trajectory(self, trajectory, name: str = "trajectory") -> np.ndarray:
        """Validate a (T, N) joint trajectory (rad) and clip it into the joint limits.

        Raises ValueError naming ``name`` for a wrong shape, a joint-count mismatch, or NaN/inf.
        Targets past a joint limit are clipped to that limit (the real robot's controller would
        saturate the same way); the clip is silent because exploration noise hits limits routinely.
        """
        traj = check_array(name, trajectory, ndim=2, min_size=1)
        if traj.shape[1] != self.n_joints:
            raise ValueError(f"{name}: expected {self.n_joints} joint angles per row (a {self.n_joints}-DoF arm), "
                             f"got {traj.shape[1]}")
        return np.clip(traj, self.limits[:, 0], self.limits[:, 1])

    def reset(self, q0) -> np.ndarray:
        """Reset the world: arm at ``q0`` (N,) at rest, cylinder at its start. Returns the object start (2,)."""
        cid = self.client_id
        p.restoreState(self._initial_state, physicsClientId=cid)
        for j, qj in zip(self.joints, q0):
            p.resetJointState(self.arm, j, float(qj), 0.0, physicsClientId=cid)
        start = np.asarray(self.obj.start_xy, dtype=np.float64)
        if self.object_noise > 0:
            start = start + self.rng.normal(0.0, self.object_noise, size=2)
        p.resetBasePositionAndOrientation(self.object, self._object_pose(start), [0, 0, 0, 1], physicsClientId=cid)
        p.resetBaseVelocity(self.object, [0, 0, 0], [0, 0, 0], physicsClientId=cid)
        return start

    # ------------------------------------------------------------------ roll-out
    def rollout(self, trajectory) -> dict[str, np.ndarray]:
        """Execute one joint trajectory and record the executed states.

        Parameters
        ----------
        trajectory : (T, N) joint targets (rad), one row per control step (``control_dt`` apart).
            The arm starts at rest at the first row; targets are clipped into the joint limits.

        Returns
        -------
        dict with, per control step (after the step's physics):
            ``joint_angles`` (T, N) rad, ``ee_xy`` (T, 2) m (paddle centre line at the tip),
            ``ee_yaw`` (T,) rad, ``object_xy`` (T, 2) m, ``object_start`` (2,) m.
        """
        traj = self.check_trajectory(trajectory)
        t_len, n = traj.shape
        start = self.reset(traj[0])
        # Velocity feed-forward from finite differences reduces the position controller's lag.
        vel = np.zeros_like(traj)
        vel[1:] = np.diff(traj, axis=0) / self.control_dt
        q_out = np.empty((t_len, n))
        ee_xy = np.empty((t_len, 2))
        ee_yaw = np.empty(t_len)
        obj_xy = np.empty((t_len, 2))
        for k in range(t_len):
            q_out[k], obj_xy[k] = self.control_step(traj[k], vel[k])
        # The tip pose follows from the measured joint angles exactly (the arm is rigid and planar):
        # computing it here is cheaper than a getLinkState call per step.
        cum = np.cumsum(q_out, axis=1)
        lengths = np.asarray(self.geometry.link_lengths)
        ee_xy[:, 0] = np.cos(cum) @ lengths
        ee_xy[:, 1] = np.sin(cum) @ lengths
        ee_yaw[:] = cum[:, -1]
        return {"joint_angles": q_out, "ee_xy": ee_xy, "ee_yaw": ee_yaw, "object_xy": obj_xy, "object_start": start}

    def control_step(self, target: np.ndarray, target_velocity: np.ndarray) -> tuple[list[float], tuple[float, float]]:
        """One control step from the current state: joint targets (N,) rad and their velocities (N,)
        rad/s to the position controller, ``substeps`` physics steps; returns the joint angles (N,)
        and the cylinder's (x, y) m after it. :meth:`reset` first; targets are used as given (clip
        them with :meth:`check_trajectory`)."""
        cid, n = self.client_id, self.n_joints
        p.setJointMotorControlArray(self.arm, self.joints, p.POSITION_CONTROL, targetPositions=list(map(float, target)),
                                    targetVelocities=list(map(float, target_velocity)),
                                    positionGains=[self.position_gain] * n, velocityGains=[self.velocity_gain] * n,
                                    forces=[self.max_force] * n, physicsClientId=cid)
        for _ in range(self.substeps):
            p.stepSimulation(physicsClientId=cid)
        states = p.getJointStates(self.arm, self.joints, physicsClientId=cid)
        return [s[0] for s in states], p.getBasePositionAndOrientation(self.object, physicsClientId=cid)[0][:2]

    def ee_pose_from_sim(self) -> np.ndarray:
        """(3,) the paddle link's current ``[x, y, yaw]`` read from PyBullet (for checks against the FK)."""
        cid = self.client_id
        pos, orn = p.getLinkState(self.arm, self.ee_link, computeForwardKinematics=True, physicsClientId=cid)[4:6]
        yaw = p.getEulerFromQuaternion(orn)[2]
        return np.array([pos[0], pos[1], yaw])
