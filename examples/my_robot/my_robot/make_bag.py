"""Write a ROS 2 bag of the five reaches of demos.npz, as the arm would record them with
`ros2 bag record /joint_states /goal`: the joint states at 50 Hz (the environment's step, header
stamped; joints ``shoulder`` and ``elbow``), the goal (geometry_msgs/PointStamped) as each reach
starts, half a second between reaches. Needs rosbags (acnmp's default set-up installs it).

Run: python -m my_robot.make_bag reach_bag        (then: acnmp demos import --format rosbag2 reach_bag --list)
"""
import sys
from pathlib import Path

import numpy as np

from .env import ReachEnv
from .make_demos import demos

JOINTS = ["shoulder", "elbow"]
START_NS = 1_767_225_600 * 10**9  # 2026-01-01, when the reaches were recorded
PAUSE_NS = 500_000_000


def write_bag(path: Path) -> Path:
    """The bag at ``path`` (a new directory): /joint_states and /goal of the five reaches."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    T = store.types
    step_ns = int(round(ReachEnv.dt * 1e9))

    def header(ns: int):
        return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                                        frame_id="base")

    arrays, t = demos(), START_NS
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as bag:
        joints = bag.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=store)
        goals = bag.add_connection("/goal", "geometry_msgs/msg/PointStamped", typestore=store)
        for q, goal in zip(arrays.values, arrays.task_params):
            point = T["geometry_msgs/msg/Point"](x=float(goal[0]), y=float(goal[1]), z=0.0)
            bag.write(goals, t, store.serialize_cdr(T["geometry_msgs/msg/PointStamped"](header=header(t), point=point),
                                                    "geometry_msgs/msg/PointStamped"))
            for row in q:
                msg = T["sensor_msgs/msg/JointState"](header=header(t), name=JOINTS, position=np.asarray(row),
                                                      velocity=np.zeros(0), effort=np.zeros(0))
                bag.write(joints, t, store.serialize_cdr(msg, "sensor_msgs/msg/JointState"))
                t += step_ns
            t += PAUSE_NS
    return path


if __name__ == "__main__":
    print(write_bag(Path(sys.argv[1] if len(sys.argv) > 1 else "reach_bag")))
