"""Black-box ProMP + CMA-ES: the weights of a ProMP as one action, searched by CMA-ES.

fancy_gym's recipe for episodic RL on any Gymnasium environment (Otto et al., "MP3: Movement
Primitive-based (Re-)Planning Policy", 2023; the ALRhub ``fancy_gym`` black-box wrapper): a ProMP
(Paraschos et al., NeurIPS 2013) from ``mp_pytorch`` maps a weight vector to a whole trajectory,
the environment executes it as one episode, and CMA-ES (Hansen 2016, "The CMA Evolution
Strategy: A Tutorial"; the ``cma`` package) searches the weights by the episodes' returns.
fancy_gym's Meta-World setting: 5 radial basis functions per output on a linear phase; the
comparison also runs the count with the lowest leave-one-out error on the demonstrations alone
(:func:`choose_n_basis`), since the count decides how well the ProMP can follow them.

The search starts from the demonstrations' ProMP: the weights of every demonstration (least
squares, ``mp_pytorch``'s ``learn_mp_params_from_trajs``) with their task parameters form a joint
Gaussian; conditioned on the test condition (its task parameters and observed points) it gives the
initial mean (Paraschos et al.'s conditioning, which for task parameters is a linear regression from
them to the weights). The initial step size is the demonstrations' weight spread (the mean of the
weights' standard deviations), the same rule on every task. CMA-ES runs with ``cma``'s defaults
otherwise (population 4 + 3 ln n).

One generation executes the distribution's mean (the method's deterministic output, counted as an
episode) and stops if it succeeded, else the population, then updates CMA-ES with the returns.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.prior import BASIS_CANDIDATES, leave_one_out
from . import require

#: fancy_gym's basis functions per output for Meta-World
N_BASIS = 5


def choose_n_basis(times: np.ndarray, values: np.ndarray, task_params: np.ndarray,
                   candidates: tuple[int, ...] = BASIS_CANDIDATES) -> tuple[int, dict[int, float]]:
    """The basis count of :class:`DemoProMP` with the lowest leave-one-out error on the
    demonstrations alone (times (T,), values (N, T, D), task parameters (N, P)): each held out in
    turn, the ProMP of the others conditioned on its task parameters and start (and, without task
    parameters, its middle and end), as :func:`~acnmp_core.model.prior.leave_one_out` measures it;
    and every candidate's error. Ties go to the fewer basis functions."""
    values = np.asarray(values, dtype=np.float64)
    task_params = np.asarray(task_params, dtype=np.float64).reshape(len(values), -1)
    times = np.asarray(times, dtype=np.float64).reshape(-1)

    def error(n_basis: int) -> float:
        def predict(rest: list[int], k: int, marks: list[int]) -> np.ndarray:
            promp = DemoProMP(times, values[rest], task_params[rest], n_basis)
            w = promp.conditioned_mean(task_params[k], times[marks], values[k][marks])
            return promp.trajectories(w[None])[0]

        return leave_one_out(values, task_params, predict)

    errors = {int(c): error(int(c)) for c in sorted(candidates)}
    return min(errors, key=lambda c: (round(errors[c], 12), c)), errors


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
    curve : (episodes so far, mean's error) after each mean's episode. sigma0 : the initial step size.
    dimension : the weights searched. start : (T, D) the trajectory the search started from (the
    conditioned ProMP's mean)."""

    episodes: int
    success: bool
    curve: list
    sigma0: float
    dimension: int
    start: np.ndarray


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
        # the fit's residual variance per output: how closely a conditioned mean can pass a point
        fit = self.trajectories(self.weights)
        self.noise = np.maximum(((fit - values) ** 2).mean(axis=(0, 1)), 1e-10)

    def conditioned_mean(self, task_params: np.ndarray | None = None, obs_times: np.ndarray | None = None,
                         obs_values: np.ndarray | None = None) -> np.ndarray:
        """(D * n_basis,) the mean weights given ``task_params`` (P,) and observed points ``obs_values``
        (M, D) at ``obs_times`` (M,): the joint Gaussian of the demonstrations' weights and task
        parameters conditioned on them (Paraschos et al. 2018), ``mu + S H^T (H S H^T + R)^-1 (y - H mu)``
        with ``H`` the basis at the observed times and the identity on the task parameters, ``R``
        the demonstrations' fit residual for the points and zero for the parameters (a
        pseudo-inverse: parameters the demonstrations vary together, such as a goal set by an
        object and a direction, are not independent). Without task parameters or points: the
        demonstrations' mean weights."""
        n, k = self.weights.shape
        c = np.zeros(0) if task_params is None else np.asarray(task_params, dtype=np.float64).reshape(-1)
        z = np.c_[self.weights, self.task_params] if c.size else self.weights
        mu, cov = z.mean(axis=0), np.atleast_2d(np.cov(z.T))
        rows, ys, noise = [], [], []
        if c.size:
            rows.append(np.c_[np.zeros((c.size, k)), np.eye(c.size)])
            ys.append(c)
            noise.append(np.zeros(c.size))
        if obs_times is not None and len(obs_times):
            design = self.design(np.asarray(obs_times, dtype=np.float64))  # (M*D, k)
            rows.append(np.c_[design, np.zeros((len(design), z.shape[1] - k))])
            ys.append(np.asarray(obs_values, dtype=np.float64).reshape(-1))
            noise.append(np.tile(self.noise, len(obs_times)))
        if not rows:
            return mu[:k]
        h, y = np.vstack(rows), np.concatenate(ys)
        gram = h @ cov @ h.T + np.diag(np.concatenate(noise))
        return (mu + cov @ h.T @ np.linalg.pinv(gram, rcond=1e-10, hermitian=True) @ (y - h @ mu))[:k]

    def design(self, times: np.ndarray) -> np.ndarray:
        """(M * D, D * n_basis) the linear map from weights to the trajectory's values at ``times``
        (M,), rows time-major: ``mp_pytorch``'s own basis, read off by evaluating unit weights."""
        unit = self.trajectories_at(np.eye(self.weights.shape[1]), times)  # (D*K, M, D)
        return unit.reshape(len(unit), -1).T

    def spread(self) -> float:
        """The demonstrations' weight spread: the mean over weights of their standard deviation."""
        return float(np.mean(self.weights.std(axis=0)))

    def trajectories(self, weights: np.ndarray) -> np.ndarray:
        """(B, T, D) the trajectories of weight vectors (B, D * n_basis) on the demonstrations' times."""
        return self.trajectories_at(weights, self.times)

    def trajectories_at(self, weights: np.ndarray, times: np.ndarray) -> np.ndarray:
        """(B, M, D) the trajectories of weight vectors (B, D * n_basis) at ``times`` (M,)."""
        import torch

        w = torch.as_tensor(np.atleast_2d(weights), dtype=torch.float64)
        self.mp.reset()
        self.mp.update_inputs(times=torch.as_tensor(np.tile(np.asarray(times, dtype=np.float64), (len(w), 1))),
                              params=w)
        return self.mp.get_traj_pos().numpy()


def run_black_box(promp: DemoProMP, evaluator, target, config: BlackBoxConfig, seed: int) -> BlackBoxResult:
    """CMA-ES over ``promp``'s weights at ``target`` (an :class:`~acnmp_core.adaptation.config.AdaptTarget`:
    the task parameters and observed points the ProMP is conditioned on, and the times the
    trajectories are executed at) until the distribution's mean succeeds on ``evaluator`` or
    ``config.budget`` episodes were executed (a population that would pass the budget is cut to
    what is left)."""
    cma = require("cma", "black-box ProMP + CMA-ES")

    params = None if target.task_params is None else np.asarray(target.task_params, dtype=np.float64)
    x0 = promp.conditioned_mean(params, target.obs_times, target.obs_values)
    times = np.asarray(target.query_times, dtype=np.float64)
    sigma0 = promp.spread()
    opts = {"seed": int(seed) + 1, "verbose": -9}  # cma's seed 0 means "from the clock"
    if config.popsize is not None:
        opts["popsize"] = int(config.popsize)
    es = cma.CMAEvolutionStrategy(x0, sigma0, opts)
    used, curve, success = 0, [], False
    while used < config.budget:
        mean = evaluator.evaluate(promp.trajectories_at(es.mean, times), times, params)
        used += 1
        curve.append([used, None if mean.errors is None else float(mean.errors[0])])
        if bool(mean.success[0]):
            success = True
            break
        left = config.budget - used
        if left <= 0:
            break
        xs = es.ask()[:left]
        batch = evaluator.evaluate(promp.trajectories_at(np.array(xs), times), times, params)
        used += len(xs)
        if len(xs) == es.popsize:
            es.tell(xs, [-float(r) for r in batch.returns])
    return BlackBoxResult(used, success, curve, sigma0, len(x0), promp.trajectories_at(x0, times)[0])
