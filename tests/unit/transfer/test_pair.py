"""E4 in small: the transfer pair aligns paired latents only with its alignment term, robot B's
decoder reproduces a skill shown on robot A only, adapt() trains B's decoder alone, the cube task's
reward falls with the cube's distance to the goal, and everything is deterministic given a seed."""
from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from acnmp_core.adaptation.loop import adapt
from acnmp_core.adaptation.config import AdaptConfig, AdaptTarget
from acnmp_core.data.demos import DemoSet
from acnmp_core.experiments.transfer import summarise
from acnmp_core.experiments.plots import plot_transfer
from acnmp_core.tasks.push.demos import follow_poses, ik_from_seeds
from acnmp_core.tasks.transfer.demos import home_pose, new_skill_path
from acnmp_core.tasks.transfer.scene import CubeGapScene, CubeGapTask, transfer_geometry
from acnmp_core.transfer.pair import TransferConfig, TransferPair, TransferredSkill, spread_observations, train_pair

torch.set_num_threads(1)
T = 60
TIMES = np.linspace(0.0, 1.0, T)
TRAIN_S = np.linspace(0.0, 1.0, 8)
HELD_OUT_S = 0.8  # between two training skills, where their mean is no answer


def skill_a(s: float) -> np.ndarray:
    """(T, 3) robot A's trajectory of the skill with parameter s."""
    return np.stack([s * np.sin(np.pi * TIMES), (1 - s) * TIMES, 0.5 * s * TIMES**2], axis=1)


def skill_b(s: float) -> np.ndarray:
    """(T, 4) robot B's trajectory of the same skill (a different robot: other outputs)."""
    return np.stack([np.cos(np.pi * TIMES) * (0.3 + s), -s * TIMES, (1 - s) * np.sin(np.pi * TIMES),
                     s**2 * TIMES], axis=1)


def demos(fn) -> DemoSet:
    return DemoSet.from_arrays(np.tile(TIMES, (len(TRAIN_S), 1)), np.stack([fn(s) for s in TRAIN_S]))


CFG = TransferConfig(latent_weight=300.0, steps=300, batch_size=16, widths=(32, 32, 16), lr=3e-3)


def trained(weight: float, seed: int = 0, steps: int = CFG.steps) -> tuple[TransferPair, list[float]]:
    cfg = TransferConfig(**{**CFG.to_dict(), "latent_weight": weight, "steps": steps})
    pair = TransferPair(3, 4, cfg, seed=seed)
    res = train_pair(pair, demos(skill_a), demos(skill_b), cfg, seed=seed)
    return pair, res.nll_b


@pytest.fixture(scope="module")
def pairs():
    return {"aligned": trained(CFG.latent_weight)[0], "plain": trained(0.0)[0]}


def paired_distance(pair: TransferPair) -> float:
    """Mean |r_A - r_B| over the training pairs, relative to the mean distance between A's latents."""
    ra = np.stack([pair.latent_a(TIMES, skill_a(s)) for s in TRAIN_S])
    rb = np.stack([pair.latent_b(TIMES, skill_b(s)) for s in TRAIN_S])
    spread = np.linalg.norm(ra[:, None] - ra[None], axis=2)[np.triu_indices(len(ra), 1)].mean()
    return float(np.linalg.norm(ra - rb, axis=1).mean() / spread)


def test_latents_of_paired_demos_align_with_the_term_only(pairs):
    assert paired_distance(pairs["aligned"]) < 0.2
    assert paired_distance(pairs["plain"]) > 0.5


def test_b_decoder_reproduces_a_skill_shown_on_a_only(pairs):
    ot, ov = spread_observations(TIMES, skill_a(HELD_OUT_S), 11)
    truth = skill_b(HELD_OUT_S)
    err = {k: float(np.sqrt(np.mean((p.transfer(ot, ov, TIMES).mean - truth) ** 2))) for k, p in pairs.items()}
    pred = pairs["aligned"].transfer(ot, ov, TIMES)
    assert pred.mean.shape == (T, 4) and pred.std.shape == (T, 4) and pred.latent.shape == (16,)
    mean_demo = float(np.sqrt(np.mean((np.stack([skill_b(s) for s in TRAIN_S]).mean(0) - truth) ** 2)))
    assert err["aligned"] < 0.5 * mean_demo  # B gets the skill, not an average of its own demos
    assert err["aligned"] < 0.5 * err["plain"]


