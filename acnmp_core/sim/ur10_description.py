"""The UR10 description from ``example-robot-data`` with a two-finger parallel gripper on its flange.

The UR10 (``ur_description/urdf/ur10_robot.urdf``: link lengths, inertias, joint limits, STL
collision meshes) is read from the installed ``example-robot-data`` package, found through its
distribution metadata (the wheel installs its data under ``cmeel.prefix/share``; no Python module
ships with it). The text is rewritten at run time:

* ``package://`` mesh URIs become absolute paths into the installed share directory, so PyBullet
  needs no search path;
* the visual elements (COLLADA meshes) are dropped by default: a headless simulator never renders
  them and parsing them costs about 0.4 s per load. A viewer reads them from
  :func:`ur10_source_urdf` instead;
* a gripper (:func:`gripper_urdf_links`) is appended, fixed to the ``tool0`` flange frame, so the
  arm and the gripper are one multibody and the fingers move with no extra constraint.

The gripper, in the ``tool0`` frame (z out of the flange, towards the object when picking):

* ``gripper_palm``: a box ``palm_size`` whose top face lies on the flange;
* ``finger_left`` / ``finger_right``: prismatic joints along +x / -x of the palm; the joint value is
  the distance (m) from the gripper's centre plane to the finger's inner face (0 = closed on the
  centre, ``finger_travel`` = fully open). Each finger is a box hanging ``finger_length`` below
  the palm;
* ``tcp``: a massless frame between the fingers, ``tcp_above_tip`` above the fingertips: the point
  the task's grasp and obstacle-avoidance rewards measure.
"""
from __future__ import annotations

import importlib.metadata
import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from .urdf import cached_urdf

#: The six arm joints in chain order, as the URDF names them.
UR10_ARM_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
                   "wrist_2_joint", "wrist_3_joint")
#: The gripper's joints and the TCP link, as :func:`gripper_urdf_links` names them.
FINGER_JOINTS = ("finger_left_joint", "finger_right_joint")
TCP_LINK = "tcp"

_UR10_RELATIVE = "example-robot-data/robots/ur_description/urdf/ur10_robot.urdf"


@lru_cache(maxsize=1)
def example_robot_data_share() -> Path:
    """The ``share`` directory of the installed ``example-robot-data`` (holds ``example-robot-data/robots``).

    Raises RuntimeError if the package is not installed or its data is missing.
    """
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise RuntimeError("example-robot-data is not installed (pip install example-robot-data==6.0.0)") from None
    share = Path(str(dist.locate_file("cmeel.prefix/share")))
    if not (share / _UR10_RELATIVE).is_file():
        raise RuntimeError(f"example-robot-data: {_UR10_RELATIVE} not found under {share}")
    return share


def ur10_source_urdf() -> Path:
    """Path of the package's own ``ur10_robot.urdf`` (with its ``package://`` URIs and visual meshes)."""
    return example_robot_data_share() / _UR10_RELATIVE


@dataclass(frozen=True)
class GripperGeometry:
    """A simple two-finger parallel gripper (metres, kilograms, newtons).

    Attributes
    ----------
    palm_size : (x, y, z) of the palm box; x is the fingers' closing axis.
    palm_mass : palm mass.
    finger_size : (thickness along x, width along y) of each finger's cross-section.
    finger_length : how far each finger hangs below the palm.
    finger_mass : mass of each finger.
    finger_travel : upper limit of each finger joint (distance of its inner face from the centre).
    finger_effort : force limit of each finger joint (the squeeze force when closed on an object).
    tcp_above_tip : height of the tool centre point above the fingertips.
    """

    palm_size: tuple[float, float, float] = (0.13, 0.05, 0.04)
    palm_mass: float = 0.6
    finger_size: tuple[float, float] = (0.012, 0.025)
    finger_length: float = 0.035
    finger_mass: float = 0.05
    finger_travel: float = 0.05
    finger_effort: float = 40.0
    tcp_above_tip: float = 0.007

    def __post_init__(self) -> None:
        for name in ("palm_mass", "finger_length", "finger_mass", "finger_travel", "finger_effort"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name}: expected a positive value, got {getattr(self, name)!r}")
        if not 0 <= self.tcp_above_tip < self.finger_length:
            raise ValueError(f"tcp_above_tip: expected in [0, finger_length), got {self.tcp_above_tip!r}")
        if self.finger_travel + self.finger_size[0] > self.palm_size[0] / 2 + 1e-9:
            raise ValueError("finger_travel: an open finger would stick out of the palm")

    @property
    def tcp_offset(self) -> float:
        """Distance (m) from the flange (``tool0``) to the TCP along the tool axis."""
        return self.palm_size[2] + self.finger_length - self.tcp_above_tip


