"""A pouring rig simulated headless in PyBullet: a cup of marbles on a wrist joint, a receiving cup.

Scene (metres and kilograms inside PyBullet; grams at the interface)
--------------------------------------------------------------------
* The **wrist** is one revolute joint about +y at height ``axis_height`` above the floor, at x = 0.
  A positive angle turns the cup's mouth towards +x, where the receiving cup stands.
* The **cup** is the wrist's only link, a compound of convex boxes: a base, a back wall, two side
  walls, a pour-side wall that leans outwards by ``flare`` (35 deg; like a jug's spout side) and a lip that
  reaches inwards from the pour-side rim, sloping up towards the mouth like a funnel. The wrist axis
  runs along the pour-side rim, so the mouth stays near the axis while the cup turns over it.
  With the cup near 90 deg the lip is a dam and the marbles pile up behind it at their angle of
  repose: the 85-95 deg expert pours only the part of the load above that pile. Turned well past
  90 deg (about 150 deg and more) the lip becomes a chute and the cup empties. The cup's own mass is
  the tare.
* The **marbles** are glass-like spheres (radius 1.35 cm, 25 g by default). Their number follows from
  the initial weight: ``(weight - tare) / marble mass``, rounded half up (75 g tare: 650 g holds 23
  marbles, 1200 g 45, 1400 g 53).
* The **receiving cup** is four static walls on the floor below and beside the wrist; the floor is
  its bottom. A marble counts as poured when its centre lies inside the walls and below their top;
  marbles on the floor outside, or still in the pouring cup, count as not poured.

Simulation
----------
* DIRECT mode, one physics client per :class:`PourSim` (one world per marble count); every call
  passes ``physicsClientId``.
* The marbles start on a jittered grid (a fixed seed) in the upright cup and settle once
  (``initial_settle_time``); their settled centres are the snapshot for that marble count. Every
  roll-out rebuilds the world from scratch (``resetSimulation``, about 30 ms) with the marbles at
  rest at the snapshot, so a trajectory gives bit-identical results every time, in any process.
  ``saveState``/``restoreState`` is not enough here: it restores positions and velocities exactly,
  but contact manifolds left over from the previous roll-out (pairs the saved state did not have)
  survive it and change the first solver steps, and a pile of marbles amplifies that into a
  different pour.
* Each trajectory row is the wrist's position target (rad) for one control step: ``control_dt`` =
  ``substeps`` x ``sim_dt`` = 4 x 1/240 s, i.e. 60 Hz. After the last row the wrist holds that target
  while the marbles settle (at most ``settle_time``, stopping early once every marble is slower than
  ``settle_speed``), then the poured mass is read.
* Speed: few, big marbles (53 at 1400 g) and 10 solver iterations (PyBullet's default is 50) keep
  the contact count and the solver cheap; the settling after the motion stops as soon as the
  marbles are at rest (``benchmarks/performance/bench_pour.py`` measures a roll-out's cost).

Behaviour worth knowing
-----------------------
Poured mass comes in whole marbles (25 g). Near 90 deg granular flow is partly chaotic: a small
change of a held tilt can change the pour by a marble or more (benchmarks/studies/e6_pour/README.md, "The rig's
sensitivity", measures it). Past ~120 deg the outcome is stable; at 1400 g, tilting 150 deg or
more pours all 53 marbles (1325 g). A swing much faster than the expert's throws marbles past the receiving cup.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from .quiet_pybullet import pybullet as p

from ..validation import check_array
from .physics import PhysicsClient

G_PER_KG = 1000.0

Box = tuple[tuple[float, float, float], tuple[float, float, float], float]  # half extents, centre, pitch (rad)


@dataclass(frozen=True)
class CupGeometry:
    """The pouring cup (m, deg, g).

    Attributes
    ----------
    inner_width : cavity size along x, the pouring direction, at the rim.
    inner_depth : cavity size along y, the wrist axis.
    inner_height : cavity height from the base's top to the rim.
    wall : thickness of the base and the walls.
    flare : how far the pour-side wall leans outwards from vertical (deg): with the cup on its side
        that wall is the floor, and the flare makes it slope down to the mouth; the steeper that
        floor, the steadier a pour near 90 deg (benchmarks/studies/e6_pour/README.md).
    lip : how far the pour-side lip reaches inwards from the wall: the dam's height at 90 deg.
    lip_angle : the lip's slope (deg), rising inwards towards the mouth, so that past about
        180 - lip_angle deg it is a chute towards the mouth rather than a ledge.
    lip_thickness : the lip's thickness.
    tare_g : the empty cup's mass (g).
    """

    inner_width: float = 0.14
    inner_depth: float = 0.12
    inner_height: float = 0.10
    wall: float = 0.01
    flare: float = 35.0
    lip: float = 0.03
    lip_angle: float = 35.0
    lip_thickness: float = 0.01
    tare_g: float = 75.0

    def __post_init__(self) -> None:
        for name in ("inner_width", "inner_depth", "inner_height", "wall", "lip_thickness", "tare_g"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name}: expected a positive value, got {getattr(self, name)!r}")
        if not 0 <= self.flare < 60:
            raise ValueError(f"flare: expected an angle in [0, 60) deg, got {self.flare!r}")
        if not 0 <= self.lip_angle < 60:
            raise ValueError(f"lip_angle: expected an angle in [0, 60) deg, got {self.lip_angle!r}")
        if not 0 <= self.lip < self.inner_width / 2:
            raise ValueError(f"lip: expected a reach in [0, inner_width / 2), got {self.lip!r}")

    def pour_wall_x(self, depth) -> np.ndarray:
        """x (m, wrist frame) of the pour-side wall's inner face ``depth`` (m) below the rim."""
        return -self.wall - np.asarray(depth) * np.tan(np.deg2rad(self.flare))

    @property
    def lip_drop(self) -> float:
        """How far below the rim the lip's low end reaches (m)."""
        if self.lip <= 0:
            return 0.0
        phi = np.deg2rad(self.lip_angle)
        return float(self.lip * np.tan(phi) + self.lip_thickness / np.cos(phi))