def test_training_is_deterministic_given_the_seed():
    a, la = trained(CFG.latent_weight, seed=3, steps=30)
    b, lb = trained(CFG.latent_weight, seed=3, steps=30)
    assert la == lb
    for x, y in zip(a.model_b.state_dict().values(), b.model_b.state_dict().values()):
        assert torch.equal(x, y)
    assert trained(CFG.latent_weight, seed=4, steps=30)[1] != la


def test_rl_in_b_trains_b_decoder_only():
    view = TransferredSkill(trained(CFG.latent_weight, steps=30)[0])
    before = {k: v.clone() for k, v in {**{f"a.{k}": v for k, v in view.model_a.state_dict().items()},
                                        **{f"b.{k}": v for k, v in view.model_b.state_dict().items()}}.items()}
    ot, ov = spread_observations(TIMES, skill_a(HELD_OUT_S), 11)
    goal = skill_b(HELD_OUT_S) + 0.3  # something the transferred trajectory misses

    class Track:  # a kinematic evaluator: reward minus the distance to the shifted trajectory per step
        def evaluate(self, trajs, times, task_params=None):
            from acnmp_core.rollout import RolloutBatch

            d = np.linalg.norm(np.asarray(trajs) - goal, axis=2)
            return RolloutBatch(rewards=-d, success=np.zeros(len(trajs), bool), errors=d.mean(1))

    res = adapt(view, demos(skill_b), AdaptTarget(ot, ov, None, TIMES), Track(),
                AdaptConfig(max_rollouts=6, noisy_per_iter=1), seed=0, params=view.decoder_parameters())
    assert res.trajectory.shape == (T, 4) and res.rollouts == 6
    after = {**{f"a.{k}": v for k, v in view.model_a.state_dict().items()},
             **{f"b.{k}": v for k, v in view.model_b.state_dict().items()}}
    changed = {k for k in before if not torch.equal(before[k], after[k])}
    assert changed and all(k.startswith("b.decoder.") for k in changed)


@pytest.fixture(scope="module")
def cube_task():
    with CubeGapTask(3) as task:
        yield task


def test_cube_task_reward_falls_with_the_distance_to_the_goal(cube_task):
    scene, geom = CubeGapScene(), transfer_geometry(3)
    q_home = ik_from_seeds(home_pose(scene), geom)
    times = np.linspace(0.0, 1.0, 300)
    push = follow_poses(new_skill_path(scene, scene.goal_xy, geom), geom, q_home)  # straight to the goal
    stay = np.tile(q_home, (300, 1))  # never touches the cube
    batch = cube_task.evaluate(np.stack([push, stay]), times)
    cube = batch.states["object_xy"]
    dist = np.linalg.norm(cube - np.asarray(scene.goal_xy), axis=2)
    np.testing.assert_allclose(batch.rewards, -dist / 300)
    assert batch.errors[0] < batch.errors[1] and batch.returns[0] > batch.returns[1]
    assert batch.errors[1] == pytest.approx(np.linalg.norm(np.subtract(scene.cube_xy, scene.goal_xy)), abs=1e-3)
    assert batch.success.tolist() == [bool(batch.errors[0] < 0.015), False]
    assert scene.gap_width == pytest.approx(0.039, abs=5e-4)


def test_summary_counts_success_within_k_iterations(tmp_path):
    runs = [{"condition": "transfer", "iterations": i, "success": i is not None, "rollouts": 2 * (i or 20) + 1,
             "initial_error": 0.03, "initial_rmse_to_expert": 0.1, "curve": [[0, 0.03], [i or 19, 0.01]]}
            for i in (0, 3, 8, None)]
    s = summarise(runs)
    assert s["success_by_iteration"] == {"3": 0.5, "7": 0.5, "11": 0.75, "19": 0.75}
    assert s["iterations_median"] == 5.5 and s["success_rate"] == 0.75
    result = {"runs": 4, "per_run": runs, "paper": {"success_by_iteration": {"3": 0.23, "19": 1.0}}}
    out = plot_transfer(json.loads(json.dumps(result)), tmp_path / "e4.png")
    assert out.exists() and out.stat().st_size > 0


