"""Experiments that drive their own loop (E2, E3 --distributed) execute roll-outs on workers and
the recorder logs every one: counted once per job, with the worker that ran it, and the arm and the
object for a planar arm."""
from __future__ import annotations

import numpy as np
import pytest
import rerun as rr

from clients.distributed import remote_rollouts
from services.recording.replay import summarize

T = 30


def _arm_trajectories(b: int) -> np.ndarray:
    """(b, T, 3) joint trajectories: a slow sweep from a folded pose, away from the cylinder."""
    base = np.array([-0.8, 1.2, -1.0])
    sweep = np.linspace(0.0, 0.3, T)[:, None] * np.array([1.0, -0.5, 0.2])
    return np.stack([base + (1 + 0.2 * i) * sweep for i in range(b)])


def test_remote_rollouts_are_recorded_once_each(tmp_path):
    path = tmp_path / "remote.rrd"
    times = np.linspace(0, 1, T)
    with remote_rollouts("planar3", "push", workers=2, record=str(path), prefix="t-rec", progress=False) as make:
        first = make("push-acnmp-extrapolation", {"n_joints": 3, "tolerance": 0.03})
        second = make("push-acnmp-extrapolation", {"n_joints": 3, "tolerance": 0.03})
        b1 = first.evaluate(_arm_trajectories(5), times, np.array([0.4, 0.1]))
        b2 = first.evaluate(_arm_trajectories(3), times, np.array([0.4, 0.1]))
        second.evaluate(_arm_trajectories(2), times, np.array([0.4, 0.1]))
    s = summarize(path)
    assert s["footer"] is True
    jobs = s["jobs"]
    assert set(jobs) == {"push-acnmp-extrapolation-0", "push-acnmp-extrapolation-1"}
    assert (jobs["push-acnmp-extrapolation-0"]["rollouts"], jobs["push-acnmp-extrapolation-0"]["unique_rollouts"]) == (8, 8)
    assert (jobs["push-acnmp-extrapolation-1"]["rollouts"], jobs["push-acnmp-extrapolation-1"]["duplicates"]) == (2, [])
    workers = jobs["push-acnmp-extrapolation-0"]["workers"]  # as the remote batches named them
    assert sum(workers.values()) == 8 and set(workers) <= {"planar3-0", "planar3-1"}
    np.testing.assert_allclose(jobs["push-acnmp-extrapolation-0"]["best_return"],
                               max(b1.returns.max(), b2.returns.max()))

    reader = rr.chunk.RrdReader(path)
    arm_paths = {c.entity_path for c in reader.stream(store=reader.recordings()[0])
                 if c.entity_path.startswith("/arm") and not c.is_static}
    assert "/arm/push-acnmp-extrapolation-0/links" in arm_paths
    assert "/arm/push-acnmp-extrapolation-0/object" in arm_paths


@pytest.mark.slow
def test_distributed_wall_loop_matches_in_process_and_records_what_it_counts(tmp_path):
    import torch

    from acnmp_core.adaptation.config import AdaptConfig
    from acnmp_core.experiments.wall import run_wall

    torch.set_num_threads(1)
    # small: 2 environments, ACNMP's budget 16 (not 1000), short training; what is compared is
    # that the distributed loop counts and records what the in-process one does
    kw = dict(envs=2, seed=4, n_initial=10, n_test=20, eval_every=2, train_steps=200, assimilate_steps=20,
              adapt_config=AdaptConfig(max_rollouts=16))
    local = run_wall(**kw)
    path = tmp_path / "wall.rrd"
    with remote_rollouts("point2d", "wall", workers=2, record=str(path), prefix="t-wall", progress=False) as make:
        remote = run_wall(**kw, evaluator_factory=lambda method: make(f"wall-{method}"))
    assert remote["rollouts_per_env"] == local["rollouts_per_env"]
    for m in ("acnmp", "promp_rl"):
        assert remote["methods"][m]["test_success_rate"] == local["methods"][m]["test_success_rate"]
    jobs = summarize(path)["jobs"]
    assert jobs["wall-acnmp-0"]["unique_rollouts"] == jobs["wall-acnmp-0"]["rollouts"] \
        == local["methods"]["acnmp"]["trajectories_total"]
    assert jobs["wall-promp_rl-1"]["rollouts"] == local["methods"]["promp_rl"]["trajectories_total"]


def test_push_cli_distributed_records_every_rollout(tmp_path):
    import json

    from clients.cli import main

    rrd, out = tmp_path / "e2.rrd", tmp_path / "e2.json"
    assert main(["experiment", "push", "--seeds", "1", "--train-steps", "200", "--acnmp-budget", "4",
                 "--promp-budget", "5", "--distributed", "--workers", "2", "--record", str(rrd),
                 "--json", str(out), "--quiet"]) == 0
    runs = json.loads(out.read_text())["runs"]
    jobs = summarize(rrd)["jobs"]
    assert len(jobs) == len(runs) == 4
    for n, r in enumerate(runs):  # evaluators are made in run order: job <method>-<case>-<n>
        job = jobs[f"push-{r['method']}-{r['case']}-{n}"]
        # a failed ACNMP run executes its final mean once more to measure it (not counted)
        extra = 1 if r["method"] == "acnmp" and r["adapted"] and not r["success"] else 0
        assert job["rollouts"] == job["unique_rollouts"] == r["rollouts"] + extra
