"""What one Pusher-v5 roll-out costs, and roll-out throughput with 1 and 2 workers (issue 33).

Measured in one run, so the ratios compare like with like on a shared machine:

* ``raw_env_ms``: 100 ``env.step`` calls of Pusher-v5 with the expert's PD actions computed in a
  plain loop (the floor: what the simulator and Gymnasium cost);
* ``adapter_ms``: one episode through ``GymRolloutEvaluator`` (reset, task placement, PD tracking,
  states and rewards logged), batches of 40, one env in this process;
* ``vector_ms``: the same batches through Gymnasium's ``AsyncVectorEnv`` with 2 sub-processes;
* ``workers``: roll-outs per second through a local deployment with 1 and 2 pusher workers
  (batches of 40 sent by the learner's ``RemoteEvaluator``, which splits them across workers; timed
  once every worker has built its environment).

Writes benchmarks/results/bench_pusher_rollouts.json. Usage:
``python benchmarks/performance/bench_pusher_rollouts.py [--batches N]``.
"""
from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from acnmp_core.robots.gym_robot import GymRolloutEvaluator  # noqa: E402
from acnmp_core.robots.pusher import TASK, pusher_config  # noqa: E402
from acnmp_core.tasks.pusher.scene import PUSHER_KD, PUSHER_KP, pusher_expert, set_pusher_task, training_params  # noqa: E402
from benchmarks._results import benchmark_args, provenance, save_result  # noqa: E402

BATCH = 40


def raw_env_ms(traj: np.ndarray, params: np.ndarray, n: int) -> float:
    """Median ms of one episode as a plain Gymnasium loop with the same PD actions."""
    import gymnasium as gym

    env = gym.make("Pusher-v5")
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        env.reset(seed=0)
        obs = set_pusher_task(env, params)
        for target in traj:
            obs, *_ = env.step(np.clip(PUSHER_KP * (target - obs[:7]) - PUSHER_KD * obs[7:14], -2, 2).astype(np.float32))
        times.append(time.perf_counter() - t0)
    env.close()
    return 1e3 * float(np.median(times))


def evaluator_ms(ev, trajs: np.ndarray, times: np.ndarray, params: np.ndarray, batches: int) -> float:
    """Median ms per episode over ``batches`` batches of ``len(trajs)`` (after one warm-up batch)."""
    ev.evaluate(trajs, times, params)
    per = []
    for _ in range(batches):
        t0 = time.perf_counter()
        ev.evaluate(trajs, times, params)
        per.append((time.perf_counter() - t0) / len(trajs))
    return 1e3 * float(np.median(per))


def workers_rate(n_workers: int, trajs: np.ndarray, times: np.ndarray, params: np.ndarray, batches: int) -> float:
    """Roll-outs per second through a fresh local deployment with ``n_workers`` pusher workers."""
    from clients.distributed import remote_rollouts

    with remote_rollouts("pusher", TASK, workers=n_workers, prefix="bench-pusher", progress=False) as make:
        ev = make("bench", {})
        # warm up until every worker has executed a chunk (and built its MuJoCo model, ~1 s)
        while len(set(ev.evaluate(trajs, times, params).workers)) < n_workers:
            pass
        t0 = time.perf_counter()
        for _ in range(batches):
            ev.evaluate(trajs, times, params)
        return batches * len(trajs) / (time.perf_counter() - t0)


def main(argv: list[str] | None = None) -> int:
    """Measure and write the JSON."""
    args = benchmark_args(__doc__, "bench_pusher_rollouts", argv, batches=(5, "batches of 40 roll-outs timed per way"))
    meta = provenance()
    t0 = time.perf_counter()
    params = training_params()[0]
    traj = pusher_expert(params)
    trajs = np.repeat(traj[None], BATCH, axis=0)
    times = np.linspace(0.0, 1.0, len(traj))
    raw = raw_env_ms(traj, params, BATCH * args.batches)
    with GymRolloutEvaluator(pusher_config()) as ev:
        adapter = evaluator_ms(ev, trajs, times, params, args.batches)
    with GymRolloutEvaluator(dataclasses.replace(pusher_config(), vector_envs=2)) as ev:
        vector = evaluator_ms(ev, trajs, times, params, args.batches)
    rates = {str(n): workers_rate(n, trajs, times, params, args.batches) for n in (1, 2)}
    result = {
        "provenance": meta, "batch": BATCH, "batches": args.batches, "steps": int(len(traj)),
        "raw_env_ms": round(raw, 2), "adapter_ms": round(adapter, 2), "adapter_over_raw": round(adapter / raw, 3),
        "vector_2_ms": round(vector, 2), "vector_2_speedup": round(adapter / vector, 3),
        "workers_rollouts_per_s": {k: round(v, 2) for k, v in rates.items()},
        "workers_2_over_1": round(rates["2"] / rates["1"], 3),
        "wall_time_s": round(time.perf_counter() - t0, 2),
    }
    return save_result(result, args.out, None, ("raw_env_ms", "adapter_ms", "vector_2_ms", "workers_rollouts_per_s"))


if __name__ == "__main__":
    sys.exit(main())
