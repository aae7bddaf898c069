"""The peers and ``acnmp experiment peers``: the accounting, not the outcome. Episodes are counted with
the evaluation episodes, budgets are honoured, a run that did not succeed is marked censored and shown
as "> budget" (never as a number it did not reach), a method that does not apply to a task is left
out and named, the result is written after every run and resumed, and bad inputs are one line with
exit 2."""
from __future__ import annotations

import json

import numpy as np
import pytest

from acnmp_core.errors import InputError
from acnmp_core.adaptation.config import AdaptTarget
from acnmp_core.experiments.peers import PeerRun, PeersConfig, merge_results, plan, summarise
from acnmp_core.rollout import RolloutBatch


class _Counting:
    """An evaluator that counts the trajectories it executes and succeeds from the ``succeed_at``-th on."""

    def __init__(self, succeed_at: int | None = None):
        self.executed = 0
        self.succeed_at = succeed_at

    def evaluate(self, trajectories, times, task_params=None):
        n, t, _ = np.shape(trajectories)
        index = self.executed + np.arange(1, n + 1)
        self.executed += n
        success = np.zeros(n, dtype=bool) if self.succeed_at is None else index >= self.succeed_at
        rewards = -np.abs(np.asarray(trajectories)).mean(axis=(1, 2))[:, None] * np.ones((n, t))
        return RolloutBatch(rewards=rewards, success=success, errors=np.ones(n))


def _run(method="acnmp", seed=0, episodes=10, success=True, budget=400, case="extrapolation", task="metaworld-reach"):
    return PeerRun(task, method, seed, case, [0.0], episodes, success, budget, 1.0)


def test_a_censored_run_is_shown_as_beyond_its_budget_and_a_censored_median_is_no_number():
    runs = [_run(episodes=30), _run(seed=1, episodes=400, success=False), _run(seed=2, episodes=400, success=False)]
    assert [r.shown for r in runs] == ["30", "> 400", "> 400"]
    assert [r.to_json()["censored"] for r in runs] == [False, True, True]
    s = summarise(runs)["metaworld-reach"]["extrapolation"]["acnmp"]
    assert s["successes"] == 1 and s["median_episodes"] is None and s["median_shown"] == "> 400"
    s = summarise(runs[:2] + [_run(seed=2, episodes=50)])["metaworld-reach"]["extrapolation"]["acnmp"]
    assert s["median_episodes"] == 50 and s["median_shown"] == "50"


def test_every_adaptive_method_has_the_same_budget_and_lfd_one_episode():
    config = PeersConfig(tasks=("metaworld-reach",), budget=321)
    assert {m: config.budget_of(m) for m in ("lfd", "lfd_paper", "acnmp", "promp_cma", "ppo_bc")} == {
        "lfd": 1, "lfd_paper": 1, "acnmp": 321, "promp_cma": 321, "ppo_bc": 321}


def test_a_method_that_does_not_apply_to_a_task_is_left_out_of_the_plan():
    config = PeersConfig(tasks=("e1-viapoint", "e2-push"), methods=("lfd", "promp_rl", "ppo_bc"), seeds=(0,))
    assert plan(config) == [("e1-viapoint", 0, "extrapolation", "lfd"),
                            ("e2-push", 0, "extrapolation", "lfd"), ("e2-push", 0, "extrapolation", "promp_rl"),
                            ("e2-push", 0, "interpolation", "lfd"), ("e2-push", 0, "interpolation", "promp_rl"),
                            ("e2-push", 0, "extrapolation", "ppo_bc"), ("e2-push", 0, "interpolation", "ppo_bc")]


