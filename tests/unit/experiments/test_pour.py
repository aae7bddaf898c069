"""E6 in small: one seed, a short training and budget, through the CLI; the JSON has the shape issue
15 asks for; the assimilation path runs on a stub evaluator that every trajectory satisfies."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from acnmp_core.adaptation.assimilation import AssimilationConfig
from acnmp_core.adaptation.config import AdaptConfig
from acnmp_core.experiments.pour import TimedEvaluator, e6_adapt_config, make_setup, make_target, run_pour
from acnmp_core.rollout import RolloutBatch
from clients.cli import main


class _PoursExactly:
    """Every trajectory pours exactly the target: success at once, no physics."""

    def __init__(self):
        self.calls = 0

    def evaluate(self, trajectories, times, task_params=None):
        self.calls += 1
        b, t, _ = np.shape(trajectories)
        return RolloutBatch(rewards=np.zeros((b, t)), success=np.ones(b, bool), errors=np.zeros(b))


def test_setup_conditions_on_weight_target_and_the_upright_start(pour_demo_file):
    setup = make_setup(str(pour_demo_file))
    assert len(setup.demos) == 16 and setup.times.shape == (240,)
    target = make_target(setup, [1400.0, 1322.0])
    assert target.obs_times.tolist() == [0.0] and target.obs_values.tolist() == [[0.0]]


def test_the_timing_wrapper_keeps_the_inner_credit():
    inner = _PoursExactly()
    assert TimedEvaluator(inner).credit == "step"
    inner.credit = "future"
    ev = TimedEvaluator(inner)
    batch = ev.evaluate(np.zeros((2, 5, 1)), np.linspace(0, 1, 5), [1400.0, 1322.0])
    assert ev.credit == "future" and len(batch) == 2 and len(ev.cpu_s) == 1


def test_a_solution_is_assimilated_and_checked_on_every_demonstration(pour_demo_file):
    stub = _PoursExactly()
    r = run_pour([0], train_steps=20, assimilation=AssimilationConfig(steps=5), demo_path=str(pour_demo_file),
                 evaluator_factory=lambda: stub)
    assert r["acnmp"]["success_rate"] == 1.0 and r["acnmp"]["rollouts_median"] == 1
    a = r["assimilation"]
    assert a["seeds_assimilated"] == 1 and a["error_g_no_rl"] == 0.0 and a["demos_reproduced_within_30g"] == 16
    assert r["rollout_cpu_s_median"] is None  # not measured on a remote (here: stub) evaluator
    assert a["lfd_demos_reproduced_within_30g"] == 16
    assert stub.calls == 16 + 1 + 1 + 16  # demos before, the LfD roll-out, the test without RL, demos after


class _PoursAfter(_PoursExactly):
    """Misses by 100 g on the first ``n`` batches, pours exactly afterwards."""

    def __init__(self, n):
        super().__init__()
        self.n = n

    def evaluate(self, trajectories, times, task_params=None):
        batch = super().evaluate(trajectories, times, task_params)
        if self.calls <= self.n:
            rewards = np.zeros(batch.rewards.shape)
            rewards[:, -1] = -100.0
            batch = RolloutBatch(rewards=rewards, success=np.zeros(len(batch), bool), errors=np.full(len(batch), 100.0))
        return batch


def test_a_final_mean_that_succeeds_after_the_budget_is_assimilated(pour_demo_file):
    """Budget 3: the LfD roll-out and two noisy ones miss; the final mean, run once more, pours exactly
    (the 16 batches before them are the LfD model reproducing the demonstrations)."""
    stub = _PoursAfter(16 + 2)
    r = run_pour([0], train_steps=20, adapt_config=AdaptConfig(max_rollouts=3), assimilation=AssimilationConfig(steps=5),
                 demo_path=str(pour_demo_file), evaluator_factory=lambda: stub)
    run = r["runs"][0]
    assert not run["success"] and run["rollouts"] == 3 and run["solved_after_budget"]
    assert run["first_success_rollout"] is None and run["errors_g_per_rollout"] == [100.0] * 3
    assert r["acnmp"]["solved_after_budget"] == 1 and r["assimilation"]["seeds_assimilated"] == 1


class _Recording(_PoursAfter):
    """:class:`_PoursAfter` that keeps every evaluated batch of trajectories; a miss is the worse
    the lower the wrist's mean angle, so the adaptation has somewhere to go."""

    def __init__(self, n):
        super().__init__(n)
        self.batches = []

    def evaluate(self, trajectories, times, task_params=None):
        self.batches.append(np.array(trajectories))
        batch = super().evaluate(trajectories, times, task_params)
        if not batch.success.any():
            errors = 100.0 - np.mean(trajectories, axis=(1, 2))
            rewards = np.zeros(batch.rewards.shape)
            rewards[:, -1] = -errors
            batch = RolloutBatch(rewards=rewards, success=batch.success, errors=errors)
        return batch