def _inertia(m: float, x: float, y: float, z: float) -> str:
    ixx, iyy, izz = m * (y * y + z * z) / 12, m * (x * x + z * z) / 12, m * (x * x + y * y) / 12
    return f'<inertia ixx="{ixx:.8g}" ixy="0" ixz="0" iyy="{iyy:.8g}" iyz="0" izz="{izz:.8g}"/>'


def _box_link(name: str, size, xyz, mass: float, rgba: str) -> str:
    sx, sy, sz = size
    ox, oy, oz = xyz
    geom = (f'<origin xyz="{ox:.8g} {oy:.8g} {oz:.8g}" rpy="0 0 0"/>'
            f'<geometry><box size="{sx:.8g} {sy:.8g} {sz:.8g}"/></geometry>')
    return (
        f'  <link name="{name}">\n'
        f'    <inertial><origin xyz="{ox:.8g} {oy:.8g} {oz:.8g}"/><mass value="{mass:.8g}"/>'
        f'{_inertia(mass, sx, sy, sz)}</inertial>\n'
        f'    <visual>{geom}<material name="{name}_mat"><color rgba="{rgba}"/></material></visual>\n'
        f'    <collision>{geom}</collision>\n'
        f'  </link>\n'
    )


def gripper_urdf_links(g: GripperGeometry, parent: str = "tool0") -> str:
    """URDF elements (links and joints, no ``<robot>`` tag) of the gripper fixed to ``parent``."""
    px, py, pz = g.palm_size
    thick, width = g.finger_size
    parts = [
        _box_link("gripper_palm", g.palm_size, (0.0, 0.0, pz / 2), g.palm_mass, "0.2 0.2 0.2 1"),
        f'  <joint name="gripper_mount" type="fixed">\n'
        f'    <parent link="{parent}"/><child link="gripper_palm"/><origin xyz="0 0 0" rpy="0 0 0"/>\n'
        f'  </joint>\n',
    ]
    # Each finger frame sits on the palm's lower face at the centre plane; the box is offset by half
    # its thickness outwards, so the joint value is exactly the inner face's distance from the centre.
    for side, sign in (("left", 1.0), ("right", -1.0)):
        name = f"finger_{side}"
        parts.append(_box_link(name, (thick, width, g.finger_length),
                               (sign * thick / 2, 0.0, g.finger_length / 2), g.finger_mass, "0.6 0.6 0.6 1"))
        parts.append(
            f'  <joint name="{name}_joint" type="prismatic">\n'
            f'    <parent link="gripper_palm"/><child link="{name}"/>\n'
            f'    <origin xyz="0 0 {pz:.8g}" rpy="0 0 0"/><axis xyz="{sign:.0f} 0 0"/>\n'
            f'    <limit lower="0" upper="{g.finger_travel:.8g}" effort="{g.finger_effort:.8g}" velocity="0.2"/>\n'
            f'  </joint>\n'
        )
    parts.append(
        f'  <link name="{TCP_LINK}"><inertial><mass value="0"/>'
        f'<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>\n'
        f'  <joint name="tcp_joint" type="fixed">\n'
        f'    <parent link="gripper_palm"/><child link="{TCP_LINK}"/>\n'
        f'    <origin xyz="0 0 {g.tcp_offset:.8g}" rpy="0 0 0"/>\n'
        f'  </joint>\n'
    )
    return "".join(parts)


def ur10_gripper_urdf(gripper: GripperGeometry | None = None, *, visuals: bool = False) -> str:
    """The URDF text of the UR10 with the gripper on ``tool0``.

    ``visuals=False`` drops the arm's COLLADA visual meshes (see the module docstring); the
    gripper's boxes keep theirs.
    """
    g = gripper if gripper is not None else GripperGeometry()
    share = example_robot_data_share()
    text = ur10_source_urdf().read_text()
    text = text.replace("package://", f"{share.as_posix()}/")
    if not visuals:
        text = re.sub(r"\s*<visual>.*?</visual>", "", text, flags=re.S)
    close = text.rindex("</robot>")
    return text[:close] + gripper_urdf_links(g) + text[close:]


def write_ur10_gripper_urdf(gripper: GripperGeometry | None = None, *, visuals: bool = False) -> Path:
    """Write :func:`ur10_gripper_urdf` into :func:`~acnmp_core.sim.urdf.urdf_cache_dir` (named by
    its content hash) and return the path."""
    return cached_urdf("ur10_gripper", ur10_gripper_urdf(gripper, visuals=visuals))