@dataclass(frozen=True)
class ReceiverGeometry:
    """The receiving cup (m): walls of ``wall_height`` standing on the floor around the inner area
    ``x_range`` x ``(-half_y, half_y)``.

    Big enough to catch what the expert pours even with a stiffer wrist or twice as fast a tilt;
    a swing much faster than that throws marbles past it (a spill, which the reward then counts).
    """

    x_range: tuple[float, float] = (-0.06, 0.36)
    half_y: float = 0.18
    wall_height: float = 0.09
    wall: float = 0.02


@dataclass(frozen=True)
class MarbleSpec:
    """One marble: radius (m), mass (g) and contact properties (PyBullet's coefficients).

    The defaults are a glass marble (density about 2.4 g/cm^3); restitution 0 keeps marbles from
    bouncing out of the receiving cup, a small rolling friction lets them come to rest.
    ``linear_damping`` and ``angular_damping`` (PyBullet's, the fraction of velocity lost per second)
    are left at PyBullet's own when None; setting them, even to PyBullet's nominal 0.04, changes the
    pour (``benchmarks/studies/e6_pour/pour_sensitivity.py`` tries damped variants).
    """

    radius: float = 0.0135
    mass_g: float = 25.0
    lateral_friction: float = 0.4
    rolling_friction: float = 1e-4
    spinning_friction: float = 1e-4
    restitution: float = 0.0
    linear_damping: float | None = None
    angular_damping: float | None = None


