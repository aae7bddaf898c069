"""Each method of the peers comparison on one task at one test condition, as a :class:`~.config.PeerRun`.

* ``lfd``, ``acnmp``: the product's default model (a CNMP that chooses from its demonstrations
  whether the demonstrations' linear trend carries it beyond their range or the network alone does,
  :class:`~acnmp_core.model.cnmp.CNMPConfig`'s defaults) conditioned on the test condition and executed
  once, then adapted with the default :class:`~acnmp_core.adaptation.config.AdaptConfig`;
* ``lfd_paper``, ``acnmp_paper``: the paper's method (the CNMP alone, ``prior="none"``, adapted with
  :meth:`AdaptConfig.paper`);
* ``lfd_linear``, ``acnmp_linear``: the default of the previous round (the linear path beside the
  network always, the default adaptation), kept so its verdict stays measured;
* ``promp_rl``: the project's adaptive ProMP + episodic REPS from the nearest demonstration (E2's settings);
* ``promp_cma``, ``promp_cma5``: black-box ProMP + CMA-ES (fancy_gym's recipe) from the
  demonstrations' ProMP conditioned on the test condition, with the basis count chosen by
  leave-one-out error on the demonstrations and with fancy_gym's 5;
* ``ppo_bc``, ``ppo``, ``sac_bc``, ``sac``: stable-baselines3 on the task's step-based environment.

Every method's episodes count until its deterministic output first succeeds (the model's or the
distribution's mean, the deterministic policy), the evaluation episodes included.
"""
from __future__ import annotations

import copy
import time
from dataclasses import dataclass
from typing import Callable

from ...adaptation.config import AdaptConfig
from .config import PeersConfig, PeerRun
from .tasks import PeerTask


@dataclass(frozen=True)
class Variant:
    """An ACNMP variant: the model's linear path (``CNMPConfig.prior`` and ``prior_clip``) and its
    adaptation settings (``adapt(budget) -> AdaptConfig``)."""

    prior: str
    adapt: Callable[[int], AdaptConfig]
    clip: bool = True


#: the product's default, the paper's method and the previous default; the LfD-only methods execute
#: their model's first mean
VARIANTS = {"acnmp": Variant("auto", lambda budget: AdaptConfig(max_rollouts=budget)),
            "acnmp_paper": Variant("none", lambda budget: AdaptConfig.paper(max_rollouts=budget)),
            "acnmp_linear": Variant("linear", lambda budget: AdaptConfig(max_rollouts=budget))}
#: which variant's model each LfD-only method executes
LFD_OF = {"lfd": "acnmp", "lfd_paper": "acnmp_paper", "lfd_linear": "acnmp_linear"}


def model_config(task: PeerTask, prior: str, clip: bool = True):
    """A default-size :class:`~acnmp_core.model.cnmp.CNMPConfig` for ``task``'s demonstrations, its
    outputs and task parameters named as they are, with ``prior`` and ``prior_clip`` ``clip``."""
    from ...model.cnmp import CNMPConfig

    a = task.arrays
    names = lambda arr: () if arr is None else tuple(str(n) for n in arr)  # noqa: E731
    return CNMPConfig(n_outputs=a.values.shape[2], n_task_params=a.task_params.shape[1],
                      output_names=names(a.value_names), task_param_names=names(a.task_param_names), prior=prior,
                      prior_clip=clip)


def train_model(task: PeerTask, seed: int, steps: int, prior: str, clip: bool = True):
    """A CNMP of :func:`model_config` trained ``steps`` steps on ``task``'s demonstrations (seed ``seed``)."""
    from ...model.cnmp import CNMP
    from ...model.training import TrainConfig, train

    model = CNMP(model_config(task, prior, clip), seed=seed)
    train(model, task.arrays.to_demo_set(), TrainConfig(steps=steps), seed=seed)
    return model