def test_black_box_cma_counts_every_mean_and_population_episode_and_stops_at_its_budget():
    pytest.importorskip("cma")
    pytest.importorskip("mp_pytorch")
    from acnmp_core.peers.black_box import BlackBoxConfig, DemoProMP, run_black_box

    rng = np.random.default_rng(0)
    times = np.linspace(0.0, 1.0, 30)
    params = rng.uniform(-1, 1, (6, 2))
    values = np.stack([np.c_[p[0] * times, p[1] * times ** 2] for p in params]) + 0.01 * rng.normal(size=(6, 30, 2))
    promp = DemoProMP(times, values, params)
    at = AdaptTarget(np.zeros(0), np.zeros((0, 2)), np.array([0.5, 0.5]), times)
    for budget in (1, 2, 9, 25):
        ev = _Counting()
        r = run_black_box(promp, ev, at, BlackBoxConfig(budget=budget), seed=0)
        assert (r.episodes, r.success, ev.executed) == (budget, False, budget)
    ev = _Counting(succeed_at=1)
    r = run_black_box(promp, ev, at, BlackBoxConfig(budget=50), seed=0)
    assert (r.episodes, r.success, ev.executed) == (1, True, 1)
    # the mean is executed first in every generation: success at the third generation's mean
    pop = 4 + int(3 * np.log(promp.weights.shape[1]))
    ev = _Counting(succeed_at=2 * (1 + pop) + 1)
    r = run_black_box(promp, ev, at, BlackBoxConfig(budget=500), seed=0)
    assert r.success and r.episodes == ev.executed == 2 * (1 + pop) + 1 and len(r.curve) == 3
    # the conditioned mean is the linear regression of the weights on the task parameters
    fit = np.linalg.lstsq(np.c_[np.ones(6), params], promp.weights, rcond=None)[0]
    np.testing.assert_allclose(promp.conditioned_mean(np.array([0.3, -0.2])), np.r_[1.0, 0.3, -0.2] @ fit, atol=1e-8)
    # conditioned on a point of the family instead (parameters 0.6, -0.4 at t = 0.5), its mean passes
    # through it within the demonstrations' fit residual, and is that member of the family
    w = promp.conditioned_mean(None, np.array([0.5]), np.array([[0.3, -0.1]]))
    np.testing.assert_allclose(promp.trajectories_at(w, np.array([0.5]))[0, 0], [0.3, -0.1], atol=0.02)
    np.testing.assert_allclose(promp.trajectories(w)[0], np.c_[0.6 * times, -0.4 * times ** 2], atol=0.05)


def test_promp_cma_s_basis_count_is_chosen_on_the_demonstrations_alone():
    """Demonstrations an amplitude times one two-bump shape (E1's kind): the ProMP needs enough basis
    functions for the shape, and the leave-one-out choice finds them from the demonstrations; no
    test position enters the choice (the function is given none)."""
    pytest.importorskip("mp_pytorch")
    from acnmp_core.peers.black_box import choose_n_basis

    times = np.linspace(0.0, 1.0, 80)
    shape = np.exp(-((times - 0.25) ** 2) / 0.01) + np.exp(-((times - 0.75) ** 2) / 0.01)
    amps = np.array([0.2, 0.4, 0.6, -0.2, -0.4, -0.6])
    values = amps[:, None, None] * shape[None, :, None]
    n, errors = choose_n_basis(times, values, amps[:, None], candidates=(3, 5, 10, 20))
    assert n in (10, 20) and errors[n] < 0.2 * errors[3] and set(errors) == {3, 5, 10, 20}


@pytest.mark.parametrize("algorithm, warm", [("ppo", "bc"), pytest.param("ppo", None, marks=pytest.mark.slow),
                                             pytest.param("sac", "bc", marks=pytest.mark.slow)])
def test_sb3_counts_training_and_evaluation_episodes_and_honours_its_budget(algorithm, warm):
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("metaworld")
    from acnmp_core.peers.step_based import StepBasedConfig, run_step_based
    from acnmp_core.tasks.metaworld.demos import expert_transitions

    from acnmp_core.tasks.metaworld.scene import fixed_task_env

    demos = expert_transitions("metaworld-reach", n=2) if warm else None
    cfg = StepBasedConfig(algorithm, budget=4, eval_every=1, warm_start=warm, bc_steps=5)
    r = run_step_based(lambda: fixed_task_env("metaworld-reach", np.array([0.24, 0.85, 0.2])), cfg, seed=0,
                       demonstrations=demos)
    assert r.episodes <= 4 and r.episodes == r.train_episodes + r.eval_episodes
    assert r.eval_episodes == len(r.curve) and r.curve[0][0] == 1  # the first evaluation is episode 1
    assert [c[0] for c in r.curve] == sorted(c[0] for c in r.curve)
    if not r.success:
        assert r.episodes == 4
    assert (r.bc_loss is not None) == (warm == "bc")