def test_the_solution_is_assimilated_into_the_skill_before_the_adaptation_or_the_adapted_model(pour_demo_file):
    """With no training steps the assimilated model is the one it starts from: "skill" (E6's default)
    reproduces the demonstrations and pours the test exactly as the LfD model did, "adapted" pours
    the test with the adaptation's final mean. Batches: 16 demonstrations, the LfD roll-out, the
    mean and a noisy one (misses), the final mean (pours), 16 demonstrations, the test without RL."""
    got = {}
    for start in ("skill", "adapted"):
        stub = _Recording(16 + 2)
        r = run_pour([0], train_steps=20, adapt_config=AdaptConfig(max_rollouts=3), assimilation=AssimilationConfig(steps=0),
                     demo_path=str(pour_demo_file), evaluator_factory=lambda: stub, assimilate_from=start)
        assert r["config"]["assimilate_from"] == start and r["runs"][0]["solved_after_budget"]
        assert len(stub.batches) == 16 + 3 + 16 + 1
        got[start] = stub.batches
    skill, adapted = got["skill"], got["adapted"]
    lfd, final = skill[16][0], skill[18][0]
    assert not np.allclose(lfd, final)  # the adaptation moved the mean
    assert all(np.array_equal(a, b) for a, b in zip(skill[:16], skill[19:35])) and np.array_equal(skill[-1][0], lfd)
    assert np.allclose(adapted[-1][0], final, atol=1e-6)
    assert not all(np.array_equal(a, b) for a, b in zip(adapted[:16], adapted[19:35]))
    with pytest.raises(ValueError, match="assimilate_from"):
        run_pour([0], assimilate_from="both")


def test_cli_writes_the_issue_json_and_the_figure(tmp_path, monkeypatch, saved_figures, pour_demo_file):
    monkeypatch.setenv("ACNMP_CACHE", str(pour_demo_file.parent))
    out, png = tmp_path / "e6.json", tmp_path / "e6.png"
    code = main(["experiment", "pour", "--seeds", "1", "--train-steps", "100", "--budget", "3", "--no-assimilation",
                 "--json", str(out), "--plot", str(png), "--quiet"])
    assert code == 0
    r = json.loads(out.read_text())
    assert r["experiment"] == "pour" and r["seeds"] == 1 and r["test"] == {"weight_g": 1400.0, "target_g": 1322.0}
    assert r["lfd_only"]["error_g"] >= 0
    a = r["acnmp"]
    assert len(a["errors_g_per_rollout"]) == 1 and 1 <= len(a["errors_g_per_rollout"][0]) <= 3
    assert a["errors_g_per_rollout"][0][0] == r["lfd_only"]["error_g"]  # the first roll-out is the LfD one
    assert set(a) >= {"rollouts_median", "success_rate", "final_error_g_median"}
    assert set(r["assimilation"]) >= {"error_g_no_rl", "demos_reproduced_within_30g"}
    assert r["assimilation"]["seeds_assimilated"] == 0 and r["assimilation"]["lfd_demos_reproduced_within_30g"] is None
    assert r["rollout_cpu_s_median"] > 0 and r["wall_time_s"] > 0
    assert [p for _, p in saved_figures] == [png]
    ax = saved_figures[0][0].axes[0]
    dots = ax.get_lines()[0]
    assert dots.get_ydata().tolist() == a["errors_g_per_rollout"][0]


def test_bad_cli_input_is_a_clear_error(capsys):
    assert main(["experiment", "pour", "--seeds", "0"]) == 2
    err = capsys.readouterr().err
    assert "--seeds" in err and len(err.strip().splitlines()) == 1
    for jobs in ("0", "-1", "x", "99999999999999999999"):  # refused while parsing, before any training
        assert main(["experiment", "pour", "--jobs", jobs]) == 2
        err = capsys.readouterr().err
        assert "--jobs" in err and len(err.strip().splitlines()) == 1


def _without_timings(result):
    """A run_pour result without what differs between two identical runs (wall and CPU times, jobs)."""
    r = {k: v for k, v in result.items() if k not in ("wall_time_s", "rollout_cpu_s_median", "config")}
    r["runs"] = [{k: v for k, v in run.items() if k != "time_s"} for run in result["runs"]]
    return r


@pytest.mark.slow
def test_seeds_in_parallel_processes_give_the_serial_result(pour_demo_file):
    """jobs=2: two seeds in two spawned processes, each on its own rig, same result as one after the other."""
    # Per-step noise: after 20 training steps E6's demonstration-shaped noise moves the pour by less
    # than a marble, so both seeds would pour alike and the comparison below would prove nothing.
    kw = dict(train_steps=20, adapt_config=replace(e6_adapt_config(2), noise="rbf"), assimilate_solution=False,
              demo_path=str(pour_demo_file))
    serial, parallel = run_pour([1, 0], **kw), run_pour([1, 0], jobs=2, **kw)
    assert [r["seed"] for r in parallel["runs"]] == [1, 0]
    per_rollout = serial["acnmp"]["errors_g_per_rollout"]  # the LfD roll-out and a noisy one per seed
    assert [len(e) for e in per_rollout] == [2, 2] and per_rollout[0] != per_rollout[1]  # the seeds differ ...
    assert _without_timings(parallel) == _without_timings(serial)  # ... and each is the serial one
    assert parallel["config"]["jobs"] == 2 and parallel["rollout_cpu_s_median"] > 0


def test_parallel_seeds_refuse_a_remote_evaluator_and_distributed(capsys):
    import pytest

    with pytest.raises(ValueError, match="jobs"):
        run_pour([0, 1], jobs=2, evaluator_factory=_PoursExactly)
    assert main(["experiment", "pour", "--jobs", "2", "--distributed"]) == 2
    err = capsys.readouterr().err
    assert "--jobs" in err and len(err.strip().splitlines()) == 1