@dataclass(frozen=True)
class PourConfig:
    """Everything that defines the rig and how it is simulated.

    Attributes
    ----------
    cup, receiver, marbles : the scene's parts.
    axis_height : the wrist axis' height above the floor (m).
    wrist_limits : (lower, upper) wrist angle (rad); trajectory rows are clipped into them.
    max_weight_g : the heaviest initial weight (g) the rig accepts (the cup holds it).
    sim_dt : physics time step (s).
    substeps : physics steps per control step; ``control_dt = sim_dt * substeps``.
    solver_iterations : constraint-solver iterations per physics step.
    position_gain, velocity_gain, max_torque : the wrist's position controller (torque in N m).
    initial_settle_time : simulated time (s) the marbles settle once per marble count.
    settle_time : at most this long (s) after the last row before the poured mass is read.
    settle_speed : a marble slower than this (m/s) counts as settled.
    spawn_seed : seeds the jitter of the marbles' start grid.
    """

    cup: CupGeometry = field(default_factory=CupGeometry)
    receiver: ReceiverGeometry = field(default_factory=ReceiverGeometry)
    marbles: MarbleSpec = field(default_factory=MarbleSpec)
    axis_height: float = 0.24
    wrist_limits: tuple[float, float] = (-0.5, float(np.pi))
    max_weight_g: float = 1500.0
    sim_dt: float = 1.0 / 240.0
    substeps: int = 4
    solver_iterations: int = 10
    position_gain: float = 0.3
    velocity_gain: float = 1.0
    max_torque: float = 100.0
    initial_settle_time: float = 2.0
    settle_time: float = 1.0
    settle_speed: float = 0.02
    spawn_seed: int = 0

    @property
    def control_dt(self) -> float:
        """Seconds per trajectory row."""
        return self.sim_dt * self.substeps

    @property
    def tare_g(self) -> float:
        """The empty cup's mass (g)."""
        return self.cup.tare_g

    def n_marbles(self, weight_g: float, name: str = "weight_g") -> int:
        """Marbles in a cup of initial weight ``weight_g`` (g): ``(weight - tare) / marble mass``,
        rounded half up. Raises ValueError naming ``name`` below the tare or above ``max_weight_g``."""
        w = float(weight_g)
        if not np.isfinite(w):
            raise ValueError(f"{name}: expected a finite initial weight (g), got {weight_g!r}")
        if w < self.cup.tare_g:
            raise ValueError(f"{name}: the initial weight {w:g} g is below the cup's tare ({self.cup.tare_g:g} g)")
        if w > self.max_weight_g:
            raise ValueError(f"{name}: the initial weight {w:g} g is above the rig's maximum ({self.max_weight_g:g} g)")
        return int(np.floor((w - self.cup.tare_g) / self.marbles.mass_g + 0.5))

    def weight_g(self, n_marbles: int) -> float:
        """The initial weight (g) of a cup holding ``n_marbles`` marbles."""
        return self.cup.tare_g + n_marbles * self.marbles.mass_g