def test_the_runs_are_planned_trajectory_methods_first_written_one_by_one_and_resumed(tmp_path):
    """The orchestration with stand-in methods (no simulator): the SB3 runs come after every trajectory
    run; the file holds every run as soon as it finished; a resumed run skips what the file holds;
    parts merge, and the runs a part planned and none made are listed as not run."""
    from acnmp_core.experiments import peers

    out = tmp_path / "peers.json"
    ran = []

    class FakeTask:
        cases = ("extrapolation", "interpolation")

        def __init__(self, kind):
            self.name = kind

        def chosen_settings(self):
            return {"promp_cma_basis": 7}

        def close(self):
            pass

    def run_method(task, config, seed, case, method, state):
        ran.append((method, seed, case))
        if out.exists():  # every earlier run is already in the file
            assert len(json.loads(out.read_text())["runs"]) == len(ran) - 1 + resumed_from[0]
        success = method != "ppo"
        return PeerRun(task.name, method, seed, case, [0.0], 10 * (seed + 1) if success else config.budget, success,
                       config.budget_of(method), 0.1)

    resumed_from = [0]
    config = PeersConfig(tasks=("metaworld-reach",), methods=("acnmp", "ppo", "lfd"), seeds=(0, 2),
                         cases=("extrapolation",), budget=400)
    result = peers.run_peers(config, out=out, run_method=run_method, make_task=FakeTask)
    assert ran == [("lfd", 0, "extrapolation"), ("acnmp", 0, "extrapolation"), ("lfd", 2, "extrapolation"),
                   ("acnmp", 2, "extrapolation"), ("ppo", 0, "extrapolation"), ("ppo", 2, "extrapolation")]
    assert [r["shown"] for r in result["runs"] if r["method"] == "ppo"] == ["> 400", "> 400"]
    assert json.loads(out.read_text())["runs"] == result["runs"] and result["not_run"] == []
    assert result["settings"] == {"metaworld-reach": {"promp_cma_basis": 7}}
    ran.clear()
    resumed_from[0] = 6
    more = PeersConfig(**{**config.__dict__, "seeds": (0, 1, 2)})
    resumed = peers.run_peers(more, out=out, resume=True, run_method=run_method, make_task=FakeTask)
    assert ran == [("lfd", 1, "extrapolation"), ("acnmp", 1, "extrapolation"), ("ppo", 1, "extrapolation")]
    assert len(resumed["runs"]) == 9
    # merged with another part; a run that part planned and did not make is listed as not run
    part = peers.run_peers(PeersConfig(tasks=("metaworld-reach",), methods=("lfd",), seeds=(5,),
                                       cases=("interpolation",)), run_method=run_method, make_task=FakeTask)
    part["not_run"] = [{"task": "metaworld-reach", "seed": 7, "case": "interpolation", "method": "lfd"}]
    merged = merge_results([resumed, part])
    assert len(merged["runs"]) == 10 and merged["config"]["seeds"] == [0, 1, 2, 5]
    assert merged["not_run"] == part["not_run"] and len(merged["parts"]) == 2
    with pytest.raises(ValueError, match="in two results"):
        merge_results([resumed, resumed])


@pytest.mark.slow
def test_the_experiment_writes_after_every_run_and_resume_runs_only_what_is_missing(tmp_path):
    pytest.importorskip("metaworld")
    pytest.importorskip("cma")
    from acnmp_core.experiments.peers import run_peers

    out = tmp_path / "peers.json"
    seen = []
    config = PeersConfig(tasks=("metaworld-reach",), methods=("lfd", "promp_cma"), seeds=(0,), cases=("interpolation",),
                         train_steps=20, budget=2)

    def on_run(r):  # the file already holds every run so far
        seen.append(r.method)
        assert [x["method"] for x in json.loads(out.read_text())["runs"]] == seen

    first = run_peers(config, out=out, on_run=on_run)
    assert seen == ["lfd", "promp_cma"]
    for r in first["runs"]:
        assert r["episodes"] <= r["budget"] and r["censored"] == (not r["success"])
        assert r["shown"] == (str(r["episodes"]) if r["success"] else f"> {r['budget']}")
        assert r["details"]["path_error_to_expert"] > 0
    assert first["runs"][0]["budget"] == 1 and first["not_run"] == []
    assert first["versions"]["mujoco"] == "3.3.0"
    assert first["settings"]["metaworld-reach"]["promp_cma_basis"] == first["runs"][1]["details"]["n_basis"]
    more = PeersConfig(**{**config.__dict__, "seeds": (0, 1)})
    seen.clear()
    resumed = run_peers(more, out=out, resume=True, on_run=lambda r: seen.append((r.method, r.seed)))
    assert seen == [("lfd", 1), ("promp_cma", 1)] and len(resumed["runs"]) == 4
    assert json.loads(out.read_text())["runs"] == resumed["runs"]
    merged = merge_results([{**resumed, "runs": resumed["runs"][:2]}, {**resumed, "runs": resumed["runs"][2:]}])
    assert len(merged["runs"]) == 4 and merged["summary"] == resumed["summary"]