def _model(task: PeerTask, config: PeersConfig, seed: int, variant: Variant, state: dict):
    """The seed's model of ``variant``, trained once for both cases and every variant with this
    model (kept in ``state``). The default's model ("auto") is the model of the prior its choice
    names, trained with the same seed: training "auto" chooses (its held-out folds), then trains
    exactly that model (the tests check it), so the choice is made here and the chosen model is
    shared with the variant that names its prior. A "trend" model is the paper's network ("none",
    the same seed) with the demonstrations' linear path fitted beside it: its training is the
    paper's network's to the bit (the trend adds nothing inside the range it trains on). A model's
    time counts what it needed that was not yet there."""
    key = (task.name, seed, variant.prior, variant.clip)
    if key not in state:
        for old in [k for k in state if k[:2] != key[:2]]:  # only this seed's models are kept
            del state[old]
        t0 = time.perf_counter()
        if variant.prior == "auto":
            from ...model.selection import choose_prior
            from ...model.training import TrainConfig, fold_trainer

            choice = choose_prior(task.arrays.to_demo_set(), model_config(task, "auto", variant.clip),
                                  fold_trainer(TrainConfig(steps=config.train_steps), seed), seed)
            chosen = _model(task, config, seed, Variant(choice.chosen, variant.adapt, variant.clip), state)[0]
            model = copy.deepcopy(chosen)
            model.config.prior_choice = choice
            state[key] = (model, round(time.perf_counter() - t0, 2))
        elif variant.prior == "trend":
            model = copy.deepcopy(_model(task, config, seed, Variant("none", variant.adapt), state)[0])
            model.config = model_config(task, "trend", variant.clip)
            model.fit_prior(task.arrays.to_demo_set())
            state[key] = (model, round(time.perf_counter() - t0, 2))
        else:
            state[key] = (train_model(task, seed, config.train_steps, variant.prior, variant.clip),
                          round(time.perf_counter() - t0, 2))
    return state[key]


def acnmp_run(task: PeerTask, config: PeersConfig, seed: int, case: str, method: str, state: dict,
              variants: dict[str, Variant] = VARIANTS) -> PeerRun:
    """An ACNMP variant (or the LfD only of its model) at ``seed``'s ``case``."""
    from ..push import run_acnmp_target

    variant = variants[LFD_OF.get(method, method)]
    model, train_s = _model(task, config, seed, variant, state)
    target = task.target(seed, case)
    budget = config.budget_of(method)
    t0 = time.perf_counter()
    r = run_acnmp_target(copy.deepcopy(model), task.arrays.to_demo_set(), target, task.evaluator(method),
                         variant.adapt(budget), seed)
    details = {"final_error": r["final_error"], "lfd_error": r["lfd_error"], "train_s": train_s, "curve": r["curve"],
               "prior": model.config.prior, "prior_basis": model.config.prior_basis}
    if model.config.prior_choice is not None:
        details["prior_choice"] = {"chosen": model.config.prior_choice.chosen, "errors": model.config.prior_choice.errors}
    expert = task.expert_path(seed, case)
    if method in LFD_OF and expert is not None:
        details["path_error_to_expert"] = task.path_error(model.predict_query(target.query(model)).mean, expert)
    return PeerRun(task.name, method, seed, case, task.params(seed, case).tolist(), int(r["rollouts"]),
                   bool(r["success"]), budget, round(time.perf_counter() - t0, 2), details)


