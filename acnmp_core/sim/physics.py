"""What every PyBullet simulator of the project shares (it owns one headless physics client), and a
kinematic-only model that poses a URDF's collision shapes for drawing."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from .quiet_pybullet import pybullet as p


class PhysicsClient:
    """Base of a simulator that owns one PyBullet physics client, ``self._cid`` (set by the
    subclass's constructor, e.g. ``p.connect(p.DIRECT)``): :attr:`client_id` while it is open,
    :meth:`close` (idempotent), a context manager, and a best-effort close when collected (an
    un-closed client would leak its physics world)."""

    _cid: int | None = None

    @property
    def client_id(self) -> int:
        """The PyBullet client id; RuntimeError once the simulator is closed."""
        if self._cid is None:
            raise RuntimeError(f"{type(self).__name__}: the simulator is closed")
        return self._cid

    def close(self) -> None:
        """Disconnect the physics client (idempotent)."""
        if self._cid is not None:
            try:
                p.disconnect(physicsClientId=self._cid)
            finally:
                self._cid = None

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass


@dataclass(frozen=True)
class Shape:
    """One collision shape of a link, for drawing.

    link : the URDF link's name. kind : "mesh" or "box". mesh : the mesh file ("" for a box).
    half_extents : (3,) m of a box (zeros for a mesh). pos (3,) m, quat (4,) x, y, z, w: the shape's
    frame in its link's centre-of-mass frame (PyBullet's convention for collision shapes).
    """

    link: str
    kind: str
    mesh: str
    half_extents: tuple[float, float, float]
    pos: tuple[float, float, float]
    quat: tuple[float, float, float, float]


class LinkPoser(PhysicsClient):
    """A URDF loaded without simulating it, to pose its collision shapes from joint values (for
    recordings: a mesh robot is drawn by logging each shape once and its pose at every step).

    Parameters
    ----------
    urdf : path of the URDF (mesh paths absolute or relative to it).

    Attributes
    ----------
    shapes : the mesh and box collision shapes of every link (other kinds are skipped).
    """

    def __init__(self, urdf) -> None:
        self._cid = p.connect(p.DIRECT)
        cid = self._cid
        self.body = p.loadURDF(str(urdf), useFixedBase=True, physicsClientId=cid)
        self.joints: dict[str, int] = {}
        links = {-1: p.getBodyInfo(self.body, physicsClientId=cid)[0].decode()}
        for j in range(p.getNumJoints(self.body, physicsClientId=cid)):
            info = p.getJointInfo(self.body, j, physicsClientId=cid)
            self.joints[info[1].decode()] = j
            links[j] = info[12].decode()
        self.shapes: list[Shape] = []
        self._shape_links: list[int] = []
        for link in sorted(links):
            for d in p.getCollisionShapeData(self.body, link, physicsClientId=cid):
                geom, dims, mesh = d[2], d[3], d[4]
                if geom == p.GEOM_MESH:
                    shape = Shape(links[link], "mesh", mesh.decode() if isinstance(mesh, bytes) else str(mesh),
                                  (0.0, 0.0, 0.0), tuple(d[5]), tuple(d[6]))
                elif geom == p.GEOM_BOX:
                    shape = Shape(links[link], "box", "", tuple(0.5 * np.asarray(dims, dtype=float)),
                                  tuple(d[5]), tuple(d[6]))
                else:
                    continue
                self.shapes.append(shape)
                self._shape_links.append(link)

    def poses(self, joint_values: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """World poses of every shape at T steps.

        joint_values : joint name -> (T,) values (rad or m); joints not named stay at zero.
        Returns positions (T, S, 3) m and quaternions (T, S, 4) x, y, z, w, S = ``len(shapes)``.
        Raises ValueError naming an unknown joint or mismatched lengths.
        """
        cid = self.client_id
        unknown = sorted(set(joint_values) - set(self.joints))
        if unknown:
            raise ValueError(f"joint_values: unknown joint(s) {unknown}; the URDF has {sorted(self.joints)}")
        cols = {self.joints[n]: np.asarray(v, dtype=np.float64).reshape(-1) for n, v in joint_values.items()}
        lengths = {len(v) for v in cols.values()}
        if len(lengths) > 1:
            raise ValueError(f"joint_values: expected one length for every joint, got {sorted(lengths)}")
        steps = lengths.pop() if lengths else 1
        pos = np.empty((steps, len(self.shapes), 3))
        quat = np.empty((steps, len(self.shapes), 4))
        for k in range(steps):
            for j, v in cols.items():
                p.resetJointState(self.body, j, float(v[k]), physicsClientId=cid)
            frames = {}
            for i, (link, shape) in enumerate(zip(self._shape_links, self.shapes)):
                if link not in frames:
                    if link == -1:
                        frames[link] = p.getBasePositionAndOrientation(self.body, physicsClientId=cid)
                    else:
                        frames[link] = p.getLinkState(self.body, link, computeForwardKinematics=True,
                                                      physicsClientId=cid)[:2]
                pos[k, i], quat[k, i] = p.multiplyTransforms(*frames[link], shape.pos, shape.quat)
        return pos, quat
