"""Physics worlds, headless in PyBullet: the planar arm pushing a cylinder, the UR10 with its gripper
and pick-and-place scene, the pouring rig, and the helpers they share (a quiet pybullet import, a
physics client, URDF writing, planar kinematics). Nothing here knows a task or a robot kind: the
tasks in :mod:`acnmp_core.tasks` score these worlds and :mod:`acnmp_core.robots` describes them."""
