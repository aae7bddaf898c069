"""The comparison's tasks beyond the first three: E1, E2, Pusher-v5, Meta-World's window-open and
button-press. Each gives demonstrations, a test condition drawn from the seed alone, an evaluator on
which its expert succeeds, and (but E1) a step-based environment that replays the demonstrations to
the same success; a run counts its episodes."""
from __future__ import annotations

import numpy as np
import pytest

from acnmp_core.experiments.peers import PeersConfig, peer_task, plan, run_peers

pytest.importorskip("gymnasium")


@pytest.fixture(scope="module")
def e2():
    task = peer_task("e2-push")
    yield task
    task.close()


def test_e1_runs_the_paper_s_via_point_and_says_which_peers_cannot_run_there():
    task = peer_task("e1-viapoint")
    try:
        assert task.cases == ("extrapolation",) and task.arrays.values.shape == (6, 100, 2)
        assert task.params(0, "extrapolation").size == 0 and task.target(3, "extrapolation") is task.target(0, "extrapolation")
        assert set(task.not_applicable) == {"promp_rl", "ppo_bc", "ppo", "sac_bc", "sac"}
        # the expert path (the extrapolated amplitude's) passes every condition
        expert = task.expert_path(0, "extrapolation")
        assert task.evaluator("acnmp").evaluate(expert[None], task.target(0, "extrapolation").query_times).success[0]
    finally:
        task.close()
    config = PeersConfig(tasks=("e1-viapoint",), methods=("lfd", "promp_rl", "ppo_bc"), seeds=(0,))
    assert plan(config) == [("e1-viapoint", 0, "extrapolation", "lfd")]


def test_e2_s_held_out_demonstrations_succeed_and_its_step_environment_replays_them(e2):
    for case in ("extrapolation", "interpolation"):
        p = e2.params(0, case)
        expert = e2.expert_path(0, case)  # the held-out demonstration for that target
        assert e2.evaluator("promp_cma").evaluate(expert[None], e2.times, p).success[0]
        assert e2.evaluator("acnmp").credit == "future"
    obs, actions = e2.transitions
    assert obs.shape == (9 * 299, 14) and actions.shape == (9 * 299, 3) and np.abs(actions).max() <= 1.0
    env = e2.step_env(e2.arrays.task_params[0])
    try:
        env.reset(seed=0)
        for a in [*actions[:299], np.zeros(3)]:  # the demonstration's 299 changes, then a hold: 300 steps
            _, _, _, truncated, info = env.step(a)
        assert truncated and info["success_ever"] and info["min_error"] <= 0.03
    finally:
        env.close()


def test_the_pusher_s_conditions_come_from_the_seed_and_its_environment_replays_a_demonstration():
    pytest.importorskip("mujoco")
    task = peer_task("pusher")
    try:
        assert task.arrays.values.shape == (12, 100, 7)
        ext, inside = task.params(4, "extrapolation"), task.params(4, "interpolation")
        np.testing.assert_array_equal(ext, task.params(4, "extrapolation"))
        assert ext[1] < -0.29 and -0.11 < inside[1] < -0.04  # beyond the demonstrations' y, and inside
        obs, torques = task.transitions
        assert obs.shape == (1200, 23) and torques.shape == (1200, 7) and np.abs(torques).max() <= 2.0
        env = task.step_env(task.arrays.task_params[0])
        env.reset(seed=0)
        for a in torques[:100]:
            *_, truncated, info = env.step(a.astype(np.float32))
        assert truncated and info["success_ever"]
        env.close()
    finally:
        task.close()


@pytest.mark.parametrize("kind", [pytest.param("metaworld-window-open", marks=pytest.mark.slow), "metaworld-button-press"])
def test_the_articulated_meta_world_tasks_have_demonstrations_and_conditions_beyond_them(kind):
    pytest.importorskip("metaworld")
    task = peer_task(kind)
    try:
        a = task.arrays
        assert a.values.shape[1:] == (100, 4) and a.task_params.shape[1] == 2 and len(a.values) >= 10
        x = task.params(0, "extrapolation")[0]
        assert 0.20 <= abs(x) <= 0.25 and np.all(np.abs(a.task_params[:, 0]) <= 0.1)
        assert task.evaluator("acnmp").evaluate(a.values[:1], task.times, a.task_params[0]).success[0]
    finally:
        task.close()


def test_a_run_on_e2_counts_every_episode_within_its_budget(tmp_path):
    pytest.importorskip("cma")
    config = PeersConfig(tasks=("e2-push",), methods=("lfd", "acnmp", "promp_cma"), seeds=(0,),
                         cases=("extrapolation",), train_steps=30, budget=4)
    result = run_peers(config, out=tmp_path / "e2.json")
    runs = {r["method"]: r for r in result["runs"]}
    assert runs["lfd"]["budget"] == 1 and runs["lfd"]["episodes"] == 1
    for m in ("acnmp", "promp_cma"):
        r = runs[m]
        assert r["budget"] == 4 and 1 <= r["episodes"] <= 4 and r["censored"] == (not r["success"])
        assert r["episodes"] == 4 or r["success"]
    assert result["settings"]["e2-push"]["promp_cma_basis"] == runs["promp_cma"]["details"]["n_basis"]
    assert runs["lfd"]["details"]["path_error_to_expert"] > 0


@pytest.mark.parametrize("name", ["e3-wall", "bump", "arc"])
def test_the_non_linear_tasks_draw_conditions_beyond_their_demonstrations_that_their_expert_solves(name):
    """E3's wall (the hole's centre as the condition) and the two path families: demonstrations over
    a training region, conditions drawn from the seed beyond it and inside it, each solved by the
    task's expert (E3's demonstrator, the family itself), and no step-based peer (kinematic paths)."""
    task = peer_task(name)
    try:
        a = task.arrays
        lo, hi = a.task_params.min(axis=0), a.task_params.max(axis=0)
        ev = task.evaluator("acnmp")
        assert ev.evaluate(a.values, task.times, a.task_params[0]).returns.shape == (len(a.values),)
        for seed in range(3):
            for case in ("extrapolation", "interpolation"):
                p = task.params(seed, case)
                beyond = (p < lo) | (p > hi)
                assert beyond.any() if case == "extrapolation" else not beyond.any()
                assert np.array_equal(p, task.params(seed, case))  # the seed alone decides it
                assert ev.evaluate(task.expert_path(seed, case)[None], task.times, p).success[0]
        assert {"ppo_bc", "ppo", "sac_bc", "sac", "promp_cma_dense"} <= set(task.inapplicable())
        assert "promp_rl" not in task.inapplicable()
    finally:
        task.close()


def test_e2_gives_the_promp_peers_acnmp_s_dense_reward_as_their_twins(e2):
    """The same information for every method: the ProMP methods' dense twins run on the reward ACNMP
    adapts on (E2's time-averaged distance), the plain ones on the final distance."""
    assert e2.evaluator("promp_cma_dense") is e2.evaluator("acnmp") is e2.evaluator("promp_rl_dense")
    assert e2.evaluator("promp_cma") is not e2.evaluator("acnmp")
    assert not set(e2.inapplicable()) & {"promp_rl_dense", "promp_cma_dense", "promp_cma5_dense"}