def cup_boxes(cup: CupGeometry) -> list[Box]:
    """The cup's convex pieces in the wrist link's frame (origin on the axis, cup upright).

    Returns a list of (half extents (3,) m, centre (3,) m, pitch about +y (rad)).
    """
    t, w, d, h = cup.wall, cup.inner_width, cup.inner_depth, cup.inner_height
    x_in0, x_in1 = -t - w, -t  # the cavity along x at the rim; the pour wall's top is x in [-t, 0]
    x_mid = (x_in0 + x_in1) / 2
    beta = np.deg2rad(cup.flare)
    lean = h * np.tan(beta)  # how much narrower the cavity is at the base than at the rim
    x_base1 = x_in1 - lean + t / np.cos(beta)  # the pour wall's outer face at the base
    boxes: list[Box] = [
        (((x_base1 - x_in0 + t) / 2, d / 2 + t, t / 2), ((x_in0 - t + x_base1) / 2, 0.0, -h - t / 2), 0.0),  # base
        # The pour-side wall hangs from the axis, its inner face through (-t, 0) and (-t - lean, -h).
        ((t / 2, d / 2, h / (2 * np.cos(beta))),
         (x_in1 - lean / 2 + t / 2 * np.cos(beta), 0.0, -h / 2 - t / 2 * np.sin(beta)), float(beta)),
        ((t / 2, d / 2, h / 2), (x_in0 - t / 2, 0.0, -h / 2), 0.0),  # back wall
        # Side walls span the rim's width; below the leaning wall they are solid, outside the cavity.
        ((w / 2 + t, t / 2, h / 2), (x_mid, d / 2 + t / 2, -h / 2), 0.0),
        ((w / 2 + t, t / 2, h / 2), (x_mid, -d / 2 - t / 2, -h / 2), 0.0),
    ]
    if cup.lip > 0:
        phi = np.deg2rad(cup.lip_angle)
        th = cup.lip_thickness
        # A slab from the wall's inner face (its low end) to `lip` inwards (its high end, at the rim).
        length = cup.lip / np.cos(phi) + th * np.tan(phi)
        centre = (x_in1 - cup.lip / 2, 0.0, -cup.lip * np.tan(phi) / 2 - th / (2 * np.cos(phi)))
        boxes.append(((length / 2, d / 2, th / 2), centre, float(phi)))
    return boxes


def receiver_boxes(rc: ReceiverGeometry) -> list[Box]:
    """The receiving cup's walls in the world frame, as (half extents, centre, pitch) like :func:`cup_boxes`."""
    x0, x1 = rc.x_range
    t, hy, hz = rc.wall, rc.half_y, rc.wall_height / 2
    xm, hx = (x0 + x1) / 2, (x1 - x0) / 2
    return [
        ((t / 2, hy + t, hz), (x0 - t / 2, 0.0, hz), 0.0),
        ((t / 2, hy + t, hz), (x1 + t / 2, 0.0, hz), 0.0),
        ((hx, t / 2, hz), (xm, hy + t / 2, hz), 0.0),
        ((hx, t / 2, hz), (xm, -hy - t / 2, hz), 0.0),
    ]


