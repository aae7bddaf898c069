"""Robot kinds: what a robot is (:mod:`~acnmp_core.robots.spec`), the registry of kinds with the
built-in ones (planar arm, UR10, pour rig, Pusher), plugins from entry points, and the Gymnasium
adapter (:mod:`~acnmp_core.robots.gym_robot`)."""
