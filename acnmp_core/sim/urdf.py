"""URDF generation for planar N-DoF arms, written to a per-process cache directory.

The arm moves in a horizontal plane at height ``arm_height`` above the table. Every joint is a
revolute joint about +z; link ``i`` is a box of length ``link_lengths[i]`` along its x axis. A fixed
``ee`` link at the tip of the last link carries a flat paddle that hangs down to just above the
table: it is the only part of the arm low enough to touch objects on the table, so pushing happens
only with the paddle (the links pass above the objects).
"""
from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..validation import check_array


@dataclass(frozen=True)
class ArmGeometry:
    """Geometry of a planar arm (metres, radians, kilograms).

    Attributes
    ----------
    link_lengths : (N,) link lengths.
    joint_limits : (N, 2) lower/upper joint limits.
    arm_height : height of the links' centre line above the table.
    link_width, link_thickness : cross-section of the link boxes.
    link_mass : mass of each link.
    paddle_thickness : paddle size along the last link's x axis (the push direction).
    paddle_width : paddle size across the push direction.
    paddle_bottom : height of the paddle's lower edge above the table.
    """

    link_lengths: tuple[float, ...]
    joint_limits: tuple[tuple[float, float], ...]
    arm_height: float = 0.10
    link_width: float = 0.03
    link_thickness: float = 0.02
    link_mass: float = 0.5
    paddle_thickness: float = 0.01
    paddle_width: float = 0.05
    paddle_bottom: float = 0.01

    def __post_init__(self) -> None:
        lengths = check_array("link_lengths", self.link_lengths, ndim=1, min_size=1)
        if np.any(lengths <= 0):
            raise ValueError(f"link_lengths: expected positive lengths, got {lengths.tolist()}")
        limits = check_array("joint_limits", self.joint_limits, shape=(lengths.shape[0], 2))
        if np.any(limits[:, 0] >= limits[:, 1]):
            raise ValueError("joint_limits: expected lower < upper for every joint")
        if self.paddle_bottom >= self.arm_height:
            raise ValueError("paddle_bottom: expected below arm_height")
        # Store as plain tuples so the geometry is hashable and cache keys are stable.
        object.__setattr__(self, "link_lengths", tuple(float(v) for v in lengths))
        object.__setattr__(self, "joint_limits", tuple((float(a), float(b)) for a, b in limits))

    @property
    def n_joints(self) -> int:
        return len(self.link_lengths)


def _box_inertia(m: float, x: float, y: float, z: float) -> str:
    ixx, iyy, izz = m * (y * y + z * z) / 12, m * (x * x + z * z) / 12, m * (x * x + y * y) / 12
    return f'<inertia ixx="{ixx:.8g}" ixy="0" ixz="0" iyy="{iyy:.8g}" iyz="0" izz="{izz:.8g}"/>'


def _box_link(name: str, size: tuple[float, float, float], xyz: tuple[float, float, float], mass: float,
              rgba: str) -> str:
    sx, sy, sz = size
    ox, oy, oz = xyz
    geom = f'<origin xyz="{ox:.8g} {oy:.8g} {oz:.8g}" rpy="0 0 0"/><geometry><box size="{sx:.8g} {sy:.8g} {sz:.8g}"/></geometry>'
    return (
        f'  <link name="{name}">\n'
        f'    <inertial><origin xyz="{ox:.8g} {oy:.8g} {oz:.8g}"/><mass value="{mass:.8g}"/>{_box_inertia(mass, sx, sy, sz)}</inertial>\n'
        f'    <visual>{geom}<material name="{name}_mat"><color rgba="{rgba}"/></material></visual>\n'
        f'    <collision>{geom}</collision>\n'
        f'  </link>\n'
    )


def planar_arm_urdf(geom: ArmGeometry) -> str:
    """The URDF text of the arm described by ``geom``.

    Links: ``base`` (a pillar from the table to ``arm_height``), ``link1..linkN``, ``ee`` (the paddle).
    Joints: ``joint1..jointN`` (revolute about z), ``ee_joint`` (fixed at the tip of link N). The ``ee``
    link frame sits at the tip of link N at ``arm_height``; its x axis is the push direction.
    """
    h = geom.arm_height
    parts = ['<?xml version="1.0"?>\n<robot name="planar_arm">\n']
    parts.append(_box_link("base", (0.06, 0.06, h), (0.0, 0.0, h / 2), 2.0, "0.3 0.3 0.3 1"))
    parent, origin = "base", (0.0, 0.0, h)
    colours = ["0.9 0.5 0.1 1", "0.1 0.5 0.9 1"]
    for i, (length, (lo, hi)) in enumerate(zip(geom.link_lengths, geom.joint_limits), start=1):
        name = f"link{i}"
        parts.append(_box_link(name, (length, geom.link_width, geom.link_thickness), (length / 2, 0.0, 0.0),
                               geom.link_mass, colours[i % 2]))
        parts.append(
            f'  <joint name="joint{i}" type="revolute">\n'
            f'    <parent link="{parent}"/><child link="{name}"/>\n'
            f'    <origin xyz="{origin[0]:.8g} {origin[1]:.8g} {origin[2]:.8g}" rpy="0 0 0"/><axis xyz="0 0 1"/>\n'
            f'    <limit lower="{lo:.8g}" upper="{hi:.8g}" effort="100" velocity="10"/>\n'
            f'    <dynamics damping="0.1" friction="0"/>\n'
            f'  </joint>\n'
        )
        parent, origin = name, (length, 0.0, 0.0)
    # The paddle spans from just above the table up to the link's underside.
    top = -geom.link_thickness / 2
    bottom = geom.paddle_bottom - h
    parts.append(_box_link("ee", (geom.paddle_thickness, geom.paddle_width, top - bottom),
                           (0.0, 0.0, (top + bottom) / 2), 0.05, "0.2 0.8 0.2 1"))
    parts.append(
        f'  <joint name="ee_joint" type="fixed">\n'
        f'    <parent link="{parent}"/><child link="ee"/>\n'
        f'    <origin xyz="{origin[0]:.8g} 0 0" rpy="0 0 0"/>\n'
        f'  </joint>\n'
    )
    parts.append("</robot>\n")
    return "".join(parts)


def urdf_cache_dir() -> Path:
    """Where generated URDFs are kept: ``$ACNMP_CACHE/urdf`` or ``~/.cache/acnmp/urdf`` (created).

    Shared by every process and named by content, so the few geometries the project builds are
    written once, and nothing is left behind by a process that ends without running its exit
    handlers (a killed worker, a command that skips the interpreter's teardown).
    """
    root = os.environ.get("ACNMP_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "acnmp")
    path = Path(root) / "urdf"
    path.mkdir(parents=True, exist_ok=True)
    return path


def cached_urdf(stem: str, text: str) -> Path:
    """The path of URDF ``text`` in :func:`urdf_cache_dir`, as ``<stem>_<content hash>.urdf``,
    written (atomically, a temporary file per process) if it is not there yet."""
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    path = urdf_cache_dir() / f"{stem}_{digest}.urdf"
    if not path.exists():
        tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
        tmp.write_text(text)
        os.replace(tmp, path)  # atomic: a concurrent reader never sees half a file
    return path


def write_planar_arm_urdf(geom: ArmGeometry) -> Path:
    """Write the URDF of ``geom`` into :func:`urdf_cache_dir` (named by its content hash) and return the path."""
    return cached_urdf(f"planar_arm_{geom.n_joints}dof", planar_arm_urdf(geom))
