"""The robot kinds ``metaworld-reach``, ``metaworld-push``, ``metaworld-pick-place``,
``metaworld-window-open`` and ``metaworld-button-press``: Meta-World's Sawyer tasks through the
Gymnasium adapter (:mod:`acnmp_core.robots.gym_robot`).

Each kind runs one task (``metaworld_reach``, ``metaworld_push``, ...) that executes trajectories
(T, 4): the hand's target position (x, y, z) m after each environment step, PD-tracked with
:data:`~acnmp_core.tasks.metaworld.scene.KP`, and the gripper command, sent as it is
(:data:`~acnmp_core.tasks.metaworld.scene.CONTROL`). The task parameters place the puck and the goal,
or the articulated object (:class:`~acnmp_core.tasks.metaworld.scene.MetaWorldTask`); the rewards are
Meta-World's own per step; success is Meta-World's success at any step of the episode, and the
error the smallest distance to the goal it reached (m). Building a kind's evaluator without the
``metaworld`` extra fails with one line naming it.
"""
from __future__ import annotations

from .gym_robot import GymRobotConfig, gym_robot
from .spec import Joint, RobotSpec
from ..tasks.metaworld.scene import CONTROL, KP, TASKS, MetaWorldTask, make_env, require_metaworld, set_task

#: the hand's reach (m; Meta-World's mocap limits) and the gripper command's range
JOINTS = (Joint("hand_x", -0.5, 0.5), Joint("hand_y", 0.4, 1.0), Joint("hand_z", 0.05, 0.5), Joint("gripper", -1.0, 1.0))


def task_name(kind: str) -> str:
    """The task a Meta-World kind runs: ``metaworld-pick-place`` -> ``metaworld_pick_place``."""
    return kind.replace("-", "_")


def metaworld_config(spec: MetaWorldTask) -> GymRobotConfig:
    """The adapter's configuration of ``spec``'s environment (see the module docstring)."""
    require_metaworld()
    goal = tuple(i for i, name in enumerate(spec.param_names) if name.startswith("goal_"))
    return GymRobotConfig(
        lambda: make_env(spec.kind), set_task=set_task(spec.kind), control=CONTROL, kp=KP, kd=0.0,
        success=lambda ep: bool(ep.final_info["success_ever"]), error=lambda ep: float(ep.final_info["min_error"]),
        end_effector=lambda o: o[:3], object_position=lambda o: o[4:7], goal_params=goal, joints=JOINTS)


def _kind(spec: MetaWorldTask) -> RobotSpec:
    return gym_robot(spec.kind, f"Meta-World's {spec.env_name}: a Sawyer arm's hand and gripper (metaworld extra)",
                     lambda: metaworld_config(spec), task=task_name(spec.kind), credit=spec.credit)


#: the three kinds, registered as built in by :mod:`acnmp_core.robots.registry`
KINDS: tuple[RobotSpec, ...] = tuple(_kind(spec) for spec in TASKS.values())