def promp_rl_run(task: PeerTask, config: PeersConfig, seed: int, case: str, method: str = "promp_rl") -> PeerRun:
    """The project's adaptive ProMP + REPS (E2's settings) from the demonstration nearest in task
    parameters, on ``method``'s reward (``promp_rl`` or its dense twin)."""
    from dataclasses import replace

    from ...baselines.promp_rl import PrompRLConfig
    from ..push import PROMP_DEFAULTS, PushSetup, run_promp_case

    a = task.arrays
    setup = PushSetup(demos=a.to_demo_set(), targets={case: task.params(seed, case)}, times=task.times.copy(),
                      q0=task.q0, n_joints=a.values.shape[2], demo_arrays=a)
    cfg = replace(PrompRLConfig(**{**PROMP_DEFAULTS, "max_rollouts": config.budget}), seed=seed)
    t0 = time.perf_counter()
    r = run_promp_case(setup, case, task.evaluator(method), cfg)
    return PeerRun(task.name, method, seed, case, task.params(seed, case).tolist(), int(r["rollouts"]),
                   bool(r["success"]), config.budget, round(time.perf_counter() - t0, 2),
                   {"final_error": r["final_error"], "lfd_error": r["lfd_error"], "curve": r["curve"]})


def promp_cma_run(task: PeerTask, config: PeersConfig, seed: int, case: str, method: str) -> PeerRun:
    """Black-box ProMP + CMA-ES with the task's chosen basis count (``promp_cma``) or fancy_gym's 5
    (``promp_cma5``), or their dense-reward twins."""
    from ...peers.black_box import N_BASIS, BlackBoxConfig, DemoProMP, run_black_box

    n_basis = task.cma_basis if method.removesuffix("_dense") == "promp_cma" else N_BASIS
    a, target = task.arrays, task.target(seed, case)
    t0 = time.perf_counter()
    promp = DemoProMP(task.times, a.values, a.task_params, n_basis)
    r = run_black_box(promp, task.evaluator(method), target, BlackBoxConfig(budget=config.budget, n_basis=n_basis),
                      seed)
    details = {"final_error": r.curve[-1][1], "lfd_error": r.curve[0][1], "curve": r.curve, "sigma0": r.sigma0,
               "dimension": r.dimension, "n_basis": n_basis}
    expert = task.expert_path(seed, case)
    if expert is not None:
        details["path_error_to_expert"] = task.path_error(r.start, expert)
    return PeerRun(task.name, method, seed, case, task.params(seed, case).tolist(), r.episodes, r.success,
                   config.budget, round(time.perf_counter() - t0, 2), details)


def step_based_run(task: PeerTask, config: PeersConfig, seed: int, case: str, method: str) -> PeerRun:
    """A stable-baselines3 method (``ppo``, ``ppo_bc``, ``sac``, ``sac_bc``) on the task's step-based environment."""
    from ...peers.step_based import StepBasedConfig, run_step_based

    params = task.params(seed, case)
    algorithm, _, warm = method.partition("_")
    cfg = StepBasedConfig(algorithm, config.budget, eval_every=config.eval_every, warm_start=warm or None,
                          bc_steps=config.bc_steps)
    t0 = time.perf_counter()
    r = run_step_based(lambda: task.step_env(params), cfg, seed, task.transitions if warm else None)
    return PeerRun(task.name, method, seed, case, params.tolist(), r.episodes, r.success, config.budget,
                   round(time.perf_counter() - t0, 2),
                   {"final_error": r.curve[-1][1] if r.curve else None, "lfd_error": r.curve[0][1] if r.curve else None,
                    "curve": r.curve, "train_episodes": r.train_episodes, "eval_episodes": r.eval_episodes,
                    "bc_loss": r.bc_loss})


def run_method(task: PeerTask, config: PeersConfig, seed: int, case: str, method: str, state: dict) -> PeerRun:
    """``method`` on ``task`` at ``seed``'s ``case`` (``state`` keeps the seed's trained models)."""
    if method in VARIANTS or method in LFD_OF:
        return acnmp_run(task, config, seed, case, method, state)
    if method.removesuffix("_dense") == "promp_rl":
        return promp_rl_run(task, config, seed, case, method)
    if method.removesuffix("_dense") in ("promp_cma", "promp_cma5"):
        return promp_cma_run(task, config, seed, case, method)
    return step_based_run(task, config, seed, case, method)
