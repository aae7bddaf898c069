"""Black-box ProMP + CMA-ES: the weights of a ProMP as one action, searched by CMA-ES.

fancy_gym's recipe for episodic RL on any Gymnasium environment (Otto et al., "MP3: Movement
Primitive-based (Re-)Planning Policy", 2023; the ALRhub ``fancy_gym`` black-box wrapper): a ProMP
(Paraschos et al., NeurIPS 2013) from ``mp_pytorch`` maps a weight vector to a whole trajectory,
the environment executes it as one episode, and CMA-ES (Hansen 2016, "The CMA Evolution
Strategy: A Tutorial"; the ``cma`` package) searches the weights by the episodes' returns.
fancy_gym's Meta-World setting: 5 radial basis functions per output on a linear phase.

The search starts from the demonstrations' ProMP: the weights of every demonstration (least
squares, ``mp_pytorch``'s ``learn_mp_params_from_trajs``) with their task parameters form a joint
Gaussian; conditioned on the test position it gives the initial mean (Paraschos et al.'s
conditioning on a context, which for a joint Gaussian is a linear regression from task parameters
to weights). The initial step size is the demonstrations' weight spread (the mean of the weights'
standard deviations). CMA-ES runs with ``cma``'s defaults otherwise (population 4 + 3 ln n).

One generation executes the distribution's mean (the method's deterministic output, counted as an
episode) and stops if it succeeded, else the population, then updates CMA-ES with the returns.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import require

#: fancy_gym's basis functions per output for Meta-World
N_BASIS = 5


@dataclass(frozen=True)
class BlackBoxConfig:
    """budget : episodes at most (the means included). n_basis : basis functions per output.
    popsize : CMA-ES's population (None: cma's default)."""

    budget: int = 1500
    n_basis: int = N_BASIS
    popsize: int | None = None


@dataclass(frozen=True)
class BlackBoxResult:
    """episodes : executed (means and populations). success : the mean succeeded within the budget.
    curve : (episodes so far, mean's error) after each mean's episode. sigma0 : the initial step size."""

    episodes: int
    success: bool
    curve: list
    sigma0: float
    dimension: int


class DemoProMP:
    """The demonstrations' ProMP: ``mp_pytorch``'s ProMP with ``n_basis`` functions per output on
    the phase in [0, 1], the weights of each demonstration (N, D * n_basis) and its task parameters
    (N, P)."""

    def __init__(self, times: np.ndarray, values: np.ndarray, task_params: np.ndarray, n_basis: int = N_BASIS):
        import torch

        MPFactory = require("mp_pytorch.mp", "black-box ProMP + CMA-ES").MPFactory

        values = np.asarray(values, dtype=np.float64)
        n, t, d = values.shape
        self.times = np.asarray(times, dtype=np.float64).reshape(-1)
        if self.times.shape != (t,):
            raise ValueError(f"times: expected ({t},) shared by every demonstration, got {np.shape(times)}")
        self.mp = MPFactory.init_mp("promp", {"num_basis": n_basis, "basis_bandwidth_factor": 3,
                                              "num_basis_outside": 0, "weights_scale": 1.0},
                                    num_dof=d, tau=float(self.times[-1]), dtype=torch.float64)
        t_all = torch.as_tensor(np.tile(self.times, (n, 1)))
        self.weights = self.mp.learn_mp_params_from_trajs(t_all, torch.as_tensor(values))["params"].numpy()
        self.task_params = np.asarray(task_params, dtype=np.float64).reshape(n, -1)

    def conditioned_mean(self, task_params: np.ndarray) -> np.ndarray:
        """(D * n_basis,) the mean weights given ``task_params`` (P,): the joint Gaussian of weights and
        task parameters conditioned on them, ``mu_w + S_wc S_cc^-1 (c - mu_c)``."""
        c = np.asarray(task_params, dtype=np.float64).reshape(-1)
        if c.size == 0:
            return self.weights.mean(axis=0)
        wc = np.cov(np.c_[self.weights, self.task_params].T)
        k = self.weights.shape[1]
        s_wc, s_cc = wc[:k, k:], wc[k:, k:]
        return self.weights.mean(axis=0) + s_wc @ np.linalg.solve(s_cc, c - self.task_params.mean(axis=0))

    def spread(self) -> float:
        """The demonstrations' weight spread: the mean over weights of their standard deviation."""
        return float(np.mean(self.weights.std(axis=0)))

    def trajectories(self, weights: np.ndarray) -> np.ndarray:
        """(B, T, D) the trajectories of weight vectors (B, D * n_basis) on the demonstrations' times."""
        import torch

        w = torch.as_tensor(np.atleast_2d(weights), dtype=torch.float64)
        self.mp.reset()
        self.mp.update_inputs(times=torch.as_tensor(np.tile(self.times, (len(w), 1))), params=w)
        return self.mp.get_traj_pos().numpy()


def run_black_box(promp: DemoProMP, evaluator, task_params: np.ndarray, config: BlackBoxConfig, seed: int,
                  stop_after: float | None = None) -> BlackBoxResult:
    """CMA-ES over ``promp``'s weights at ``task_params`` (P,) until the distribution's mean succeeds
    on ``evaluator`` or ``config.budget`` episodes were executed (a population that would pass the
    budget is cut to what is left)."""
    cma = require("cma", "black-box ProMP + CMA-ES")

    x0 = promp.conditioned_mean(task_params)
    sigma0 = promp.spread()
    opts = {"seed": int(seed) + 1, "verbose": -9}  # cma's seed 0 means "from the clock"
    if config.popsize is not None:
        opts["popsize"] = int(config.popsize)
    es = cma.CMAEvolutionStrategy(x0, sigma0, opts)
    params = np.asarray(task_params, dtype=np.float64)
    used, curve, success = 0, [], False
    while used < config.budget:
        mean = evaluator.evaluate(promp.trajectories(es.mean), promp.times, params)
        used += 1
        curve.append([used, None if mean.errors is None else float(mean.errors[0])])
        if bool(mean.success[0]):
            success = True
            break
        left = config.budget - used
        if left <= 0:
            break
        xs = es.ask()[:left]
        batch = evaluator.evaluate(promp.trajectories(np.array(xs)), promp.times, params)
        used += len(xs)
        if len(xs) == es.popsize:
            es.tell(xs, [-float(r) for r in batch.returns])
    return BlackBoxResult(used, success, curve, sigma0, len(x0))
