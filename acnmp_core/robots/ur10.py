"""The ``ur10`` robot kind: the UR10 arm's joints with their limits, its drawing and its simulator."""
from __future__ import annotations

from ..sim.ur10 import PickPlaceScene, UR10Sim
from ..sim.ur10_description import FINGER_JOINTS, UR10_ARM_JOINTS, write_ur10_gripper_urdf


def ur10_body():
    """The registry's description of the ``ur10`` robot kind (:mod:`acnmp_core.robots.registry`).

    Joints: the six arm joints of :data:`~acnmp_core.sim.ur10_description.UR10_ARM_JOINTS` with
    their position limits (rad) read from the package's URDF; drawing: a
    :class:`~acnmp_core.robots.spec.MeshChainDrawing` of the arm and gripper's collision shapes
    with the default scene's layout (m);
    simulator: :class:`UR10Sim` with the default scene and gripper.
    """
    import xml.etree.ElementTree as ET

    from .spec import Joint, MeshChainDrawing, RobotBody
    from ..sim.ur10_description import ur10_source_urdf

    root = ET.parse(ur10_source_urdf()).getroot()
    urdf_joints = {j.get("name"): j for j in root.findall("joint")}
    joints = tuple(Joint(n, float(urdf_joints[n].find("limit").get("lower")),
                         float(urdf_joints[n].find("limit").get("upper"))) for n in UR10_ARM_JOINTS)
    sc = PickPlaceScene()
    scene = {"pick_xy": sc.pick_xy, "place_xy": sc.place_xy, "obstacle_xy": sc.obstacle_xy,
             "object_size": sc.object_size, "obstacle_size": sc.obstacle_size}
    drawing = MeshChainDrawing("ur10", UR10_ARM_JOINTS, scene, FINGER_JOINTS, write_ur10_gripper_urdf)
    return RobotBody(joints, drawing, UR10Sim)