@pytest.mark.slow
def test_every_peer_runs_end_to_end_at_the_quick_size(tmp_path, capsys):
    """``acnmp experiment peers --quick``: every method once on reach, the accounting of each run."""
    pytest.importorskip("stable_baselines3")
    from clients.cli import main

    out = tmp_path / "q.json"
    assert main(["experiment", "peers", "--quick", "--quiet", "--out", str(out), "--plot", str(tmp_path / "q.png")]) == 0
    result = json.loads(out.read_text())
    assert [r["method"] for r in result["runs"]] == ["lfd", "lfd_paper", "acnmp", "acnmp_paper", "promp_rl",
                                                     "promp_cma", "promp_cma5", "ppo_bc", "ppo", "sac_bc", "sac"]
    for r in result["runs"]:
        assert 1 <= r["episodes"] <= r["budget"] and r["censored"] == (not r["success"])
    assert {r["budget"] for r in result["runs"] if r["method"] not in ("lfd", "lfd_paper")} == {10}
    assert result["quick"] and (tmp_path / "q.png").stat().st_size > 0
    assert "metaworld-reach" in capsys.readouterr().out


@pytest.mark.parametrize("argv, expected", [
    (["--tasks", "metaworld-door"], "tasks: expected some of metaworld-reach"),
    (["--methods", "acnmp,dqn"], "methods: expected some of lfd"),
    (["--cases", "both"], "cases: expected some of extrapolation"),
    (["--resume"], "--resume: only with --out FILE"),
    (["--budget", "0"], "--budget"),
])
def test_bad_inputs_are_one_line_and_exit_2(argv, expected, capsys, tmp_path):
    from clients.cli import main

    assert main(["experiment", "peers", "--quiet", "--out", str(tmp_path / "x.json"), *argv]
                if argv != ["--resume"] else ["experiment", "peers", "--resume"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and expected in err[0], err
    assert not (tmp_path / "x.json").exists()


def test_reproduce_runs_the_peers_only_when_named(tmp_path, capsys):
    from clients.cli import main
    from clients.experiments.catalog import OPTIONAL, PAPER

    assert [e.ident for e in PAPER] == ["E1", "E2", "E3", "E4", "E5", "E6"]
    assert [e.name for e in OPTIONAL] == ["peers"] and OPTIONAL[0].quick == ("--quick",)
    assert main(["reproduce", "-o", str(tmp_path), "--with", "peer"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--with 'peer': expected some of peers" in err[0]
    assert list(tmp_path.iterdir()) == []


def test_demos_make_writes_a_kinds_scripted_demonstrations(tmp_path, capsys, monkeypatch):
    pytest.importorskip("metaworld")
    from acnmp_core.data.demo_io import load_demos
    from acnmp_core.tasks.metaworld import demos as mw_demos
    from clients.cli import main

    real = mw_demos.metaworld_demos
    monkeypatch.setattr(mw_demos, "metaworld_demos", lambda kind: real(kind, n=2, seed=7))  # 2 of the 12: cheaper

    assert main(["demos", "make", "metaworld-reach", "-o", str(tmp_path / "reach.npz")]) == 0
    assert "acnmp up --robot metaworld-reach --demos SKILL=" in capsys.readouterr().out
    demos = load_demos(tmp_path / "reach.npz")
    assert demos.values.shape[1:] == (100, 4) and demos.task_params.shape[1] == 3
    assert main(["demos", "make", "metaworld-door", "-o", str(tmp_path / "x.npz")]) == 2
    assert "invalid choice: 'metaworld-door'" in capsys.readouterr().err


@pytest.mark.parametrize("argv, expected", [
    (["--tasks", "metaworld-door"], "tasks: expected some of metaworld-reach"),
    (["--seeds", "a,b"], "--seeds: expected comma-separated integers"),
    (["--merge", "/nonexistent/part.json"], "--merge: "),
    (["--part", "3/2"], "--part: expected 1 <= K <= N"),
])
def test_the_benchmark_main_says_a_bad_input_in_one_line(argv, expected, capsys, tmp_path):
    from benchmarks.experiments.peers import main

    with pytest.raises(SystemExit) as exc:
        main([*argv, "--out", str(tmp_path / "x.json")])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert expected in err[-1] and "Traceback" not in "\n".join(err), err
    assert not (tmp_path / "x.json").exists()
