"""Adapt the skill `reach` of a running deployment to a goal outside the demonstrations.

Run beside `acnmp up --robot my_arm ... --demos reach=...` (see README.md):
    python adapt.py [GOAL_X GOAL_Y]        (default: 0.6 0.45; the demonstrations reach y <= 0.2)
"""
import sys

import numpy as np

from acnmp_core import AdaptConfig, AdaptTarget
from acnmp_core.errors import InputError
from acnmp_core.jobs.adapt import AdaptJob
from clients.client import ACNMPClient, ClientError


def main(argv: list[str]) -> int:
    goal = np.array([float(v) for v in argv[:2]] or [0.6, 0.45])
    times = np.linspace(0.0, 1.0, 50)
    target = AdaptTarget(obs_times=np.array([0.0]), obs_values=np.array([[0.3, 1.2]]),  # the start posture
                         task_params=goal, query_times=times)
    job = AdaptJob(target, task="reach", robot="my_arm", config=AdaptConfig(mode="acnmp", max_rollouts=300))
    with ACNMPClient(timeout=30) as client:
        result = client.wait_job(client.adapt("reach", job), timeout=600)["result"]
    print(f"goal {goal.tolist()}: adapted with {result['rollouts']} roll-outs on the workers, "
          f"success {result['success']}")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except (InputError, ClientError, ValueError) as exc:  # one line, as the acnmp command line does
        sys.exit(f"adapt.py: {exc}")