class PourSim(PhysicsClient):
    """One PyBullet world: floor, wrist with cup, receiving cup and ``n_marbles`` settled marbles.

    Parameters
    ----------
    n_marbles : marbles in the cup (>= 0).
    config : the rig (:class:`PourConfig`).

    Building settles the marbles once (about 0.3 s of CPU for 53 marbles) and keeps their centres;
    :meth:`rollout` rebuilds the world from them first.
    """

    def __init__(self, n_marbles: int, config: PourConfig | None = None) -> None:
        if isinstance(n_marbles, bool) or not isinstance(n_marbles, (int, np.integer)) or n_marbles < 0:
            raise ValueError(f"n_marbles: expected an integer >= 0, got {n_marbles!r}")
        self.config = cfg = config if config is not None else PourConfig()
        self.n_marbles = int(n_marbles)
        self._cid: int | None = p.connect(p.DIRECT)
        try:
            self._build(None)
            for _ in range(int(round(cfg.initial_settle_time / cfg.sim_dt))):
                p.stepSimulation(physicsClientId=self._cid)
            spilled = self.n_marbles - int(self._inside_cup().sum())
            if spilled:
                raise ValueError(f"n_marbles: {self.n_marbles} marbles do not fit the cup "
                                 f"({spilled} spilled while settling)")
            self._settled = self.marble_positions()
        except BaseException:
            self.close()
            raise

    # ------------------------------------------------------------------ building
    def _build(self, marble_xyz: np.ndarray | None) -> None:
        """Empty the physics world and build the rig, the marbles on their start grid (``None``) or
        at rest at ``marble_xyz`` (n_marbles, 3)."""
        cfg, cid = self.config, self.client_id
        p.resetSimulation(physicsClientId=cid)
        p.setGravity(0, 0, -9.81, physicsClientId=cid)
        p.setPhysicsEngineParameter(fixedTimeStep=cfg.sim_dt, numSolverIterations=cfg.solver_iterations,
                                    deterministicOverlappingPairs=1, physicsClientId=cid)
        self.floor = p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid),
                                       physicsClientId=cid)
        self.receiver = p.createMultiBody(0, self._compound(receiver_boxes(cfg.receiver)), physicsClientId=cid)
        self.cup = self._build_wrist()
        self.marbles = self._add_marbles(self._start_grid() if marble_xyz is None else marble_xyz)
        m = cfg.marbles
        for body, link in [(self.floor, -1), (self.receiver, -1), (self.cup, 0)] + [(b, -1) for b in self.marbles]:
            p.changeDynamics(body, link, lateralFriction=m.lateral_friction, restitution=m.restitution,
                             physicsClientId=cid)
        self._hold(0.0)

    def _compound(self, boxes: list[Box]) -> int:
        """A compound collision shape of convex boxes."""
        return p.createCollisionShapeArray(
            [p.GEOM_BOX] * len(boxes), halfExtents=[list(h) for h, _, _ in boxes],
            collisionFramePositions=[list(c) for _, c, _ in boxes],
            collisionFrameOrientations=[list(p.getQuaternionFromEuler([0, a, 0])) for _, _, a in boxes],
            physicsClientId=self.client_id)

    def _build_wrist(self) -> int:
        cfg, cid, c = self.config, self.client_id, self.config.cup
        col = self._compound(cup_boxes(c))
        com = [-(c.wall + c.inner_width / 2), 0.0, -(c.inner_height + c.wall) / 2]  # roughly; the wrist is stiff
        body = p.createMultiBody(
            0, -1, basePosition=[0, 0, cfg.axis_height],
            linkMasses=[c.tare_g / G_PER_KG], linkCollisionShapeIndices=[col], linkVisualShapeIndices=[-1],
            linkPositions=[[0, 0, 0]], linkOrientations=[[0, 0, 0, 1]],
            linkInertialFramePositions=[com], linkInertialFrameOrientations=[[0, 0, 0, 1]],
            linkParentIndices=[0], linkJointTypes=[p.JOINT_REVOLUTE], linkJointAxis=[[0, 1, 0]],
            physicsClientId=cid)
        # Disable the default velocity motor so only our position targets drive the wrist.
        p.setJointMotorControl2(body, 0, p.VELOCITY_CONTROL, force=0, physicsClientId=cid)
        return body

    def _start_grid(self) -> np.ndarray:
        """(n_marbles, 3) start centres (m): a grid with gaps of at least 1.5 mm, filled layer by layer
        from the base, clear of the leaning wall and the lip, with a seeded jitter of +-0.5 mm."""
        cfg = self.config
        c, m = cfg.cup, cfg.marbles
        pitch = 2 * m.radius + 0.0015
        nx = int((c.inner_width - 0.001) / pitch + 1e-9)
        ny = int((c.inner_depth - 0.001) / pitch + 1e-9)
        if nx < 1 or ny < 1:
            raise ValueError("config: the marbles are wider than the cup's cavity")
        xs = -c.wall - c.inner_width / 2 + (np.arange(nx) - (nx - 1) / 2) * pitch
        ys = (np.arange(ny) - (ny - 1) / 2) * pitch
        z0 = cfg.axis_height - c.inner_height + m.radius + 0.001
        under_lip = xs + m.radius > -c.wall - c.lip - 0.001
        cands: list[tuple[float, float, float]] = []
        layer = 0
        while len(cands) < self.n_marbles:
            z = z0 + layer * pitch
            if z > cfg.axis_height + 2 * c.inner_height:
                raise ValueError(f"n_marbles: {self.n_marbles} marbles do not fit the cup")
            # Columns away from the lip may rise above the rim: those marbles drop in while settling.
            depth = min(max(cfg.axis_height - (z - m.radius), 0.0), c.inner_height)  # wall nearest at the bottom
            clear = (xs + m.radius + 0.0005 < c.pour_wall_x(depth)) & (
                ~under_lip | (z + m.radius + 0.0005 < cfg.axis_height - c.lip_drop))
            cands += [(x, y, z) for y in ys for x in xs[clear]]
            layer += 1
        xyz = np.asarray(cands[: self.n_marbles], dtype=np.float64).reshape(-1, 3)
        # The jitter breaks the columns' symmetry, so the settled packing is a plausible one.
        xyz[:, :2] += np.random.default_rng(cfg.spawn_seed).uniform(-0.0005, 0.0005, size=(len(xyz), 2))
        return xyz

    def _add_marbles(self, xyz: np.ndarray) -> list[int]:
        cid, m = self.client_id, self.config.marbles
        if len(xyz) == 0:
            return []
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=m.radius, physicsClientId=cid)
        ids = []
        for pos in xyz:
            body = p.createMultiBody(m.mass_g / G_PER_KG, shape, basePosition=pos.tolist(),
                                     useMaximalCoordinates=True, physicsClientId=cid)
            damping = {k: v for k, v in (("linearDamping", m.linear_damping), ("angularDamping", m.angular_damping))
                       if v is not None}  # PyBullet's keyword arguments: only those the spec sets
            p.changeDynamics(body, -1, rollingFriction=m.rolling_friction, spinningFriction=m.spinning_friction,
                             physicsClientId=cid, **damping)
            ids.append(body)
        return ids

    # ------------------------------------------------------------------ helpers
    @property
    def initial_weight_g(self) -> float:
        """The cup's initial weight (g): tare plus marbles."""
        return self.config.weight_g(self.n_marbles)

    def _hold(self, angle: float, velocity: float = 0.0) -> None:
        cfg = self.config
        p.setJointMotorControl2(self.cup, 0, p.POSITION_CONTROL, targetPosition=float(angle),
                                targetVelocity=float(velocity), positionGain=cfg.position_gain,
                                velocityGain=cfg.velocity_gain, force=cfg.max_torque, physicsClientId=self.client_id)

    def marble_positions(self) -> np.ndarray:
        """(n_marbles, 3) current marble centres (m, world frame)."""
        cid = self.client_id
        if not self.marbles:
            return np.zeros((0, 3))
        return np.array([p.getBasePositionAndOrientation(b, physicsClientId=cid)[0] for b in self.marbles])

    def _max_marble_speed(self) -> float:
        cid = self.client_id
        return max((float(np.linalg.norm(p.getBaseVelocity(b, physicsClientId=cid)[0])) for b in self.marbles),
                   default=0.0)

    def in_receiver(self, positions) -> np.ndarray:
        """(n,) bool: which marble centres ``positions`` (n, 3) m lie inside the receiving cup's walls
        and below their top."""
        rc = self.config.receiver
        pos = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
        return ((pos[:, 0] > rc.x_range[0]) & (pos[:, 0] < rc.x_range[1]) & (np.abs(pos[:, 1]) < rc.half_y)
                & (pos[:, 2] < rc.wall_height))

    def _inside_cup(self) -> np.ndarray:
        # The upright cup's cavity (a loose box): used only right after the initial settling.
        c, cfg = self.config.cup, self.config
        pos = self.marble_positions()
        return ((pos[:, 0] > -c.wall - c.inner_width) & (pos[:, 0] < -c.wall) & (np.abs(pos[:, 1]) < c.inner_depth / 2)
                & (pos[:, 2] > cfg.axis_height - c.inner_height) & (pos[:, 2] < cfg.axis_height))

    def check_trajectory(self, trajectory, name: str = "trajectory") -> np.ndarray:
        """Validate a (T, 1) or (T,) wrist trajectory (rad) and clip it into ``wrist_limits``.

        Returns the (T,) clipped angles. Raises ValueError naming ``name`` for a wrong shape or NaN/inf.
        The clip is silent: a real wrist saturates the same way and exploration noise hits limits.
        """
        traj = check_array(name, trajectory, ndim=(1, 2), min_size=1)
        if traj.ndim == 2:
            if traj.shape[1] != 1:
                raise ValueError(f"{name}: expected one wrist angle per row (shape (T, 1)), got shape {traj.shape}")
            traj = traj[:, 0]
        lo, hi = self.config.wrist_limits
        return np.clip(traj, lo, hi)

    # ------------------------------------------------------------------ roll-out
    def rollout(self, trajectory, *, n_frames: int = 6) -> dict[str, np.ndarray]:
        """Execute one wrist trajectory from the settled snapshot and measure what was poured.

        Parameters
        ----------
        trajectory : (T, 1) or (T,) wrist targets (rad), one per control step (``control_dt`` apart).
            The wrist starts at rest at the first row; rows are clipped into ``wrist_limits``.
        n_frames : marble positions are kept at this many frames (>= 2), evenly spaced from before
            the first step to after settling.

        Returns
        -------
        dict with
            ``wrist_angle`` (T,) rad, measured after each control step;
            ``poured_g_t`` (T,) g in the receiving cup after each control step;
            ``marble_xyz`` (n_frames, n_marbles, 3) m; ``frame_steps`` (n_frames,) int, the control
            step each frame was taken before (T: after settling);
            ``poured_g`` () g in the receiving cup after settling;
            ``settle_steps`` () int, physics steps spent settling after the last row.
        """
        traj = self.check_trajectory(trajectory)
        if isinstance(n_frames, bool) or not isinstance(n_frames, (int, np.integer)) or n_frames < 2:
            raise ValueError(f"n_frames: expected an integer >= 2, got {n_frames!r}")
        cfg, cid = self.config, self.client_id
        t_len = traj.shape[0]
        self._build(self._settled)
        p.resetJointState(self.cup, 0, float(traj[0]), 0.0, physicsClientId=cid)
        vel = np.zeros(t_len)
        vel[1:] = np.diff(traj) / cfg.control_dt  # velocity feed-forward reduces the controller's lag
        mass = cfg.marbles.mass_g
        frame_steps = np.linspace(0, t_len, n_frames).round().astype(np.int64)
        frames = []
        angle = np.empty(t_len)
        poured_t = np.empty(t_len)
        for k in range(t_len):
            if k in frame_steps:
                frames += [self.marble_positions()] * int(np.sum(frame_steps == k))
            self._hold(traj[k], vel[k])
            for _ in range(cfg.substeps):
                p.stepSimulation(physicsClientId=cid)
            angle[k] = p.getJointState(self.cup, 0, physicsClientId=cid)[0]
            poured_t[k] = mass * self.in_receiver(self.marble_positions()).sum()
        self._hold(traj[-1])
        settle = 0
        max_steps = int(round(cfg.settle_time / cfg.sim_dt))
        while settle < max_steps:
            for _ in range(cfg.substeps):
                p.stepSimulation(physicsClientId=cid)
            settle += cfg.substeps
            if self._max_marble_speed() < cfg.settle_speed:
                break
        final = self.marble_positions()
        frames += [final] * int(np.sum(frame_steps == t_len))
        return {"wrist_angle": angle, "poured_g_t": poured_t, "marble_xyz": np.stack(frames).reshape(n_frames, -1, 3),
                "frame_steps": frame_steps, "poured_g": np.float64(mass * self.in_receiver(final).sum()),
                "settle_steps": np.int64(settle)}


#: Initial weight (g) of the pouring task's test, the heaviest load the experiments use: the rig the
#: registry builds holds it.
TEST_WEIGHT_G = 1400.0