def test_an_authors_data_directory_without_their_arrays_is_refused_before_any_training(tmp_path, capsys):
    from clients.cli import main

    assert main(["experiment", "transfer", "--seeds", "1", "--authors-data", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert f"--authors-data {tmp_path}: the authors' four E4 arrays are not all there" in err


def test_checkpoints_beyond_the_iterations_run_are_not_reported(tmp_path):
    """Issue 36 row 6: with --budget 6 (2 RL iterations) the table printed 0 % "after 7/11/19" and
    the plot ran to iteration 19; a checkpoint no unfinished run reached is now None ("not run"),
    and the plot ends at the last iteration run."""
    from acnmp_core.experiments.transfer import summarise
    from acnmp_core.experiments.plots import plot_transfer

    def run(success_at, last):
        return {"iterations": success_at, "success": success_at is not None, "rollouts": 2 * last + 1,
                "initial_error": 0.05, "initial_rmse_to_expert": 0.1, "curve": [[i, 0.05] for i in range(last + 1)]}

    short = summarise([run(None, 2), run(1, 1)])
    assert short["success_by_iteration"] == {"3": None, "7": None, "11": None, "19": None}
    full = summarise([run(None, 19), run(5, 5)])
    assert full["success_by_iteration"] == {"3": 0.0, "7": 0.5, "11": 0.5, "19": 0.5}
    result = {"runs": 2, "per_run": [{**run(None, 2), "condition": "transfer"}],
              "paper": {"success_by_iteration": {"3": 0.23, "7": 0.73, "11": 0.9, "19": 1.0}}}
    import matplotlib.pyplot as plt

    shown = {}
    real_savefig = plt.Figure.savefig

    def savefig(self, *a, **k):
        shown["xmax"] = max(max(line.get_xdata(), default=0) for line in self.axes[0].get_lines())
        return real_savefig(self, *a, **k)

    plt.Figure.savefig = savefig
    try:
        plot_transfer(result, tmp_path / "t.png")
    finally:
        plt.Figure.savefig = real_savefig
    assert shown["xmax"] == 2


@pytest.mark.parametrize("prior", ["auto", "trend"])
def test_a_pair_of_default_models_decodes_with_each_arm_s_path_as_the_arms_predict(prior):
    """A pair whose arms are one default model (``auto``; and ``trend``, whose path adds beyond the
    range: a via-point above every demonstration) transfers exactly what the model predicts itself:
    robot A's observations encoded as A encodes them, robot B's path given them; a robot B with a
    path and other outputs than A's is refused (its path needs observations of its own outputs)."""
    from acnmp_core.errors import InputError
    from acnmp_core.model.cnmp import CNMP, CNMPConfig
    from acnmp_core.model.training import TrainConfig, train
    from acnmp_core.tasks.viapoint.task import obstacle_demos
    from acnmp_core.transfer.pair import TransferPair

    demos = obstacle_demos()
    model = CNMP(CNMPConfig(n_outputs=2, encoder_widths=(32, 32), decoder_widths=(32, 32), prior=prior), seed=0)
    train(model, demos, TrainConfig(steps=200), seed=0, progress=False)
    assert model.config.prior in ("trend", "none") and (model.prior is not None) == (model.config.prior == "trend")
    pair = TransferPair.from_models(model, model)
    times, obs = np.array([0.0, 0.25, 1.0]), np.array([[0.0, 0.0], [0.25, 0.9], [1.0, 0.0]])
    query_times = np.linspace(0.0, 1.0, 50)
    mine = model.predict(times, obs, None, query_times)
    moved = pair.transfer(times, obs, query_times)
    np.testing.assert_allclose(moved.mean, mine.mean, atol=1e-6)
    np.testing.assert_allclose(moved.latent, mine.latent, atol=1e-6)
    other = CNMP(CNMPConfig(n_outputs=2, output_names=("q1", "q2"), encoder_widths=(32, 32),
                            decoder_widths=(32, 32), prior="trend"), seed=1)
    other.fit_normalization(demos)
    with pytest.raises(InputError, match="linear path is conditioned on observations of its own outputs"):
        TransferPair.from_models(model, other)
