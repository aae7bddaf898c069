"""A UR10 with a two-finger gripper picking a box over an obstacle, simulated headless in PyBullet.

Robot
-----
The UR10 of ``example-robot-data`` (real link geometry, inertias, STL collision meshes as convex
hulls, joint position limits read from the URDF) with the simple parallel gripper of
:mod:`~acnmp_core.sim.ur10_description` on its flange, loaded as one fixed-base multibody. The
robot's base stands on the table top (z = 0) at the world origin. Self-collision is off (PyBullet's
default): pick-and-place paths never fold the arm onto itself, and the checks would cost time.

Scene (:class:`PickPlaceScene`)
-------------------------------
A static table box (top at z = 0), a box to pick (footprint ``object_size``, height ``h_obj``, mass
``object_mass``) at ``pick_xy``, a static wall-like obstacle (footprint ``obstacle_size``, height
``h_obs``) at ``obstacle_xy``, long across the straight pick-to-place line so it cannot be passed
beside, and a place position ``place_xy`` on the other side. The heights are set per roll-out batch
with :meth:`UR10Sim.set_heights`; the object and the obstacle are rebuilt only when they change.

Grasp
-----
Physical, by contact and friction only: closing drives both finger joints towards the centre with
their force limit (``GripperGeometry.finger_effort``, 40 N each), so a box between the fingers is
squeezed and lifted by friction (coefficient ``friction`` = 1 on fingers and box). Nothing attaches
the object to the gripper; the one constraint in the world is a gear coupling the two finger joints
to each other, the single drive of a real parallel gripper (without it both finger motors saturate
on a held box and the pair drifts sideways under load). A box that is missed, hit by the palm
(the fingers reach only ``finger_length`` = 3.5 cm below it) or pinched at an edge slips, topples
or stays behind in the simulation as it would in reality.

Control
-------
* Position control of the six arm joints following a (T, 6) joint trajectory (rad), one row per
  control step of ``control_dt`` = 8 ms (125 Hz, the UR's controller rate; the project's 625-step
  trajectories last 5 s), with a finite-difference velocity feed-forward and the URDF's effort
  limits as force limits; between rows the target is interpolated at every physics step, so the
  executed joint angles follow a feasible commanded path within about 0.01 deg. Targets outside the
  joint limits are clipped into them. Joint velocity limits are not enforced (a real UR would
  stop); the expert keeps below them.
* The gripper is not part of the learnt output: :meth:`UR10Sim.rollout` takes a (T,) boolean
  schedule (closed or open per step) that the task derives from the trajectory's phase.

Physics settings (the :class:`UR10Sim` defaults, chosen for speed): physics step 4 ms (2 substeps
per control step; with one 8 ms step the held box slips out), 20 solver iterations (10 also hold
the box, 20 leave a margin), box collision shapes for the gripper, PyBullet's convex hulls of the
arm's STL meshes, the arm's COLLADA visuals not loaded, the base link's contact with the table
filtered out. A 625-step roll-out (1250 physics steps) takes about 0.1-0.2 s on the development
machine; ``benchmarks/performance/bench_ur10_rollout.py`` measures it.

Determinism: the world is reset before every roll-out by restoring a saved state (positions,
velocities and the contact cache), then setting the arm to the trajectory's first row, so a roll-out
depends only on its inputs and the heights.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from .quiet_pybullet import pybullet as p

from ..validation import check_array
from .physics import PhysicsClient
from .ur10_description import FINGER_JOINTS, TCP_LINK, UR10_ARM_JOINTS, GripperGeometry, write_ur10_gripper_urdf

#: The authors' start pose (deg) of their UR10 demonstrations, in :data:`UR10_ARM_JOINTS` order.
START_POSE_DEG = (-32.0, -53.3, 52.9, -88.1, -90.9, 13.7)


@dataclass(frozen=True)
class PickPlaceScene:
    """Where things stand on the table (metres, kilograms); the heights are set per roll-out.

    Attributes
    ----------
    pick_xy, place_xy : the object's start and the place position (its centre).
    obstacle_xy : the obstacle's centre, between the two.
    object_size : (x, y) footprint of the box to pick.
    object_mass : its mass.
    obstacle_size : (x, y) footprint of the obstacle; x across the carrying direction.
    table_size : (x, y, thickness) of the table; its top is at z = 0.
    table_center_xy : centre of the table top.
    friction : lateral friction of the fingers, the object and the table.
    """

    pick_xy: tuple[float, float] = (0.75, -0.25)
    place_xy: tuple[float, float] = (0.75, 0.25)
    obstacle_xy: tuple[float, float] = (0.75, 0.0)
    object_size: tuple[float, float] = (0.04, 0.04)
    object_mass: float = 0.1
    obstacle_size: tuple[float, float] = (0.30, 0.04)
    table_size: tuple[float, float, float] = (1.6, 1.6, 0.04)
    table_center_xy: tuple[float, float] = (0.5, 0.0)
    friction: float = 1.0


def _check_height(name: str, value, lo: float, hi: float) -> float:
    v = float(check_array(name, value, shape=()))
    if not lo <= v <= hi:
        raise ValueError(f"{name}: expected a height in [{lo}, {hi}] m, got {v}")
    return v


class UR10Sim(PhysicsClient):
    """One PyBullet world: table, UR10 with gripper, object, obstacle.

    Parameters
    ----------
    scene : the layout (:class:`PickPlaceScene`).
    gripper : the gripper (:class:`~acnmp_core.sim.ur10_description.GripperGeometry`).
    control_dt : control period (s); one trajectory row per control step.
    substeps : physics steps per control step (physics step = ``control_dt / substeps``).
    position_gain, velocity_gain : PyBullet position-motor gains of the arm joints.
    solver_iterations : constraint-solver iterations per physics step.
    """

    def __init__(
        self,
        scene: PickPlaceScene | None = None,
        gripper: GripperGeometry | None = None,
        *,
        control_dt: float = 1.0 / 125.0,
        substeps: int = 2,
        position_gain: float = 0.3,
        velocity_gain: float = 1.0,
        solver_iterations: int = 20,
    ) -> None:
        if not control_dt > 0:
            raise ValueError(f"control_dt: expected a positive period (s), got {control_dt!r}")
        if int(substeps) < 1:
            raise ValueError(f"substeps: expected an integer >= 1, got {substeps!r}")
        self.scene = scene if scene is not None else PickPlaceScene()
        self.gripper = gripper if gripper is not None else GripperGeometry()
        self.control_dt = float(control_dt)
        self.substeps = int(substeps)
        self.sim_dt = self.control_dt / self.substeps
        self.position_gain, self.velocity_gain = float(position_gain), float(velocity_gain)
        self._cid: int | None = p.connect(p.DIRECT)
        cid = self._cid
        p.setGravity(0, 0, -9.81, physicsClientId=cid)
        p.setPhysicsEngineParameter(fixedTimeStep=self.sim_dt, numSolverIterations=int(solver_iterations),
                                    deterministicOverlappingPairs=1, physicsClientId=cid)
        sc = self.scene
        tx, ty, tz = sc.table_size
        table_col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[tx / 2, ty / 2, tz / 2], physicsClientId=cid)
        self.table = p.createMultiBody(0, table_col, basePosition=[*sc.table_center_xy, -tz / 2],
                                       physicsClientId=cid)
        p.changeDynamics(self.table, -1, lateralFriction=sc.friction, physicsClientId=cid)
        self.robot = p.loadURDF(str(write_ur10_gripper_urdf(self.gripper)), [0, 0, 0], useFixedBase=True,
                                flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=cid)
        names = {}
        links = {}
        for j in range(p.getNumJoints(self.robot, physicsClientId=cid)):
            info = p.getJointInfo(self.robot, j, physicsClientId=cid)
            names[info[1].decode()] = j
            links[info[12].decode()] = j
        self.arm_joints = [names[n] for n in UR10_ARM_JOINTS]
        self.finger_joints = [names[n] for n in FINGER_JOINTS]
        self.tcp_link = links[TCP_LINK]
        infos = [p.getJointInfo(self.robot, j, physicsClientId=cid) for j in self.arm_joints]
        #: (6, 2) joint position limits (rad) from the URDF.
        self.limits = np.array([[i[8], i[9]] for i in infos], dtype=np.float64)
        #: (6,) joint velocity limits (rad/s) and efforts (N m) from the URDF.
        self.velocity_limits = np.array([i[11] for i in infos], dtype=np.float64)
        self.efforts = np.array([i[10] for i in infos], dtype=np.float64)
        # The base link rests on the table for ever: its contact would only cost solver time.
        p.setCollisionFilterPair(self.robot, self.table, links["base_link"], -1, 0, physicsClientId=cid)
        for j in self.arm_joints + self.finger_joints:
            # Disable the default velocity motors so only our position targets drive the joints.
            p.setJointMotorControl2(self.robot, j, p.VELOCITY_CONTROL, force=0, physicsClientId=cid)
        for link in [links["finger_left"], links["finger_right"]]:
            p.changeDynamics(self.robot, link, lateralFriction=sc.friction, physicsClientId=cid)
        # The fingers move as one mechanism (a real parallel gripper has one drive): without this
        # gear both finger motors saturate on a held object and the pair drifts sideways under load.
        gear = p.createConstraint(self.robot, self.finger_joints[0], self.robot, self.finger_joints[1],
                                  p.JOINT_GEAR, [1, 0, 0], [0, 0, 0], [0, 0, 0], physicsClientId=cid)
        p.changeConstraint(gear, gearRatio=-1, maxForce=200, erp=0.2, physicsClientId=cid)
        self.object: int | None = None
        self.obstacle: int | None = None
        self._state: int | None = None
        self.heights: tuple[float, float] | None = None
        self.start_pose = np.deg2rad(np.asarray(START_POSE_DEG))

    # ------------------------------------------------------------------ helpers
    @property
    def open_width(self) -> float:
        """Finger joint value (m) of the open gripper: the inner faces' distance from the centre."""
        return self.gripper.finger_travel * 0.8

    def set_heights(self, h_obj, h_obs) -> None:
        """Set the object's and the obstacle's heights (m); rebuilds them and the saved start state
        only when they change. Heights must lie in [0.005, 0.5] m."""
        h_obj = _check_height("h_obj", h_obj, 0.005, 0.5)
        h_obs = _check_height("h_obs", h_obs, 0.005, 0.5)
        if self.heights == (h_obj, h_obs):
            return
        cid = self.client_id
        for body in (self.object, self.obstacle):
            if body is not None:
                p.removeBody(body, physicsClientId=cid)
        if self._state is not None:
            p.removeState(self._state, physicsClientId=cid)
        sc = self.scene
        ox, oy = sc.object_size
        col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[ox / 2, oy / 2, h_obj / 2], physicsClientId=cid)
        self.object = p.createMultiBody(sc.object_mass, col, basePosition=self._object_start(h_obj),
                                        physicsClientId=cid)
        p.changeDynamics(self.object, -1, lateralFriction=sc.friction, spinningFriction=0.001,
                         rollingFriction=0.0, physicsClientId=cid)
        bx, by = sc.obstacle_size
        col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[bx / 2, by / 2, h_obs / 2], physicsClientId=cid)
        self.obstacle = p.createMultiBody(0, col, basePosition=[*sc.obstacle_xy, h_obs / 2], physicsClientId=cid)
        # Settle once so the broadphase pairs and the box-table contact cache exist before the state
        # is saved: every roll-out (the first included) then starts from the same cache.
        self._pose_robot(self.start_pose)
        for _ in range(10):
            p.stepSimulation(physicsClientId=cid)
        self._place_object(h_obj)
        self._pose_robot(self.start_pose)
        self._state = p.saveState(physicsClientId=cid)
        self.heights = (h_obj, h_obs)

    def _object_start(self, h_obj: float) -> list[float]:
        return [*self.scene.pick_xy, h_obj / 2]

    def _place_object(self, h_obj: float) -> None:
        cid = self.client_id
        p.resetBasePositionAndOrientation(self.object, self._object_start(h_obj), [0, 0, 0, 1], physicsClientId=cid)
        p.resetBaseVelocity(self.object, [0, 0, 0], [0, 0, 0], physicsClientId=cid)

    def _pose_robot(self, q, finger: float | None = None) -> None:
        cid = self.client_id
        for j, qj in zip(self.arm_joints, q):
            p.resetJointState(self.robot, j, float(qj), 0.0, physicsClientId=cid)
        w = self.open_width if finger is None else finger
        for j in self.finger_joints:
            p.resetJointState(self.robot, j, w, 0.0, physicsClientId=cid)

    def check_trajectory(self, trajectory, name: str = "trajectory") -> np.ndarray:
        """Validate a (T, 6) joint trajectory (rad) and clip it into the URDF's joint limits.

        Raises ValueError naming ``name`` for a wrong shape or NaN/inf. The clip is silent: the
        real controller saturates the same way and exploration noise reaches limits routinely.
        """
        traj = check_array(name, trajectory, ndim=2, min_size=1)
        if traj.shape[1] != 6:
            raise ValueError(f"{name}: expected 6 joint angles per row (the UR10's arm joints), got {traj.shape[1]}")
        return np.clip(traj, self.limits[:, 0], self.limits[:, 1])

    def reset(self, q0) -> None:
        """Reset the world: arm at ``q0`` (6,) rad at rest with the gripper open, the object at rest
        at ``pick_xy``. :meth:`set_heights` must have been called."""
        if self._state is None:
            raise RuntimeError("UR10Sim: call set_heights(h_obj, h_obs) before a roll-out")
        p.restoreState(self._state, physicsClientId=self.client_id)
        self._pose_robot(q0)

    # ------------------------------------------------------------------ kinematics
    def tcp_pose(self, q) -> tuple[np.ndarray, np.ndarray]:
        """Forward kinematics of the TCP at arm configuration ``q`` (6,) rad.

        Returns position (3,) m and rotation matrix (3, 3) (columns: the TCP's x, y, z axes in the
        world frame). Moves the simulated arm; the next :meth:`reset` restores the world.
        """
        q = check_array("q", q, shape=(6,))
        cid = self.client_id
        for j, qj in zip(self.arm_joints, q):
            p.resetJointState(self.robot, j, float(qj), 0.0, physicsClientId=cid)
        pos, orn = p.getLinkState(self.robot, self.tcp_link, computeForwardKinematics=True,
                                  physicsClientId=cid)[4:6]
        return np.asarray(pos), np.asarray(p.getMatrixFromQuaternion(orn)).reshape(3, 3)

    def inverse_kinematics(self, position, rotation, q0, *, iters: int = 100, damping: float = 1e-4,
                           tol: float = 1e-7) -> np.ndarray:
        """Damped least-squares IK of the TCP pose, started from ``q0``.

        Parameters
        ----------
        position : (3,) target TCP position (m).
        rotation : (3, 3) target TCP rotation matrix (world frame).
        q0 : (6,) initial guess (rad); warm-starting from the previous waypoint keeps a path smooth.
        iters, damping, tol : solver iterations, Levenberg damping, and the pose error to stop at
            (metres and radians stacked).

        Returns
        -------
        (6,) joint angles within the joint limits. Raises ValueError if the pose error stays above
        1 mm / 0.01 rad (out of reach).
        """
        target = check_array("position", position, shape=(3,))
        rot_d = check_array("rotation", rotation, shape=(3, 3))
        q = check_array("q0", q0, shape=(6,)).copy()
        cid = self.client_id
        fingers = [self.open_width] * len(self.finger_joints)
        # PyBullet's Jacobian takes every movable joint, in index order; the fingers follow the arm.
        for _ in range(iters):
            pos, rot = self.tcp_pose(q)
            # Orientation error as a rotation vector (small-angle), from the axes' cross products.
            err = np.concatenate([target - pos, 0.5 * np.cross(rot, rot_d, axis=0).sum(axis=1)])
            if np.linalg.norm(err) < tol:
                break
            lin, ang = p.calculateJacobian(self.robot, self.tcp_link, [0.0, 0.0, 0.0], [*q.tolist(), *fingers],
                                           [0.0] * 8, [0.0] * 8, physicsClientId=cid)
            jac = np.vstack([np.asarray(lin)[:, :6], np.asarray(ang)[:, :6]])
            dq = jac.T @ np.linalg.solve(jac @ jac.T + damping * np.eye(6), err)
            q = np.clip(q + dq, self.limits[:, 0], self.limits[:, 1])
        pos, rot = self.tcp_pose(q)
        rot_err = np.linalg.norm(0.5 * np.cross(rot, rot_d, axis=0).sum(axis=1))
        if np.linalg.norm(target - pos) > 1e-3 or rot_err > 1e-2:
            raise ValueError(f"position: the TCP pose at {np.round(target, 3).tolist()} is out of reach "
                             f"(IK residual {np.linalg.norm(target - pos):.4f} m, {rot_err:.4f} rad)")
        return q

    # ------------------------------------------------------------------ roll-out
    def rollout(self, trajectory, gripper_closed) -> dict[str, np.ndarray]:
        """Execute one joint trajectory with a gripper schedule and record the executed states.

        Parameters
        ----------
        trajectory : (T, 6) arm joint targets (rad), one row per control step (``control_dt`` apart).
            The arm starts at rest at the first row; targets are clipped into the joint limits.
        gripper_closed : (T,) bool, the gripper's command per step (True: close, False: open).

        Returns
        -------
        dict with, per control step (after the step's physics):
            ``joint_angles`` (T, 6) rad, ``finger_opening`` (T,) m (mean finger joint value: the
            inner faces' distance from the centre), ``tcp_xyz`` (T, 3) m, ``object_xyz`` (T, 3) m,
            ``object_quat`` (T, 4) (x, y, z, w), ``obstacle_contact`` (T,) bool (anything touches
            the obstacle), ``finger_contacts`` (T,) int (how many fingers touch the object).
        """
        traj = self.check_trajectory(trajectory)
        t_len = traj.shape[0]
        closed = np.asarray(gripper_closed)
        if closed.shape != (t_len,):
            raise ValueError(f"gripper_closed: expected shape ({t_len},), got {closed.shape}")
        closed = closed.astype(bool)
        cid = self.client_id
        self.reset(traj[0])
        # Velocity feed-forward from finite differences reduces the position controller's lag.
        vel = np.zeros_like(traj)
        vel[1:] = np.diff(traj, axis=0) / self.control_dt
        out = {
            "joint_angles": np.empty((t_len, 6)),
            "finger_opening": np.empty(t_len),
            "tcp_xyz": np.empty((t_len, 3)),
            "object_xyz": np.empty((t_len, 3)),
            "object_quat": np.empty((t_len, 4)),
            "obstacle_contact": np.zeros(t_len, dtype=bool),
            "finger_contacts": np.zeros(t_len, dtype=np.int64),
        }
        robot, joints, fingers = self.robot, self.arm_joints, self.finger_joints
        kp, kd, forces = [self.position_gain] * 6, [self.velocity_gain] * 6, self.efforts.tolist()
        f_force = [self.gripper.finger_effort] * 2
        f_links = set(fingers)  # a finger's link index equals its joint index
        all_joints = joints + fingers
        state = None
        prev = traj[0]
        for k in range(t_len):
            if closed[k] != state:  # the finger motors keep their last command
                state = bool(closed[k])
                target = 0.0 if state else self.open_width
                p.setJointMotorControlArray(robot, fingers, p.POSITION_CONTROL, targetPositions=[target] * 2,
                                            forces=f_force, positionGains=[0.2] * 2, velocityGains=[1.0] * 2,
                                            physicsClientId=cid)
            # The path is interpolated between rows at every physics step, as a UR's servo loop
            # does. PyBullet's motor solves for the velocity at the end of a physics step, so it
            # reaches the target it is given plus the feed-forward velocity times the step: giving it
            # the path's point at the step's start lands the joint on the path at the step's end.
            # (Holding the row's own target would make the arm lead the commanded path by a step.)
            for j in range(self.substeps):
                target = prev + (traj[k] - prev) * (j / self.substeps)
                p.setJointMotorControlArray(robot, joints, p.POSITION_CONTROL, targetPositions=target.tolist(),
                                            targetVelocities=vel[k].tolist(), positionGains=kp, velocityGains=kd,
                                            forces=forces, physicsClientId=cid)
                p.stepSimulation(physicsClientId=cid)
            prev = traj[k]
            js = p.getJointStates(robot, all_joints, physicsClientId=cid)
            out["joint_angles"][k] = [s[0] for s in js[:6]]
            out["finger_opening"][k] = 0.5 * (js[6][0] + js[7][0])
            out["tcp_xyz"][k] = p.getLinkState(robot, self.tcp_link, computeForwardKinematics=True,
                                               physicsClientId=cid)[4]
            pos, orn = p.getBasePositionAndOrientation(self.object, physicsClientId=cid)
            out["object_xyz"][k] = pos
            out["object_quat"][k] = orn
            out["obstacle_contact"][k] = len(p.getContactPoints(bodyA=self.obstacle, physicsClientId=cid)) > 0
            touching = {c[4] for c in p.getContactPoints(bodyA=self.object, bodyB=robot, physicsClientId=cid)}
            out["finger_contacts"][k] = len(touching & f_links)
        return out
